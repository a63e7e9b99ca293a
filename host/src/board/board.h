// board.h: one board on the far end of a Link: frames out, replies in, decoded.
#ifndef STEPCHOIR_HOST_BOARD_H
#define STEPCHOIR_HOST_BOARD_H

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "board/link.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

// kMsgCaps, decoded.
struct Caps {
  uint8_t protocol_version = 0;
  uint8_t motor_count = 0;
  uint32_t f_cpu_hz = 0;
  uint8_t queue_size = 0;
  std::vector<uint8_t> endstops;  // per motor: sc::kEndstopMin | kEndstopMax | kEndstopShared
  std::string board_name;
};

// kMsgStatus, decoded.
struct Status {
  sc::StatusHead head{};
  std::vector<sc::StatusMotor> motors;
};

// kMsgError, decoded.
struct BoardError {
  uint8_t code = 0, type = 0, detail = 0;
};

// Decoders for reply payloads (type byte included). Throw std::runtime_error naming the
// message type and what is wrong.
Caps parse_caps(const uint8_t *p, size_t len);
Status parse_status(const uint8_t *p, size_t len);

// Encodes a payload into a wire frame.
std::vector<uint8_t> frame(const std::vector<uint8_t> &payload);

// A payload of set-period entries (a chord), from (motor, period_q8) pairs.
std::vector<uint8_t> periods_payload(const std::vector<sc::PeriodEntry> &entries);

// A kMsgAt payload: the entries take effect at board time at_ticks.
std::vector<uint8_t> at_payload(uint32_t at_ticks, const std::vector<sc::PeriodEntry> &entries);

// A kMsgWatchdog payload: silence after ms without a frame (0 = never).
std::vector<uint8_t> watchdog_payload(uint16_t ms);

// A kMsgConfig payload.
std::vector<uint8_t> config_payload(const sc::ConfigBody &c);

// A kMsgDriver payload: one driver's SLEEP and RESET pins, idle power-down and wake time.
std::vector<uint8_t> driver_payload(const sc::DriverBody &d);

// A kMsgDriverAct payload: motor's driver woken, put to sleep, disabled or reset
// (sc::DriverAction).
std::vector<uint8_t> driver_act_payload(uint8_t motor, uint8_t action);

// A kMsgMove payload, and a kMsgSetPosition payload: motor's counted position (steps).
std::vector<uint8_t> move_payload(const sc::MoveBody &b);
std::vector<uint8_t> set_position_payload(uint8_t motor, int32_t position);

// A kMsgSilence payload: these motors silent now, their timed entries dropped.
std::vector<uint8_t> silence_payload(const std::vector<uint8_t> &motors);

// Synchronous session with one board (used by the short commands: hello, tone, panic).
// Called from: one thread. Blocks on I/O with the given timeouts.
class Board {
 public:
  explicit Board(std::unique_ptr<Link> link) : link_(std::move(link)) {}

  // Sends a payload as one frame; throws on a failed port.
  void send(const std::vector<uint8_t> &payload);

  // Sends one delimiter, so the board drops any partial frame left from before.
  void resync();

  // Waits for the next reply of `type`; replies of other types are skipped (errors are kept in
  // errors()), bytes after it are kept for the next call.
  std::optional<std::vector<uint8_t>> wait_reply(uint8_t type, int timeout_ms);

  // Asks for capabilities, retrying a few times; throws when the board never answers.
  Caps hello(int timeout_ms = 1500);

  // The first exchange on a port just opened. An Uno or a Mega resets when its port opens (DTR)
  // and its bootloader holds it up to about 1.4 s, losing what the host sends meanwhile (a
  // Mega's stays in it while bytes keep coming): so this only listens, up to boot_wait_ms, for
  // the capabilities the firmware sends unasked when it starts; without them (a board that did
  // not reset) it asks with hello(hello_timeout_ms). Throws when the board never answers.
  Caps greet(int boot_wait_ms = kBootWaitMs, int hello_timeout_ms = 1500);
  // Longer than either bootloader holds the board when no byte comes
  // (tools/vboard/src/board_config.cpp).
  static constexpr int kBootWaitMs = 2000;
  // Capabilities that come sooner than this after the open are stale (shorter than any
  // bootloader, longer than any bridge holds bytes).
  static constexpr int kStaleMs = 100;
  // A board asked for something every second or more often that sent nothing for this long
  // has stopped answering: a Mega reset with its link up stays in its bootloader while bytes
  // keep coming (live's BoardStats::heard_us, the song player's).
  static constexpr int kSilentMs = 3500;
  // How long the host then sends nothing and listens for the capabilities the firmware sends
  // as it starts: a Mega's bootloader that bytes reached starts it 5.0 s after the last one
  // (tools/vboard/src/board_config.cpp).
  static constexpr int kQuietWaitMs = 6500;

  // Asks for status; nullopt on timeout.
  std::optional<Status> status(int timeout_ms = 500);

  // Errors the board reported so far.
  const std::vector<BoardError> &errors() const { return errors_; }

  Link &link() { return *link_; }

 private:
  std::unique_ptr<Link> link_;
  sc::FrameDecoder decoder_;
  std::vector<uint8_t> pending_;  // bytes read but not yet decoded
  size_t pending_pos_ = 0;
  std::vector<BoardError> errors_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_BOARD_H
