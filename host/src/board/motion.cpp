// motion.cpp: see motion.h.
#include "board/motion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace stepchoir {
namespace {

// While a motor moves the host heartbeats this often, plus its loop's time: a sixth of the
// firmware's watchdog, so that a virtual board run at twice real time still gets one every
// 100 ms of its own time, a third of the watchdog.
constexpr int kMoveHeartbeatMs = sc::kWatchdogDefaultMs / 6;

// A speed in mm/s as the board's steps/s, within what a move may take.
uint16_t steps_per_s(double mm_per_s, const MotionSettings &ms) {
  const double v = std::round(mm_per_s * ms.steps_per_mm);
  return static_cast<uint16_t>(std::clamp(v, double(sc::kMoveSpeedMin), double(sc::kMoveSpeedMax)));
}

std::string motor_name(const std::string &port, uint8_t motor) { return port + ": motor " + std::to_string(motor); }

// The longest a move of `steps` may take (s): every step at the ramp's slowest speed, and 2 s
// for the link and the start.
double move_seconds(uint32_t steps, uint16_t v_min) { return 2.0 + double(steps) / v_min; }

}  // namespace

std::string mm_text(double steps, const MotionSettings &ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f mm", steps / ms.steps_per_mm);
  return buf;
}

MoveResult move_motor(Board &board, const std::string &port, uint8_t motor, int64_t steps, double speed,
                      const MotionSettings &ms, bool to_switch) {
  MoveResult r;
  if (steps == 0) return r;
  sc::MoveBody b{};
  b.motor = motor;
  b.flags = static_cast<uint8_t>((steps > 0 ? sc::kMoveUp : 0) | (to_switch ? sc::kMoveToSwitch : 0));
  const uint64_t n = static_cast<uint64_t>(std::llabs(steps));
  if (n > sc::kMaxTravelSteps) throw std::runtime_error(motor_name(port, motor) + ": a move of " + std::to_string(n) + " steps is too long");
  b.steps = static_cast<uint32_t>(n);
  b.speed_max = steps_per_s(speed, ms);
  b.speed_min = std::min(b.speed_max, steps_per_s(ms.min_speed, ms));
  b.accel = static_cast<uint32_t>(std::clamp(std::round(ms.acceleration * ms.steps_per_mm), 1.0, double(sc::kMoveAccelMax)));
  const size_t errors_before = board.errors().size();
  board.send(move_payload(b));
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + std::chrono::duration_cast<clock::duration>(
                                           std::chrono::duration<double>(move_seconds(b.steps, b.speed_min)));
  for (;;) {
    const auto reply = board.wait_reply(sc::kMsgMoveDone, kMoveHeartbeatMs);
    for (size_t i = errors_before; i < board.errors().size(); ++i) {
      const BoardError &e = board.errors()[i];
      if (e.type == sc::kMsgMove || e.type == sc::kMsgHeartbeat)
        throw std::runtime_error(motor_name(port, motor) + ": the board refused the move: " + sc::error_name(e.code) +
                                 (e.code == sc::kErrUnknownType ? " (its firmware is older than this program: flash this version's)"
                                  : e.code == sc::kErrBusy      ? " (the motor is playing or moving)"
                                                                : ""));
    }
    if (reply) {
      sc::MoveDoneBody d{};
      if (!sc::get_move_done(reply->data(), static_cast<uint8_t>(reply->size()), &d) || d.motor != motor) continue;
      if (d.end == sc::kMoveEndStopped)
        throw std::runtime_error(motor_name(port, motor) + ": the move was stopped (stop-all or the watchdog) after " +
                                 std::to_string(d.steps) + " steps");
      r.end = d.end;
      r.position = d.position;
      r.steps = d.steps;
      return r;
    }
    if (clock::now() > deadline) {
      board.send({sc::kMsgStopAll});
      throw std::runtime_error(motor_name(port, motor) + ": the move did not end in time: every motor stopped");
    }
    board.send({sc::kMsgHeartbeat});  // keeps the watchdog fed while the motor moves (every kMoveHeartbeatMs)
  }
}

HomeResult home_motor(Board &board, const Caps &caps, const std::string &port, uint8_t motor,
                      uint32_t travel_steps, const MotionSettings &ms, const std::function<void(const std::string &)> &say) {
  const std::string name = motor_name(port, motor);
  const uint8_t ends = motor < caps.endstops.size() ? caps.endstops[motor] : 0;
  if (!(ends & (sc::kEndstopMin | sc::kEndstopMax)))
    throw std::runtime_error(name + " has no end switch: move its carriage to the middle with `stepchoir jog`, then "
                             "declare it there with `stepchoir center`");
  if (travel_steps == 0) throw std::runtime_error(name + ": homing needs its travel_steps in the configuration");
  const bool both = (ends & sc::kEndstopShared) || ((ends & sc::kEndstopMin) && (ends & sc::kEndstopMax));
  const int dir = (ends & sc::kEndstopMin) ? -1 : 1;  // toward the first switch
  const int64_t search = int64_t(travel_steps) + travel_steps / 4;
  const int64_t backoff = std::max<int64_t>(1, std::llround(ms.backoff_mm * ms.steps_per_mm));
  const char *first = dir < 0 ? "min" : "max";
  // Touches the switch toward `d`, at `speed` within `limit` steps; throws if it never fires.
  auto touch = [&](int d, double speed, int64_t limit, const char *which) {
    const MoveResult r = move_motor(board, port, motor, d * limit, speed, ms, true);
    if (r.end != sc::kMoveEndSwitch)
      throw std::runtime_error(name + ": the " + std::string(which) + " switch did not fire within " +
                               std::to_string(limit) + " steps (" + mm_text(double(limit), ms) +
                               "): the motor stopped. Is the switch wired, and travel_steps right?");
    return r;
  };
  touch(dir, ms.home_speed, search, first);
  move_motor(board, port, motor, -dir * backoff, ms.home_speed, ms, false);
  touch(dir, ms.home_speed / 4, 2 * backoff, first);
  const int32_t origin = dir < 0 ? 0 : int32_t(travel_steps);
  board.send(set_position_payload(motor, origin));
  say(name + ": " + first + " switch found, position " + std::to_string(origin));
  HomeResult h;
  h.travel_steps = int32_t(travel_steps);
  move_motor(board, port, motor, -dir * backoff, ms.home_speed, ms, false);
  if (both) {
    const MoveResult far = touch(-dir, ms.home_speed, search, dir < 0 ? "max" : "min");
    h.travel_steps = std::abs(far.position - origin);
    h.measured = true;
    if (dir > 0) board.send(set_position_payload(motor, 0));  // positions count from the min end
    say(name + ": " + (dir < 0 ? "max" : "min") + " switch found: travel " + std::to_string(h.travel_steps) +
        " steps (" + mm_text(h.travel_steps, ms) + ")");
    move_motor(board, port, motor, dir * backoff, ms.home_speed, ms, false);
  }
  const auto s = board.status(1000);
  if (!s || motor >= s->motors.size()) throw std::runtime_error(name + ": no status reply");
  h.middle = h.travel_steps / 2;
  move_motor(board, port, motor, int64_t(h.middle) - s->motors[motor].position_steps, ms.max_speed, ms, false);
  say(name + ": in the middle, position " + std::to_string(h.middle));
  return h;
}

}  // namespace stepchoir
