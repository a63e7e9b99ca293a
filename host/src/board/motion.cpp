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

namespace {

// "PORT: motor 2" or "PORT: motors 0, 1 and 2".
std::string motors_name(const std::string &port, const std::vector<uint8_t> &motors) {
  if (motors.size() == 1) return motor_name(port, motors[0]);
  std::string text = port + ": motors ";
  for (size_t i = 0; i < motors.size(); ++i)
    text += (i == 0 ? "" : i + 1 == motors.size() ? " and " : ", ") + std::to_string(motors[i]);
  return text;
}

// The move body of an order (steps not 0).
sc::MoveBody move_body(const std::string &port, const MoveOrder &o) {
  sc::MoveBody b{};
  b.motor = o.motor;
  b.flags = static_cast<uint8_t>((o.steps > 0 ? sc::kMoveUp : 0) | (o.to_switch ? sc::kMoveToSwitch : 0));
  const uint64_t n = static_cast<uint64_t>(std::llabs(o.steps));
  if (n > sc::kMaxTravelSteps)
    throw std::runtime_error(motor_name(port, o.motor) + ": a move of " + std::to_string(n) + " steps is too long");
  b.steps = static_cast<uint32_t>(n);
  b.speed_max = steps_per_s(o.speed, o.ms);
  b.speed_min = std::min(b.speed_max, steps_per_s(o.ms.min_speed, o.ms));
  b.accel = static_cast<uint32_t>(std::clamp(std::round(o.ms.acceleration * o.ms.steps_per_mm), 1.0, double(sc::kMoveAccelMax)));
  return b;
}

}  // namespace

std::vector<MoveResult> move_motors(Board &board, const std::string &port, const std::vector<MoveOrder> &orders) {
  std::vector<MoveResult> results(orders.size());
  std::vector<sc::MoveBody> bodies;
  std::vector<size_t> waiting;  // orders whose move-done has not come
  double longest_s = 0;
  for (size_t i = 0; i < orders.size(); ++i) {
    if (orders[i].steps == 0) continue;
    bodies.push_back(move_body(port, orders[i]));
    waiting.push_back(i);
    longest_s = std::max(longest_s, move_seconds(bodies.back().steps, bodies.back().speed_min));
  }
  if (waiting.empty()) return results;
  std::vector<uint8_t> motors;
  for (size_t i : waiting) motors.push_back(orders[i].motor);
  const size_t errors_before = board.errors().size();
  for (const sc::MoveBody &b : bodies) board.send(move_payload(b));
  // Stops every motor when some other than the ones that ended may still move, and throws.
  const auto fail = [&](const std::string &what) {
    if (!waiting.empty()) board.send({sc::kMsgStopAll});
    throw std::runtime_error(what);
  };
  using clock = std::chrono::steady_clock;
  const auto deadline =
      clock::now() + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(longest_s));
  while (!waiting.empty()) {
    const auto reply = board.wait_reply(sc::kMsgMoveDone, kMoveHeartbeatMs);
    for (size_t i = errors_before; i < board.errors().size(); ++i) {
      const BoardError &e = board.errors()[i];
      if (e.type == sc::kMsgMove || e.type == sc::kMsgHeartbeat)
        fail(motors_name(port, motors) + ": the board refused the move: " + sc::error_name(e.code) +
             (e.code == sc::kErrUnknownType ? " (its firmware is older than this program: flash this version's)"
              : e.code == sc::kErrBusy      ? " (the motor is playing or moving)"
                                            : ""));
    }
    if (reply) {
      sc::MoveDoneBody d{};
      if (!sc::get_move_done(reply->data(), static_cast<uint8_t>(reply->size()), &d)) continue;
      const auto it = std::find_if(waiting.begin(), waiting.end(), [&](size_t i) { return orders[i].motor == d.motor; });
      if (it == waiting.end()) continue;
      const size_t i = *it;
      waiting.erase(it);
      if (d.end == sc::kMoveEndStopped)
        fail(motor_name(port, d.motor) + ": the move was stopped (stop-all or the watchdog) after " +
             std::to_string(d.steps) + " steps");
      results[i].end = d.end;
      results[i].position = d.position;
      results[i].steps = d.steps;
      continue;
    }
    if (clock::now() > deadline) {
      std::vector<uint8_t> late;
      for (size_t i : waiting) late.push_back(orders[i].motor);
      fail(motors_name(port, late) + ": the move did not end in time: every motor stopped");
    }
    board.send({sc::kMsgHeartbeat});  // keeps the watchdog fed while motors move (every kMoveHeartbeatMs)
  }
  return results;
}

MoveResult move_motor(Board &board, const std::string &port, uint8_t motor, int64_t steps, double speed,
                      const MotionSettings &ms, bool to_switch) {
  return move_motors(board, port, {MoveOrder{motor, steps, speed, ms, to_switch}})[0];
}

std::vector<HomeResult> home_motors(Board &board, const Caps &caps, const std::string &port,
                                    const std::vector<HomeJob> &jobs, const std::function<void(const std::string &)> &say) {
  // Each motor's switches, as caps has them, and the stages' figures.
  struct Homing {
    std::string name;
    bool both = false;   // a switch at each end (or one input for both)
    int dir = 0;         // toward the first switch: -1 min, +1 max
    int64_t search = 0;  // the longest run to a switch, steps
    int64_t backoff = 0;
    int32_t origin = 0;  // the first switch's position
  };
  std::vector<Homing> hs;
  for (const HomeJob &j : jobs) {
    Homing h;
    h.name = motor_name(port, j.motor);
    const uint8_t ends = j.motor < caps.endstops.size() ? caps.endstops[j.motor] : 0;
    if (!(ends & (sc::kEndstopMin | sc::kEndstopMax)))
      throw std::runtime_error(h.name + " has no end switch: move its carriage to the middle with `stepchoir jog`, then "
                               "declare it there with `stepchoir center`");
    if (j.travel_steps == 0) throw std::runtime_error(h.name + ": homing needs its travel_steps in the configuration");
    h.both = (ends & sc::kEndstopShared) || ((ends & sc::kEndstopMin) && (ends & sc::kEndstopMax));
    h.dir = (ends & sc::kEndstopMin) ? -1 : 1;
    h.search = int64_t(j.travel_steps) + j.travel_steps / 4;
    h.backoff = std::max<int64_t>(1, std::llround(j.ms.backoff_mm * j.ms.steps_per_mm));
    h.origin = h.dir < 0 ? 0 : int32_t(j.travel_steps);
    hs.push_back(h);
  }
  std::vector<HomeResult> out(jobs.size());
  for (size_t i = 0; i < jobs.size(); ++i) out[i].travel_steps = int32_t(jobs[i].travel_steps);
  const auto live = [&](size_t i) { return out[i].failure.empty(); };
  // One stage: every motor that `takes` its move (`steps`, signed, at `speed`), at once.
  const auto stage = [&](const std::function<bool(size_t)> &takes, const std::function<int64_t(size_t)> &steps,
                         const std::function<double(size_t)> &speed, bool to_switch) {
    std::vector<MoveOrder> orders(jobs.size());
    for (size_t i = 0; i < jobs.size(); ++i)
      if (takes(i)) orders[i] = MoveOrder{jobs[i].motor, steps(i), speed(i), jobs[i].ms, to_switch};
    return move_motors(board, port, orders);
  };
  // After a stage of touches: a motor whose move did not end at the switch stopped at its limit,
  // and is out of the rest. first_side: the switch toward its first one (else the far one).
  const auto touched = [&](const std::vector<MoveResult> &r, const std::function<bool(size_t)> &took,
                           const std::function<int64_t(size_t)> &limit, bool first_side) {
    for (size_t i = 0; i < jobs.size(); ++i) {
      if (!took(i) || r[i].end == sc::kMoveEndSwitch) continue;
      const bool min_side = (hs[i].dir < 0) == first_side;
      out[i].failure = hs[i].name + ": the " + std::string(min_side ? "min" : "max") + " switch did not fire within " +
                       std::to_string(limit(i)) + " steps (" + mm_text(double(limit(i)), jobs[i].ms) +
                       "): the motor stopped. Is the switch wired, and travel_steps right?";
    }
  };
  const auto home_speed = [&](size_t i) { return jobs[i].ms.home_speed; };
  const auto search = [&](size_t i) { return hs[i].search; };
  const auto touch_limit = [&](size_t i) { return 2 * hs[i].backoff; };
  const auto backoff = [&](int sign) { return [&hs, sign](size_t i) { return sign * hs[i].dir * hs[i].backoff; }; };
  touched(stage(live, [&](size_t i) { return hs[i].dir * hs[i].search; }, home_speed, true), live, search, true);
  stage(live, backoff(-1), home_speed, false);
  touched(stage(live, [&](size_t i) { return hs[i].dir * touch_limit(i); },
                [&](size_t i) { return jobs[i].ms.home_speed / 4; }, true),
          live, touch_limit, true);
  for (size_t i = 0; i < jobs.size(); ++i) {
    if (!live(i)) continue;
    board.send(set_position_payload(jobs[i].motor, hs[i].origin));
    say(hs[i].name + ": " + (hs[i].dir < 0 ? "min" : "max") + " switch found, position " + std::to_string(hs[i].origin));
  }
  stage(live, backoff(-1), home_speed, false);
  const auto both = [&](size_t i) { return live(i) && hs[i].both; };
  const auto far = stage(both, [&](size_t i) { return -hs[i].dir * hs[i].search; }, home_speed, true);
  touched(far, both, search, false);
  for (size_t i = 0; i < jobs.size(); ++i) {
    if (!both(i)) continue;  // (a motor whose far switch did not fire is out: not live)
    out[i].travel_steps = std::abs(far[i].position - hs[i].origin);
    out[i].measured = true;
    if (hs[i].dir > 0) board.send(set_position_payload(jobs[i].motor, 0));  // positions count from the min end
    say(hs[i].name + ": " + (hs[i].dir < 0 ? "max" : "min") + " switch found: travel " +
        std::to_string(out[i].travel_steps) + " steps (" + mm_text(out[i].travel_steps, jobs[i].ms) + ")");
  }
  stage(both, backoff(1), home_speed, false);
  bool any = false;
  for (size_t i = 0; i < jobs.size(); ++i) any = any || live(i);
  if (!any) return out;
  const auto s = board.status(1000);
  for (size_t i = 0; i < jobs.size(); ++i)
    if (live(i) && (!s || jobs[i].motor >= s->motors.size())) throw std::runtime_error(hs[i].name + ": no status reply");
  for (size_t i = 0; i < jobs.size(); ++i)
    if (live(i)) out[i].middle = out[i].travel_steps / 2;
  stage(live, [&](size_t i) { return int64_t(out[i].middle) - s->motors[jobs[i].motor].position_steps; },
        [&](size_t i) { return jobs[i].ms.max_speed; }, false);
  for (size_t i = 0; i < jobs.size(); ++i)
    if (live(i)) say(hs[i].name + ": in the middle, position " + std::to_string(out[i].middle));
  return out;
}

}  // namespace stepchoir
