// e2e_more.h: more end-to-end helpers: a virtual board stopped on demand, motor config and
// control payloads, board-clock polling, line garbage and trace queries for the safety tests.
#ifndef STEPCHOIR_TESTS_E2E_MORE_H
#define STEPCHOIR_TESTS_E2E_MORE_H

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "analysis.h"
#include "board/board.h"
#include "config/config.h"
#include "e2e_util.h"
#include "trace.h"


namespace e2e {

// The virtual board as a child process; stop() ends it with SIGTERM and returns its status.
using StoppableVboard = VboardProcess;

// A ConfigBody for `motor`: A4988 at 16 microsteps, switches active low (the vboard's default),
// the full period range, no onset ramp, 2 us pulses, and the given travel.
inline sc::ConfigBody motor_config(uint8_t motor, uint32_t travel_steps) {
  sc::ConfigBody c = stepchoir::default_motor_hardware(motor);
  c.travel_steps = travel_steps;
  return c;
}

// A kMsgWatchdog payload: timeout in ms, 0 = off.
inline std::vector<uint8_t> watchdog_payload(uint16_t ms) { return stepchoir::watchdog_payload(ms); }

// A set-period payload for one motor (period 0 = silence).
inline std::vector<uint8_t> tone_payload(uint8_t motor, uint32_t period_q8) {
  return stepchoir::periods_payload({{motor, period_q8}});
}

// Writes several payloads as frames in one write, so they reach the board back to back.
inline void send_back_to_back(stepchoir::Board &b, const std::vector<std::vector<uint8_t>> &payloads) {
  std::vector<uint8_t> wire;
  for (const auto &p : payloads) {
    const auto f = stepchoir::frame(p);
    wire.insert(wire.end(), f.begin(), f.end());
  }
  if (!b.link().write(wire.data(), wire.size())) throw std::runtime_error("write failed");
}

// Waits for the clock reply carrying `seq` (earlier clock replies are skipped); its ticks.
inline uint32_t clock_reply(stepchoir::Board &b, uint8_t seq, int timeout_ms = 5000) {
  for (;;) {
    auto r = b.wait_reply(sc::kMsgClock, timeout_ms);
    if (!r) throw std::runtime_error("no clock reply for seq " + std::to_string(seq));
    if (r->size() >= 6 && (*r)[1] == seq) return sc::get_u32(&(*r)[2]);
  }
}

// Reads frames straight from the link until `count` frames of type `type` have arrived and
// returns them in order. Unlike Board::wait_reply, which drops whatever else came in the
// same read, it loses no reply that arrives right behind another. Throws on timeout.
inline std::vector<std::vector<uint8_t>> read_replies(stepchoir::Board &b, uint8_t type, size_t count,
                                                     int timeout_ms = 5000) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  sc::FrameDecoder dec;
  std::vector<std::vector<uint8_t>> out;
  uint8_t buf[256];
  while (out.size() < count) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(give_up - std::chrono::steady_clock::now()).count();
    if (left <= 0)
      throw std::runtime_error("got " + std::to_string(out.size()) + " of " + std::to_string(count) +
                               " replies of type " + std::to_string(type));
    const long n = b.link().read(buf, sizeof buf, static_cast<int>(left));
    if (n < 0) throw std::runtime_error("read failed");
    for (long i = 0; i < n; ++i)
      if (dec.push(buf[i]) == sc::kFrameOk && dec.payload()[0] == type)
        out.emplace_back(dec.payload(), dec.payload() + dec.payload_len());
  }
  return out;
}

// Polls the board clock (every 2 ms of wall time) until it reaches target_ticks; returns the
// last clock read. The clock requests are frames, so they also keep the watchdog fed.
inline uint32_t wait_board_time(stepchoir::Board &b, uint32_t target_ticks, int wall_limit_ms = 60000) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(wall_limit_ms);
  for (uint8_t seq = 0x60;; ++seq) {
    b.send({sc::kMsgClockReq, seq});
    const uint32_t now = clock_reply(b, seq);
    if (static_cast<int32_t>(now - target_ticks) >= 0) return now;
    if (std::chrono::steady_clock::now() > give_up)
      throw std::runtime_error("board time never reached " + std::to_string(target_ticks));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

// Starts `motor` at period_q8 with an `at` frame lead_s ahead of the board clock (the motor
// must be silent: its first step then falls exactly on the returned board time). The lead
// covers the host's round trip when the simulation runs unpaced on a busy machine (a frame
// that comes after its time is played at once, and the note then starts late).
inline uint32_t start_note_at(stepchoir::Board &b, uint8_t motor, uint32_t period_q8, uint32_t f_cpu_hz,
                              double lead_s = 0.05) {
  const uint32_t at = board_ticks(b, 0x5a) + static_cast<uint32_t>(lead_s * f_cpu_hz);
  b.send(at_payload(at, {{motor, period_q8}}));
  return at;
}

// Trace cycles minus board ticks, from a note started with start_note_at: its first step
// rose on board time at_ticks. 0 when board ticks count CPU cycles from power-up.
inline int64_t cycle_offset(const sc::trace::MotorTrace &m, uint32_t at_ticks) {
  if (m.steps.empty()) throw std::runtime_error("cycle_offset: the note left no step in the trace");
  return static_cast<int64_t>(m.steps.front().rise_cycle) - static_cast<int64_t>(at_ticks);
}

// The same from a note's first `edges` steps on its grid (the k-th due at at_ticks +
// floor(k * period_q8 / 256)): their median offset, which one edge held up by an interrupt
// (up to about 2 us) does not move.
inline int64_t grid_cycle_offset(const sc::trace::MotorTrace &m, uint32_t at_ticks, uint32_t period_q8,
                                 size_t edges = 41) {
  if (m.steps.empty()) throw std::runtime_error("grid_cycle_offset: the note left no step in the trace");
  std::vector<uint64_t> rises;
  for (size_t k = 0; k < m.steps.size() && k < edges; ++k) rises.push_back(m.steps[k].rise_cycle);
  // against the grid from the first edge, then the first edge against at_ticks
  std::vector<double> r = sc::trace::commanded_grid_residuals_cycles(rises, rises.front(), period_q8);
  std::nth_element(r.begin(), r.begin() + std::ptrdiff_t(r.size() / 2), r.end());
  return cycle_offset(m, at_ticks) + static_cast<int64_t>(std::llround(r[r.size() / 2]));
}

// Board ticks for a duration in seconds.
inline uint32_t ticks_for(double seconds, uint32_t f_cpu_hz) { return static_cast<uint32_t>(seconds * f_cpu_hz); }

// `n` bytes of line garbage from a fixed seed: the first half uniform random bytes (mostly
// over-long frames), the second half random bytes with a 0x00 about every 16 bytes (many
// short frames that reach the COBS, length and CRC checks).
inline std::vector<uint8_t> garbage_bytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> out(n);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t byte = static_cast<uint8_t>(rng());
    out[i] = (i >= n / 2 && rng() % 16 == 0) ? 0 : byte;
  }
  return out;
}

// Cycles of the switch presses (logical endstop changes to 1) of one motor.
inline std::vector<uint64_t> press_cycles(const sc::trace::MotorTrace &m) {
  std::vector<uint64_t> out;
  for (const auto &e : m.endstop_changes)
    if (e.value == 1) out.push_back(e.cycle);
  return out;
}

// The first ENABLE change of a motor at or after `cycle` to `level`, or nullptr.
inline const sc::trace::LevelChange *first_enable_change(const sc::trace::MotorTrace &m, uint64_t cycle,
                                                          uint8_t level) {
  for (const auto &e : m.enables)
    if (e.cycle >= cycle && e.value == level) return &e;
  return nullptr;
}

// One note a motor sounded in a trace: its start and end (s, the trace's real time) and its
// pitch (fractional MIDI note) from the mean interval of its STEP edges in real time.
struct Sounded {
  size_t motor;
  double start_s, end_s, pitch;
};

// Every note of every motor of t, motor by motor (sc::trace::segment_notes' split).
inline std::vector<Sounded> sounded_notes(const sc::trace::Trace &t) {
  std::vector<Sounded> out;
  for (size_t m = 0; m < t.motor.size(); ++m)
    for (const auto &seg : sc::trace::segment_notes(t.motor[m].steps, t.f_cpu_hz)) {
      const double start_s = t.real_seconds(seg.start_cycle), end_s = t.real_seconds(seg.end_cycle);
      const double hz = static_cast<double>(seg.last_step - seg.first_step) / (end_s - start_s);
      out.push_back({m, start_s, end_s, 69.0 + 12.0 * std::log2(hz / 440.0)});
    }
  return out;
}

// Reads t's notes (sounded_notes) and lists them as Catch messages, shown when a check fails.
inline std::vector<Sounded> sounded_notes_logged(const sc::trace::Trace &t) {
  std::vector<Sounded> out = sounded_notes(t);
  for (const Sounded &n : out)
    UNSCOPED_INFO("motor " << n.motor << ": " << n.pitch << " from " << n.start_s << " s to " << n.end_s << " s");
  return out;
}

// The last note motor m sounded within half a semitone of pitch; nullptr when none.
inline const Sounded *find_sounded(const std::vector<Sounded> &notes, size_t motor, int pitch) {
  const Sounded *found = nullptr;
  for (const Sounded &s : notes)
    if (s.motor == motor && std::fabs(s.pitch - pitch) < 0.5) found = &s;
  return found;
}

}  // namespace e2e

#endif  // STEPCHOIR_TESTS_E2E_MORE_H
