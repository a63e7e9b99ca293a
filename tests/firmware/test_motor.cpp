// test_motor.cpp: the firmware's pure motor logic (motor.h) and timed queue (timed_queue.h),
// built for the host: a fake clock, and plain bytes for the DIR port and the switch inputs.
// Expected values are worked out here from the rules the headers state, not read off the code.
#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

#include "motor.h"  // everything in it has internal linkage: this is its one host TU
#include "timed_queue.h"

namespace { uint32_t g_clock = 0; }  // board time, set by each test

uint32_t sched::now() { return g_clock; }

using namespace sched;

namespace {

const uint8_t kOtherBits = 0xA1;  // other motors' bits on the DIR port (ours, bit 4, is clear)
const uint8_t kDirBit = 0x10, kMaxBit = 0x04, kMinBit = 0x08;
using V = std::vector<int32_t>;

// Switch wiring: none, one input for both ends, two inputs on two ports, two bits of one port.
enum Wiring { kNone, kShared, kSeparate, kSamePort };

// One motor on fake ports, armed, moving down, stepping every 1000 ticks from tick 100000.
// With travel: soft limits as set_motion (scheduler.cpp) sets them, the margin past a switch.
struct Rig {
  uint8_t dir = kOtherBits, max_port, min_port;
  Wiring wiring;
  bool active_high;
  Motor m{};

  Rig(Wiring w, bool ah, uint32_t travel = 0) : wiring(w), active_high(ah) {
    g_count.late_edges = 0;
    g_count.motor_fault = g_count.late_entries = g_count.late_motor = 0;
    max_port = min_port = ah ? 0x00 : 0xFF;  // released
    m.dir_port = &dir;
    m.dir_mask = kDirBit;
    m.flags = (uint8_t)(kArmed | (ah ? kActiveHigh : 0) | (travel ? kLimits : 0));
    m.sw_up_pin = w == kNone ? nullptr : &max_port;
    m.sw_down_pin = w == kNone ? nullptr : w == kSeparate ? &min_port : &max_port;
    m.sw_up_mask = kMaxBit;
    m.sw_down_mask = w == kShared ? kMaxBit : kMinBit;
    const int32_t margin = w != kNone ? cfg::kSoftMarginSteps : 0;
    m.travel_steps = travel;
    m.limit_hi = (int32_t)travel + margin;
    m.limit_lo = -margin;
    m.position = (int32_t)(travel / 2);
    m.period_q8 = 256u * 1000;
    m.deadline = 100000;
  }
  void go(bool up) {
    if (up) m.flags |= kUp, dir |= kDirBit;
    else m.flags &= (uint8_t)~kUp, dir &= (uint8_t)~kDirBit;
  }
  void press(bool max, bool on) {  // the max switch, or the min one
    uint8_t &port = wiring == kSeparate && !max ? min_port : max_port;
    const uint8_t mask = max || wiring == kShared ? kMaxBit : kMinBit;
    port = (uint8_t)(on == active_high ? port | mask : port & ~mask);
  }
  bool has(uint8_t flag) const { return m.flags & flag; }
  int heading() const { return has(kUp) != bool(dir & kDirBit) ? 0 : has(kUp) ? 1 : -1; }  // 0: DIR differs
  void tap(bool max) { press(max, true), step(), press(max, false); }  // one step on a switch
  V state() const { return {m.position, m.reversals, heading()}; }
  void step(int n = 1) {  // n edges, as the motor's handler does each
    for (int i = 0; i < n; ++i) account_step(m), next_deadline(m);
  }
};

}  // namespace

TEST_CASE("motor: the period fraction is carried - N steps take exactly N periods", "[motor]") {
  struct Row { uint32_t period_q8, start; };
  // 1000.5 ticks (+1000, +1001, ...); 1/256 over 1000; the shortest + 255/256; across the wrap
  const Row rows[] = {{256u * 1000 + 128, 5000}, {256u * 1000 + 1, 5000}, {256u * 3200 + 255, 5000},
                      {256u * 4000, 0xFFFFF000u}, {sc::kPeriodQ8Max, 0xFFFF0000u}};
  for (const Row &row : rows) {
    INFO("period_q8 " << row.period_q8 << " start " << row.start);
    Rig r(kNone, false);
    r.m.period_q8 = row.period_q8;
    r.m.deadline = row.start;
    for (uint64_t k = 1; k <= 3000; ++k) {
      r.step();
      const uint64_t q8 = k * row.period_q8;  // exact time since the start, 1/256 tick
      REQUIRE(r.m.deadline == (uint32_t)(row.start + (q8 >> 8)));
      REQUIRE(r.m.deadline_frac == (q8 & 0xFF));
    }
  }
}

TEST_CASE("motor: the onset ramp shrinks the period by ramp_q8 a step down to the note period", "[motor]") {
  struct Row { uint32_t start_q8, ramp_q8, target_q8; };
  const Row rows[] = {
      {256u * 5000, 256u * 300, 256u * 1000 + 128},  // 13 shrinks (5000 - 13*300 = 1100), then the note
      {256u * 2000, 100, 256u * 1990},               // 25 shrinks of 100/256 tick (2560/100 = 25.6)
      {256u * 1500, 256u * 600, 256u * 1000},        // the first shrink would pass the note: the note
      {256u * 2000, 256u * 250, 256u * 1000},        // 1750, 1500, 1250, then exactly the note
      {256u * 800, 256u * 100, 256u * 1000},         // starts shorter than the note: no ramp
      {0, 0, 256u * 1000},                           // no ramp configured
  };
  for (const Row &row : rows) {
    INFO("start " << row.start_q8 << " ramp " << row.ramp_q8 << " target " << row.target_q8);
    Rig r(kNone, false);
    r.m.start_q8 = row.start_q8;
    r.m.ramp_q8 = row.ramp_q8;
    r.m.deadline = 7000;
    r.m.deadline_frac = 99;  // a silent motor's first edge is on a whole tick
    start_period(r.m, row.target_q8);
    const bool ramp = row.start_q8 > row.target_q8;
    CHECK(r.has(kRamp) == ramp);
    CHECK(r.m.period_q8 == (ramp ? row.start_q8 : row.target_q8));
    CHECK(r.m.deadline_frac == 0);
    uint64_t t_q8 = 7000ull * 256;
    for (int64_t k = 1; k <= 100; ++k) {
      // Step k's period: start - k*ramp while longer than the note's, then the note's.
      const int64_t shrunk = ramp ? (int64_t)row.start_q8 - k * row.ramp_q8 : 0;
      const uint32_t p = shrunk > (int64_t)row.target_q8 ? (uint32_t)shrunk : row.target_q8;
      t_q8 += p;
      r.step();
      REQUIRE(r.m.period_q8 == p);
      REQUIRE(r.m.deadline == (uint32_t)(t_q8 >> 8));
      REQUIRE(r.has(kRamp) == (shrunk > (int64_t)row.target_q8));
    }
  }
}

TEST_CASE("motor: a timed change lands on its time - replacing an old edge just before it", "[motor]") {
  const uint32_t D0 = 100000, kNew = 256u * 700 + 128;  // old: 1000 ticks, next edge D0 (Rig's); new 700.5
  struct Row { int32_t at; uint32_t period; int kept; };  // at: after D0; kept: old edges sounding
  const Row rows[] = {
      {5600, kNew, 6}, {5513, kNew, 6},  // D0+5000 is 600, 513 before the time: it sounds
      {5511, kNew, 5}, {5300, kNew, 5},  // 511, 300 before (< kStrikeSnapTicks): the strike replaces it
      {5000, kNew, 5}, {900, kNew, 1},   // on an old edge: that edge is the strike; between two edges
      {200, kNew, 0}, {-500, kNew, 0},   // the next edge 200 before: replaced at once; or after it
      {5600, 0, 6}, {5300, 0, 6},        // timed silence: the edges before it sound, one just before too
      {5000, 0, 5}, {-500, 0, 0},        // an edge on the time is the first one silenced
  };
  for (const Row &row : rows) {
    INFO("at D0" << (row.at < 0 ? "" : "+") << row.at << " period " << row.period);
    Rig r(kNone, false);
    g_clock = D0 - 2000;
    const uint32_t at = D0 + (uint32_t)row.at;
    CHECK(apply(r.m, row.period, true, at));
    std::vector<uint32_t> edges, want;
    for (; r.m.period_q8 != 0 && edges.size() < (size_t)row.kept + 4; r.step())
      edges.push_back(r.m.deadline);
    for (int i = 0; i < row.kept; ++i) want.push_back(D0 + 1000u * (uint32_t)i);
    if (row.period)  // the new note from the time on, its fraction counted from there
      for (uint64_t j = 0; j < 4; ++j) want.push_back(at + (uint32_t)(j * row.period >> 8));
    CHECK(edges == want);
    CHECK(r.m.period_q8 == row.period);
    CHECK_FALSE(r.has(kRestrike));
  }
}

TEST_CASE("motor: an endstop reverses once - marks the end with travel - works at both ends", "[motor]") {
  for (Wiring w : {kShared, kSeparate, kSamePort})
    for (bool ah : {false, true})
      for (uint32_t travel : {0u, 3200u}) {
        INFO("wiring " << w << " active_high " << ah << " travel " << travel);
        Rig r(w, ah, travel);
        r.m.position = 1000;
        r.go(true);
        if (w != kShared) r.press(false, true);  // the min switch is not read going up
        r.step(5);
        r.press(false, false);
        CHECK(r.state() == V{1005, 0, 1});
        r.press(true, true);
        r.step();  // to 1006, onto the max switch
        const int32_t top = travel ? (int32_t)travel : 1006;
        CHECK(r.state() == V{top, 1, -1});
        CHECK(r.m.calibration_steps == top - 1006);
        CHECK((r.dir & ~kDirBit) == (kOtherBits & ~kDirBit));  // the other motors' bits kept
        r.step(3);  // leaving it, still pressed: no second reversal
        CHECK(r.state() == V{top - 3, 1, -1});
        if (w == kShared) r.press(true, false);  // a separate max input is not read going down
        r.step(400);  // 400,000 ticks released > kRearmTicks
        CHECK(r.has(kArmed));
        r.tap(false);
        CHECK(r.state() == V{travel ? 0 : top - 404, 2, 1});
        CHECK(r.m.calibration_steps == (travel ? -(top - 404) : 0));
      }
}

TEST_CASE("motor: switch chatter gives no second reversal - kRearmTicks released re-arms", "[motor]") {
  struct Row { uint32_t period_q8; int rearm_step; };
  // 321 * 1000 > 320,000 = kRearmTicks >= 320 * 1000; 80 * 4000.5 = 320,040 > 320,000 > 79 * 4000.5
  const Row rows[] = {{256u * 1000, 321}, {256u * 4000 + 128, 80}};
  for (const Row &row : rows)
    for (bool ah : {false, true}) {
      INFO("period_q8 " << row.period_q8 << " active_high " << ah);
      Rig r(kShared, ah);
      r.m.period_q8 = row.period_q8;
      r.go(true);
      r.tap(true);
      r.step(50);
      r.tap(true);  // it closes again, well within kRearmTicks: ignored
      CHECK(r.state() == V{-50, 1, -1});  // fired at 1, then 51 steps down
      CHECK_FALSE(r.has(kArmed));
      for (int j = 1; j <= row.rearm_step; ++j) {  // released since that bounce
        r.step();
        REQUIRE(r.has(kArmed) == (j == row.rearm_step));
      }
      r.tap(true);  // the far end
      CHECK(r.state() == V{-51 - row.rearm_step, 2, 1});
    }
}

TEST_CASE("motor: a switch still pressed kStuckSteps after it fired is stuck", "[motor]") {
  for (bool ah : {false, true})
    for (uint32_t travel : {0u, 3200u}) {
      INFO("active_high " << ah << " travel " << travel);
      Rig r(kShared, ah, travel);
      const int32_t fired_at = travel ? (int32_t)travel - 3 : 500;  // counted position when it fires
      const int32_t calib = travel ? (int32_t)travel - fired_at : 0;
      r.m.position = fired_at - 1;
      r.go(true);
      r.press(true, true);  // and it stays pressed
      r.step();
      CHECK(r.state() == V{fired_at + calib, 1, -1});
      r.step(cfg::kStuckSteps);  // kStuckSteps steps still pressed: not stuck yet (a fault stays)
      CHECK(V{r.has(kFault), g_count.motor_fault} == V{0, 0});
      r.step();  // kStuckSteps + 1 steps pressed after it fired
      CHECK(V{r.has(kFault), g_count.motor_fault} == V{1, sc::kErrEndstopStuck});
      CHECK((r.m.sw_up_pin == nullptr && r.m.sw_down_pin == nullptr));
      CHECK(r.m.position == fired_at - cfg::kStuckSteps - 1);  // as counted without the switch
      r.step(10);  // still pressed: ignored
      CHECK(r.state() == V{fired_at - cfg::kStuckSteps - 11, 1, -1});
      if (travel) {  // the soft limits still hold
        r.m.position = r.m.limit_lo + 2;
        r.step(2);
        CHECK(r.state() == V{-(int32_t)cfg::kSoftMarginSteps, 2, 1});
      }
    }
}

TEST_CASE("motor: soft limits reverse at limit_hi and limit_lo - with or without switches", "[motor]") {
  struct Row { Wiring w; uint32_t travel; bool limits; };
  const Row rows[] = {{kNone, 3200, true}, {kSeparate, 3200, true},  // switches never pressed
                      {kShared, 200, true}, {kNone, 1, true}, {kNone, 3200, false}};
  for (const Row &row : rows) {
    INFO("wiring " << row.w << " travel " << row.travel << " limits " << row.limits);
    Rig r(row.w, false, row.travel);
    if (!row.limits) r.m.flags &= (uint8_t)~kLimits;
    const int32_t margin = row.w != kNone ? cfg::kSoftMarginSteps : 0;
    const int32_t hi = (int32_t)row.travel + margin, lo = -margin, span = hi - lo;
    r.m.position = lo;
    r.go(true);
    V at_step, at_pos;  // where each reversal came
    for (int32_t i = 1; i <= 3 * span; ++i) {
      r.step();
      if (row.limits) REQUIRE((r.m.position >= lo && r.m.position <= hi));
      if (r.m.reversals != at_step.size()) at_step.push_back(i), at_pos.push_back(r.m.position);
      REQUIRE(r.heading() != 0);
    }
    CHECK(at_step == (row.limits ? V{span, 2 * span, 3 * span} : V{}));
    CHECK(at_pos == (row.limits ? V{hi, lo, hi} : V{}));
    if (!row.limits) CHECK(r.m.position == lo + 3 * span);
  }
}

TEST_CASE("motor: each motor counts its own reversals - at a switch and a soft limit - wrapping", "[motor]") {
  Rig a(kShared, false, 3200), b(kNone, false, 300);  // a: a switch; b: none, soft limits 0 and 300
  a.go(true), b.go(true);
  a.press(true, true);
  a.step(4);  // onto the max switch, and 3 steps back still pressed: one reversal
  a.press(true, false);
  CHECK(V{a.m.reversals, b.m.reversals} == V{1, 0});
  b.step(150);  // from the middle (150) up to limit_hi: it turns there
  CHECK(V{a.m.reversals, b.m.reversals} == V{1, 1});
  b.step(300);  // down to limit_lo
  a.step(300);  // a, away from its switches: no reversal
  CHECK(V{a.m.reversals, b.m.reversals} == V{1, 2});
  b.m.reversals = 0xFFFF;
  b.step(300);  // up to limit_hi again: the count wraps
  CHECK(V{a.m.reversals, b.m.reversals} == V{1, 0});
}

TEST_CASE("motor: start_up takes the side with more room - not into a pressed switch", "[motor]") {
  struct Row { Wiring w; uint32_t travel; int32_t pos; bool up; int pressed; bool want; };
  const Row rows[] = {  // pressed: 0 none, 1 max, 2 min
      {kNone, 3200, 100, false, 0, true},    {kNone, 3200, 3100, true, 0, false},
      {kNone, 3200, 1599, false, 0, true},   {kNone, 3200, 1601, true, 0, false},
      {kNone, 0, 100, true, 0, true},        {kNone, 0, 100, false, 0, false},  // no travel: as it was
      {kSeparate, 3200, 100, false, 1, false}, {kSeparate, 3200, 3100, true, 2, true},  // pressed ahead
      {kSeparate, 3200, 100, false, 2, true},  {kSeparate, 0, 0, true, 1, false},  // behind; no travel
      {kShared, 3200, 100, false, 1, true},    {kShared, 3200, 3100, true, 1, false},  // position decides
  };
  for (const Row &row : rows)
    for (bool ah : {false, true}) {
      INFO("wiring " << row.w << " pos " << row.pos << " pressed " << row.pressed << " active_high " << ah);
      Rig r(row.w, ah, row.travel);
      r.m.position = row.pos;
      r.go(row.up);
      if (row.pressed) r.press(row.pressed == 1, true);
      CHECK(start_up(r.m) == row.want);
    }
}

TEST_CASE("motor: set_dir sets the flag and the DIR bit - leaving the other bits of the port", "[motor]") {
  struct Row { bool flag_up, port_high, want; };  // the last two: flag and port disagreeing
  const Row rows[] = {{false, false, true}, {true, true, false}, {true, true, true},
                      {false, false, false}, {true, false, true}, {false, true, false}};
  for (const Row &row : rows) {
    INFO("flag " << row.flag_up << " port " << row.port_high << " want " << row.want);
    Rig r(kNone, false);
    r.go(row.flag_up);
    if (row.port_high != row.flag_up) r.dir ^= kDirBit;
    set_dir(r.m, row.want);
    CHECK(r.heading() == (row.want ? 1 : -1));
    CHECK((r.dir & ~kDirBit) == (kOtherBits & ~kDirBit));
  }
}

TEST_CASE("motor: apply starts - retunes - strikes - silences - false on a late timed change", "[motor]") {
  const uint32_t P = 256u * 1000 + 128, S = cfg::kStartLeadTicks, kOld = 256u * 1000, now0 = 1000000;
  const uint32_t N = 256u * 700;
  const int64_t kAny = INT64_MIN;
  // next: 0 silent, else the next edge of a motor sounding every 1000 ticks; times after now
  struct Row { const char *what; int32_t next; uint32_t period; bool timed; int32_t at;
               uint32_t want_period; int64_t want_deadline; bool want_pending, want_ok; };
  const Row rows[] = {
      {"silent: silence", 0, 0, false, 0, 0, kAny, false, true},
      {"silent: timed silence", 0, 0, true, 10000, 0, kAny, false, true},
      {"silent: timed silence too late", 0, 0, true, 100, 0, kAny, false, false},
      {"silent: start now", 0, P, false, 0, P, S, false, true},
      {"silent: start timed", 0, P, true, 10000, P, 10000, false, true},
      {"silent: start timed just in time", 0, P, true, (int32_t)S + 1, P, S + 1, false, true},
      {"silent: start timed too late", 0, P, true, (int32_t)S, P, S, false, false},
      {"silent: start timed in the past", 0, P, true, -50, P, S, false, false},
      {"sounding: silence now", 5000, 0, false, 0, 0, kAny, false, true},
      {"sounding: timed silence on its next edge", 5000, 0, true, 5000, 0, kAny, false, true},
      {"sounding: timed silence before its next edge", 5000, 0, true, 4000, 0, kAny, false, true},
      {"sounding: timed silence after edges due", 5000, 0, true, 20000, kOld, 5000, true, true},
      {"sounding: retune now, a period after the last edge", 5000, N, false, 0, N, 4700, false, true},
      {"sounding: retune now, longer", 5000, 256u * 3000, false, 0, 256u * 3000, 7000, false, true},
      {"sounding: retune now, phase before soonest", 500, 256u * 600, false, 0, 256u * 600, S, false, true},
      {"sounding: same period now", 5000, kOld, false, 0, kOld, 5000, false, true},
      {"sounding: strike timed before its next edge", 5000, N, true, 4800, N, 4800, false, true},
      {"sounding: strike timed after edges due", 5000, N, true, 20000, kOld, 5000, true, true},
      {"sounding: strike timed too late: now", 5000, N, true, 100, N, 4700, false, false},
  };
  for (const Row &row : rows)
    for (uint8_t before : {kRamp, kRestrike}) {  // a ramp (at its target) or a strike under way
      INFO(row.what << (before == kRamp ? ", was ramping" : ", a strike was pending"));
      g_clock = now0;
      Rig r(kNone, false, 3200);
      r.m.position = 100;  // more room up; DIR down
      r.m.deadline = now0 + (uint32_t)row.next;
      r.m.flags |= before, r.m.target_q8 = kOld, r.m.restrike_at = now0 + 30000;
      if (!row.next) r.m.period_q8 = 0;
      CHECK(apply(r.m, row.period, row.timed, now0 + (uint32_t)row.at) == row.want_ok);
      CHECK(r.m.period_q8 == row.want_period);
      if (row.want_deadline != kAny)
        CHECK(V{(int32_t)(r.m.deadline - now0), r.m.deadline_frac} == V{(int32_t)row.want_deadline, 0});
      CHECK(V{r.has(kRestrike), r.has(kRamp)} == V{row.want_pending, false});  // any change ends both
      if (row.want_pending)  // strikes (or falls silent) at its time
        CHECK(V{(int32_t)(r.m.restrike_at - now0), (int32_t)r.m.target_q8} == V{row.at, (int32_t)row.period});
      CHECK(r.heading() == (!row.next && row.period ? 1 : -1));  // a start goes start_up's way
    }
  // A retune keeps the phase to the fraction: the next edge is the new period after the last.
  for (uint64_t k = 1; k <= 4; ++k)
    for (uint32_t n : {256u * 700 + 200, 256u * 1500 + 77}) {
      INFO("after " << k << " steps of 1000.5 ticks, retune to " << n);
      Rig r(kNone, false);
      r.m.period_q8 = P;
      r.step((int)k);
      const uint64_t last = 100000ull * 256 + (k - 1) * P;  // the edge just played, q8
      g_clock = (uint32_t)(last >> 8) + 10;
      CHECK(apply(r.m, n, false, 0));
      CHECK(r.m.deadline == (uint32_t)((last + n) >> 8));
      CHECK(r.m.deadline_frac == ((last + n) & 0xFF));
    }
  // A silent motor with an onset ramp starts on its start period.
  Rig r(kNone, false);
  r.m.period_q8 = 0;
  r.m.start_q8 = 256u * 3000;
  r.m.ramp_q8 = 256u * 100;
  g_clock = now0;
  CHECK(apply(r.m, 256u * 1000, false, 0));
  CHECK(V{(int32_t)(r.m.deadline - now0), (int32_t)r.m.period_q8, (int32_t)r.m.target_q8, r.has(kRamp)} ==
        V{(int32_t)S, 256 * 3000, 256 * 1000, 1});
}

TEST_CASE("motor: take_command empties the mailbox and counts a late timed entry", "[motor]") {
  struct Row { uint8_t cmd; uint32_t period; int32_t at; bool late; uint32_t want_period; bool pending; };
  const uint32_t N = 256u * 700, O = 256u * 1000;  // late: due within kStartLeadTicks
  const Row rows[] = {{kCmdLive, N, 0, false, N, false},      {kCmdTimed, 0, 50, true, 0, false},
                      {kCmdTimed, N, 20000, false, O, true},  {kCmdTimed, 0, 20000, false, O, true},
                      {kCmdTimed, N, 100, true, N, false}};
  for (const Row &row : rows) {
    INFO("cmd " << (int)row.cmd << " period " << row.period << " at +" << row.at);
    g_clock = 1000000;
    Rig r(kNone, false);
    r.m.deadline = g_clock + 5000;
    g_count.late_entries = 7;
    r.m.cmd_period_q8 = row.period;
    r.m.cmd_at = g_clock + (uint32_t)row.at;
    r.m.cmd = row.cmd;
    take_command(3, r.m);
    CHECK(r.m.cmd == kCmdNone);
    CHECK(r.m.period_q8 == row.want_period);
    CHECK(r.has(kRestrike) == row.pending);
    CHECK(V{g_count.late_entries, g_count.late_motor} == (row.late ? V{8, 3} : V{7, 0}));
  }
}

TEST_CASE("timed queue: a FIFO ring of kQueueSize entries that wraps - clear drops all", "[motor]") {
  TimedQueue q{};
  uint32_t in = 0, out = 0;
  auto put = [&] { q.put((uint8_t)(in % 5), 256u * 1000 + in, 1000u * in), ++in; };
  auto take = [&] {
    const AtSlot &s = q.front();
    const int32_t o = (int32_t)out;
    CHECK(V{(int32_t)s.at, (int32_t)s.period_q8, s.motor} == V{1000 * o, 256000 + o, o % 5});
    q.pop(), ++out;
  };
  for (int i = 0; i < cfg::kQueueSize; ++i) put();
  CHECK(V{q.used, q.put_idx} == V{cfg::kQueueSize, 0});  // full, put_idx wrapped round
  for (int round = 0; round < 6; ++round) {  // take a few, refill: the ends wrap at varying places
    for (int i = 0; i < 5 + round; ++i) take();
    while (q.used < cfg::kQueueSize) put();
    CHECK((q.put_idx == q.take_idx && q.put_idx < cfg::kQueueSize));
  }
  while (q.used) take();
  CHECK((out == in && in > 2u * cfg::kQueueSize));
  put(), put(), q.clear();
  CHECK(q.used == 0);
  out = in;  // the entry put after the clear comes out, not one from before
  put(), take();
  CHECK(q.used == 0);
}

TEST_CASE("timed queue: drop removes the masked motors' entries - the rest keep their order", "[motor]") {
  for (uint8_t start = 0; start < cfg::kQueueSize; start += 7) {  // the ring's ends at varying places
    INFO("start " << int(start));
    TimedQueue q{};
    q.take_idx = q.put_idx = start;
    const uint8_t n = cfg::kQueueSize;
    for (uint8_t i = 0; i < n; ++i) q.put((uint8_t)(i % 4), 256u * i, 100u * i);
    q.drop(0x05);  // motors 0 and 2
    CHECK(q.used == n / 2);
    for (uint8_t i = 1; i < n; i += 2) {
      REQUIRE(q.used > 0);
      CHECK(V{q.front().motor, (int32_t)q.front().at} == V{i % 4, 100 * i});
      q.pop();
    }
    CHECK(q.used == 0);
    q.put(1, 256, 5), q.put(3, 512, 6);
    q.drop(0x02);
    CHECK(V{q.used, q.front().motor} == V{1, 3});
    q.put(0, 768, 7);  // a put after a drop follows the kept entries
    q.drop(0);
    CHECK(V{q.used, q.front().motor} == V{2, 3});
    q.pop();
    CHECK(V{q.front().motor, (int32_t)q.front().at} == V{0, 7});
    q.drop(0xFF);
    CHECK(q.used == 0);
  }
}

TEST_CASE("timed queue: taken kTakeTicks ahead - kStartLeadTicks if a strike is pending", "[motor]") {
  const int32_t T = cfg::kTakeTicks, S = cfg::kStartLeadTicks;
  struct Row { int32_t ahead; bool pending; bool take; };
  const Row rows[] = {{T + 1, false, false}, {T, false, true},     {0, false, true},
                      {-5000, false, true},  {T + 1, true, false}, {T, true, false},
                      {S + 1, true, false},  {S, true, true},      {-5000, true, true}};
  for (const Row &row : rows) {
    INFO("ahead " << row.ahead << " restrike pending " << row.pending);
    CHECK(take_entry_now(row.ahead, row.pending) == row.take);
  }
}

TEST_CASE("motor: start_up - min and max on two bits of one port are two inputs", "[motor]") {
  for (bool ah : {false, true}) {  // as on the Mega's RAMPS: X min PE5, max PE4
    Rig r(kSamePort, ah, 3200);
    r.m.position = 100;  // more room up, but the max switch ahead is pressed
    r.press(true, true);
    CHECK_FALSE(start_up(r.m));
  }
}

TEST_CASE("motor: a timed silence lets an edge due just before its time sound", "[motor]") {
  Rig r(kNone, false);
  g_clock = 98000;
  CHECK(apply(r.m, sc::kPeriodSilent, true, 100200));  // the next edge, at 100000, is 200 before
  CHECK(r.m.period_q8 == 256u * 1000);  // it still sounds (next_deadline: "a timed silence,
  r.step();                             // before its first edge at or after the time")
  CHECK(r.m.period_q8 == 0);
}
