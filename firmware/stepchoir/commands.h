// commands.h: frames in, actions out. One handler per message type, the timestamped queue,
// the watchdog and the status counters. Pure logic over hal.h, built for the AVR and the host.
#ifndef STEPCHOIR_COMMANDS_H
#define STEPCHOIR_COMMANDS_H

#include <stdint.h>

#include "config.h"
#include "hal.h"
#include "src/stepchoir_protocol.h"

namespace cmd {

// Per-motor limits the host configured (periods in ticks q8).
struct MotorLimits {
  uint32_t min_period_q8;
  uint32_t max_period_q8;
};

class Commands {
 public:
  // Called from: setup(). Defaults: every motor allowed kPeriodQ8Min..kPeriodQ8Max.
  void init();

  // Called from: setup(), last. Sends the capabilities unasked: a host that opened the port
  // (which resets an Uno or a Mega) waits for them rather than send into the bootloader.
  void announce() { reply_caps(sc::kCapsAnnounced); }

  // Called from: main loop (take_bytes in stepchoir.ino; tests, fuzzing), for each byte
  // received. Decodes frames and runs their handlers. Inlined: a byte costs about 60 cycles
  // (the line brings one every 160), so the loop keeps up with the line and a frame is handled
  // right after its last byte.
  void on_byte(uint8_t byte) {
    const uint8_t rc = decoder_.push(byte);
    if (rc != sc::kFrameNone) on_frame(rc);
  }

  // Called from: main loop. True while a frame's bytes are coming in (its delimiter not yet).
  bool in_frame() const { return decoder_.in_frame(); }

  // Called from: main loop, often. Runs the watchdog, reports late entries and ended moves.
  void poll();

  // Counters, for the status reply and the tests.
  uint32_t frames_ok() const { return frames_ok_; }
  uint16_t frames_bad() const { return frames_bad_; }
  uint8_t last_error() const { return last_error_; }
  uint8_t queue_used() const { return hal::queue_used(); }
  // True from a watchdog stop until the next set-period, at or reset-counters frame.
  bool watchdog_tripped() const { return watchdog_tripped_; }

 private:
  // Called from: on_byte(s), when the decoder ended a frame (rc: sc::kFrameOk or its error).
  void on_frame(uint8_t rc);
  // Runs one frame's handler; returns sc::kErrNone or the error it was refused with.
  uint8_t handle(const uint8_t *p, uint8_t len);
  uint8_t handle_periods(const uint8_t *p, uint8_t len);
  uint8_t handle_at(const uint8_t *p, uint8_t len);
  uint8_t handle_config(const uint8_t *p, uint8_t len);
  uint8_t handle_driver(const uint8_t *p, uint8_t len);
  uint8_t handle_driver_act(const uint8_t *p, uint8_t len);
  uint8_t handle_set_id(const uint8_t *body, uint8_t n);
  uint8_t handle_move(const uint8_t *p, uint8_t len);
  uint8_t handle_set_position(const uint8_t *p, uint8_t len);
  void reply_id();
  uint8_t check_entry(const sc::PeriodEntry &e) const;
  void reply_caps(uint8_t flags);  // flags: CapsBody::flags
  void reply_status();
  void reply_clock(uint8_t seq);
  void reply_error(uint8_t code, uint8_t type, uint8_t detail);
  void fault(uint8_t code) { last_error_ = code; }

  sc::FrameDecoder decoder_;
  MotorLimits limits_[sc::kMaxMotors];
  uint32_t frames_ok_ = 0;
  uint16_t frames_bad_ = 0;
  uint8_t last_error_ = 0;
  uint32_t last_frame_ticks_ = 0;
  bool frame_seen_ = false;  // a good frame since the last poll(): it restarts the watchdog
  uint32_t watchdog_ticks_ = 0;  // 0 = off
  bool watchdog_tripped_ = false;
  uint16_t seen_overruns_ = 0;  // UART overrun count last looked at
  uint8_t seen_late_ = 0;       // hal::late_entries() count last looked at
};

// Watchdog time in ticks for a timeout in ms at the board's F_CPU (no division at run time
// beyond this one multiply, done when the host changes it).
inline uint32_t ms_to_ticks(uint16_t ms, uint32_t f_cpu_hz) { return (uint32_t)ms * (f_cpu_hz / 1000u); }

}  // namespace cmd

#endif  // STEPCHOIR_COMMANDS_H
