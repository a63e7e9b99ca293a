// test_safety.cpp: the real firmware on the virtual board keeps the carriages on their rails:
// endstop bounce-back (clean and chattering switches, uno and mega), each motor's endstop hits
// in status, soft limits, a note's onset heading away from the end it hit, the onset ramp, and
// a stuck switch.
#include "safety_rig.h"

using namespace safety_rig;

TEST_CASE("safety: uno motor 0 bounces back off its switch - one reversal per press") {
  check_bounce_back("uno", 0);
}

TEST_CASE("safety: mega motor 0 bounces back off its min and max switches - one reversal per press") {
  check_bounce_back("mega", 0);
}

TEST_CASE("safety: uno motor 0 with 3 ms switch chatter: still exactly one reversal per press") {
  check_bounce_back("uno", 3000);
}

TEST_CASE("safety: mega motor 0 with 3 ms switch chatter: still exactly one reversal per press") {
  check_bounce_back("mega", 3000);
}

namespace {

// Reversals of a motor that played one note, as the trace shows them: steps that run the other
// way from the step before, and a DIR change after its last step (the firmware turned at that
// step, and the note ended before the next).
size_t traced_reversals(const tr::MotorTrace &m) {
  if (m.steps.empty()) return 0;
  const size_t turns = tr::reversal_indices(m.steps).size();
  const bool turned_last = !m.dir_changes.empty() && m.dir_changes.back().cycle > m.steps.back().rise_cycle;
  return turns + (turned_last ? 1 : 0);
}

}  // namespace

TEST_CASE("safety: uno endstop hits per motor - status counts each motor's reversals as the trace shows them") {
  // Motors 0 and 1 have switches on a 400-step rail, acting before the firmware's soft limits
  // (travel 800). Motor 0 plays 2000 Hz for 1.5 s, bouncing off both ends; motor 1 plays 50
  // steps from the middle, clear of them.
  const int64_t kRail = 400;
  Rig r("safety-hits-uno", "uno", {"--travel-steps", std::to_string(kRail)});
  REQUIRE(r.caps.endstops.size() >= 2);
  REQUIRE((r.caps.endstops[0] != 0 && r.caps.endstops[1] != 0));
  r.b.send(e2e::watchdog_payload(0));
  for (uint8_t m : {0, 1}) r.b.send(config_payload(e2e::motor_config(m, 2 * kRail)));
  REQUIRE_FALSE(r.b.wait_reply(sc::kMsgError, 200));
  const uint32_t t0 = e2e::board_ticks(r.b);
  r.b.send(e2e::tone_payload(0, hz_to_period_q8(2000.0, r.caps.f_cpu_hz)));
  r.b.send(e2e::tone_payload(1, hz_to_period_q8(500.0, r.caps.f_cpu_hz)));
  e2e::wait_board_time(r.b, t0 + r.ticks(0.1));
  r.b.send(e2e::tone_payload(1, 0));
  e2e::wait_board_time(r.b, t0 + r.ticks(1.5));
  r.b.send(e2e::tone_payload(0, 0));
  e2e::wait_board_time(r.b, e2e::board_ticks(r.b) + r.ticks(0.01));  // both silent: no reversal to come
  const auto st = r.b.status();
  REQUIRE(st);
  r.b.send({sc::kMsgResetCounters});
  const auto reset = r.b.status();
  REQUIRE(reset);
  const tr::Trace t = r.finish();

  const size_t traced[2] = {traced_reversals(t.motor[0]), traced_reversals(t.motor[1])};
  std::printf("uno endstop hits: motor 0 %zu steps, %zu reversals in the trace, %u in status; motor 1 %zu steps, "
              "%zu and %u; board total %u\n",
              t.motor[0].steps.size(), traced[0], unsigned(st->motors.at(0).reversals), t.motor[1].steps.size(),
              traced[1], unsigned(st->motors.at(1).reversals), unsigned(st->head.reversals));
  REQUIRE(st->motors.size() == r.caps.motor_count);
  REQUIRE(t.motor[0].steps.size() > 2000);
  REQUIRE(traced[0] >= 5);                      // motor 0 bounced off its switches
  REQUIRE(e2e::press_cycles(t.motor[0]).size() >= traced[0]);  // each at a press of a switch
  REQUIRE(t.motor[1].steps.size() >= 40);       // motor 1 played
  REQUIRE(t.motor[1].endstop_changes.empty());  // but never reached a switch
  CHECK(st->motors[0].reversals == traced[0]);
  CHECK(st->motors[1].reversals == traced[1]);
  CHECK(st->head.reversals == traced[0] + traced[1]);  // the board's total
  for (size_t m = 2; m < st->motors.size(); ++m) CHECK(st->motors[m].reversals == 0);  // silent all along
  REQUIRE(reset->motors.size() == st->motors.size());
  CHECK(reset->head.reversals == 0);
  for (const sc::StatusMotor &m : reset->motors) CHECK(m.reversals == 0);
}

TEST_CASE("safety: uno motor A (no switch) reverses at its soft limits and never leaves the rail") {
  const int64_t kRail = 300;
  Rig r("safety-soft-uno", "uno", {"--travel-steps", std::to_string(kRail)});
  REQUIRE(r.caps.endstops.size() == 4);
  REQUIRE(r.caps.endstops[3] == 0);  // motor A: no switch
  const Rig::Played p = r.play_tone(3, uint32_t(kRail), 2000.0, 1.0);
  const uint32_t period_q8 = p.period_q8;
  const Status &st = p.status;
  const tr::Trace &t = p.trace;

  const tr::MotorTrace &m = t.motor[3];
  const std::vector<size_t> rev = tr::reversal_indices(m.steps);
  const int64_t overshoot = tr::max_overshoot_steps(m.steps, kRail);
  const double deviation = worst_interval_deviation(m.steps, rev, period_q8 / 256.0);
  const double mean_change = worst_mean_interval_change(m.steps, rev);
  const double deviation_anywhere = worst_interval_deviation_anywhere(m.steps, period_q8 / 256.0);
  std::printf("uno soft limits: %zu steps, %zu reversals, overshoot %lld; worst step interval deviation %.4f %% at "
              "reversals (%.4f %% anywhere), worst 8-step mean interval change across a reversal %.4f %%\n",
              m.steps.size(), rev.size(), (long long)overshoot, deviation * 100, deviation_anywhere * 100,
              mean_change * 100);
  REQUIRE(m.steps.size() > 1500);
  CHECK(rev.size() >= 5);
  CHECK(overshoot <= 1);
  CHECK(reversals_away_from_ends(m.steps, rev, kRail, 1) == 0);  // turns only at the ends
  CHECK(m.endstop_changes.empty());
  CHECK(st.head.reversals == rev.size());
  INFO("worst step interval deviation at a reversal: " << deviation * 100 << " % (anywhere in the note: "
                                                         << deviation_anywhere * 100 << " %)");
  CHECK(deviation <= kIntervalTolerance);
  CHECK(mean_change <= kIntervalTolerance);
}

TEST_CASE("safety: uno note onset after a switch reversal heads away from the end it hit") {
  // 600-step rail, carriage at 100; the firmware believes mid travel (1600 of 3200) until a
  // switch recalibrates it, and either way its first reversal is at a switch.
  const int64_t kRail = 600;
  Rig r("safety-onset-uno", "uno", {"--travel-steps", std::to_string(kRail), "--start-position", "100"});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(1000.0, r.caps.f_cpu_hz);
  r.b.send(e2e::tone_payload(0, period_q8));
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (;;) {
    const auto st = r.b.status();
    REQUIRE(st);
    if (st->head.reversals >= 1) break;
    REQUIRE(std::chrono::steady_clock::now() < give_up);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r.b.send(e2e::tone_payload(0, 0));
  // A sounding motor takes a command at its next edge when that is near (within 256 us,
  // kVisitMarginTicks): the status right after may still say sounding. Silent within 20 ms of
  // wall time (a status round trip through the pty takes up to a few ms on a loaded machine).
  const auto silence_by = std::chrono::steady_clock::now() + std::chrono::milliseconds(20);
  bool silent = false;
  while (!silent) {
    const auto between = r.b.status();
    REQUIRE(between);
    silent = (between->motors[0].flags & sc::kMotorSounding) == 0;
    if (!silent && std::chrono::steady_clock::now() > silence_by) break;
  }
  CHECK(silent);
  e2e::wait_board_time(r.b, e2e::board_ticks(r.b) + r.ticks(0.02));  // 20 ms of silence
  r.b.send(e2e::tone_payload(0, period_q8));
  const uint32_t t2 = e2e::board_ticks(r.b, 0x42);
  e2e::wait_board_time(r.b, t2 + r.ticks(0.05));
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();

  const tr::MotorTrace &m = t.motor[0];
  REQUIRE(!m.endstop_changes.empty());
  const tr::LevelChange &press = m.endstop_changes.front();
  REQUIRE(press.value == 1);
  const bool hit_min = press.position <= kRail / 2;
  // the second note starts after the one long gap between steps (the silence)
  size_t second = 0, gaps = 0;
  for (size_t k = 1; k < m.steps.size(); ++k)
    if (m.steps[k].rise_cycle - m.steps[k - 1].rise_cycle > 3 * period_q8 / 256) second = k, ++gaps;
  REQUIRE(gaps == 1);
  // the switch was hit during the first note (by its last step at the latest: the host silences
  // the motor as soon as status shows the reversal, which may be before the next step)
  REQUIRE(press.cycle <= m.steps[second - 1].rise_cycle);
  REQUIRE(m.steps.size() - second >= 20);
  const int64_t stop_position = m.steps[second - 1].position;
  const int expected_step = hit_min ? +1 : -1;  // away from the end it hit
  size_t wrong = 0;
  for (size_t k = second; k < second + 20; ++k)
    if (m.steps[k].position - (k == second ? stop_position : m.steps[k - 1].position) != expected_step) ++wrong;
  std::printf("uno onset: switch hit at %lld, stopped at %lld, new note's first step to %lld\n",
              (long long)press.position, (long long)stop_position, (long long)m.steps[second].position);
  INFO("switch pressed at position " << press.position << ", carriage stopped at " << stop_position
                                     << ", the new note's first step went to " << m.steps[second].position);
  REQUIRE(std::abs(stop_position - press.position) < kRail / 2);  // stopped near the end it hit
  CHECK(m.steps[second].position - stop_position == expected_step);
  CHECK(wrong == 0);  // its first 20 steps all head away from that end
}

TEST_CASE("safety: uno onset ramp - the period shrinks by the configured step from the start speed") {
  Rig r("safety-ramp-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  sc::ConfigBody c = e2e::motor_config(1, 3200);
  const uint32_t target_q8 = hz_to_period_q8(2000.0, r.caps.f_cpu_hz);  // 8000 ticks
  c.start_period_q8 = hz_to_period_q8(500.0, r.caps.f_cpu_hz);          // 32000 ticks
  c.accel_q8 = 1000u << sc::kPeriodFracBits;                            // 1000 ticks a step
  r.b.send(config_payload(c));
  REQUIRE_FALSE(r.b.wait_reply(sc::kMsgError, 200));
  const uint32_t at = e2e::start_note_at(r.b, 1, target_q8, r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at + r.ticks(0.1));
  r.b.send(e2e::tone_payload(1, 0));
  const tr::Trace t = r.finish();
  const auto &steps = t.motor[1].steps;
  REQUIRE(steps.size() > 40);
  // intervals: 31000, 30000, ... (the first step uses the start period, each next one 1000
  // ticks less) until the target, then the target
  std::vector<int64_t> interval;
  for (size_t i = 1; i < steps.size(); ++i) interval.push_back(int64_t(steps[i].rise_cycle - steps[i - 1].rise_cycle));
  const int64_t start = c.start_period_q8 >> sc::kPeriodFracBits, target = target_q8 >> sc::kPeriodFracBits;
  const int64_t ramp = c.accel_q8 >> sc::kPeriodFracBits;
  size_t ramp_steps = 0;
  for (size_t i = 0; i < interval.size() && interval[i] > target + 100; ++i) {
    INFO("interval " << i << ": " << interval[i]);
    CHECK(std::llabs(interval[i] - (start - ramp * int64_t(i + 1))) <= 64);  // within the edge timing
    ++ramp_steps;
  }
  CHECK(ramp_steps == size_t((start - target) / ramp) - 1);
  for (size_t i = ramp_steps + 1; i < interval.size(); ++i) CHECK(std::llabs(interval[i] - target) <= 64);
}

TEST_CASE("safety: uno stuck switch - the motor ignores it - reports it and keeps to its travel") {
  // Motor 0's shared switch reads pressed all the time: the first step takes it for an end and
  // turns round; 400 steps later the firmware calls it stuck, undoes the position it set and
  // runs on its soft limits (travel 3200, 8 steps of margin).
  Rig r("safety-stuck-uno", "uno", {"--stuck-switch", "0"});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t at = e2e::start_note_at(r.b, 0, hz_to_period_q8(4000.0, r.caps.f_cpu_hz), r.caps.f_cpu_hz);
  e2e::wait_board_time(r.b, at + r.ticks(2.5));
  const auto st = r.b.status(1000);
  REQUIRE(st);
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();
  const auto &steps = t.motor[0].steps;
  REQUIRE(steps.size() > 8000);
  const int64_t overshoot = tr::max_overshoot_steps(steps, 3200);
  const std::vector<size_t> rev = tr::reversal_indices(steps);
  std::printf("uno stuck switch: %zu steps, %zu reversals, overshoot %lld, last error %u, motor flags 0x%02x\n",
              steps.size(), rev.size(), (long long)overshoot, st->head.last_error, st->motors[0].flags);
  CHECK(st->head.last_error == sc::kErrEndstopStuck);
  CHECK((st->motors[0].flags & sc::kMotorEndstopFault) != 0);
  CHECK(overshoot <= 8);
  CHECK(rev.size() >= 3);  // it keeps going back and forth on its soft limits
  for (size_t i = 1; i < rev.size(); ++i) {  // after the first (false) turn, only at the ends
    const int64_t p = steps[rev[i] - 1].position;
    INFO("reversal " << i << " at position " << p);
    CHECK((p <= 8 || p >= 3200 - 8));
  }
}

