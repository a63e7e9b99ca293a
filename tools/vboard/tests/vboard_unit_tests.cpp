// vboard_unit_tests.cpp: unit tests of the virtual board's pure logic (no simavr).
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "board_config.h"
#include "carriage.h"
#include "cpu_profiler.h"
#include "endstop_switch.h"
#include "line_noise.h"
#include "pacer.h"
#include "trace_writer.h"
#include "virtual_board.h"

using namespace vboard;

namespace {

// Records what the model asks of the simulator.
struct FakeDriver : SwitchPinDriver {
  std::vector<std::pair<size_t, bool>> levels;
  std::vector<uint64_t> wakeups;
  // Records a switch pin level.
  void drive_switch_pin(size_t switch_index, bool level) override { levels.push_back({switch_index, level}); }
  // Records a wakeup request.
  void wake_at(uint64_t cycle) override { wakeups.push_back(cycle); }
};

// Reads a whole temporary stream back.
std::string read_back(FILE *stream) {
  std::rewind(stream);
  std::string text;
  char buffer[4096];
  size_t count;
  while ((count = std::fread(buffer, 1, sizeof buffer, stream)) > 0) text.append(buffer, count);
  return text;
}

}  // namespace

TEST_CASE("carriage moves only when enabled and records overshoot") {
  Carriage c(10, 9);
  CHECK(c.step(true, true));
  CHECK(c.at_max());
  CHECK_FALSE(c.step(true, false));
  CHECK(c.lost_steps() == 1);
  c.step(true, true);
  c.step(true, true);
  CHECK(c.position_steps() == 12);
  CHECK(c.overshoot_steps() == 2);
  for (int i = 0; i < 13; ++i) c.step(false, true);
  CHECK(c.position_steps() == -1);
  CHECK(c.at_min());
  CHECK(c.overshoot_steps() == 2);
  CHECK(c.steps() == 16);
}

TEST_CASE("switch without chatter changes the pin once") {
  EndstopSwitch sw(true, 0, 1);
  CHECK(sw.pin_level());
  CHECK(sw.set_pressed(true, 100));
  CHECK_FALSE(sw.set_pressed(true, 101));
  SwitchPinEvent e;
  REQUIRE(sw.pop_due(100, e));
  CHECK_FALSE(e.level);
  CHECK_FALSE(e.bounce);
  CHECK_FALSE(sw.has_pending());
}

TEST_CASE("chatter is an even number of toggles inside the window and settles") {
  for (uint64_t seed = 1; seed < 50; ++seed) {
    EndstopSwitch sw(true, 1600, seed);
    sw.set_pressed(true, 1000);
    SwitchPinEvent e;
    REQUIRE(sw.pop_due(1000, e));
    int toggles = 0;
    uint64_t last = 1000;
    while (sw.has_pending()) {
      const uint64_t at = sw.next_event_cycle();
      CHECK(at > last);
      CHECK(at <= 1000 + 1600 + 6);
      REQUIRE(sw.pop_due(at, e));
      CHECK(e.bounce);
      last = at;
      ++toggles;
    }
    CHECK((toggles == 2 || toggles == 4 || toggles == 6));
    CHECK_FALSE(sw.pin_level());  // pressed, active low
  }
}

TEST_CASE("chatter is deterministic for a seed") {
  EndstopSwitch a(false, 800, 7), b(false, 800, 7);
  a.set_pressed(true, 0);
  b.set_pressed(true, 0);
  SwitchPinEvent ea, eb;
  while (a.has_pending()) {
    REQUIRE(b.has_pending());
    a.pop_due(UINT64_MAX, ea);
    b.pop_due(UINT64_MAX, eb);
    CHECK(ea.cycle == eb.cycle);
  }
}

TEST_CASE("pacer maps cycles to wall time with the crystal error and bounds catch-up") {
  Pacer fast(16e6, 100000, 5000000);  // +10 %
  fast.start(0, 1000);
  CHECK(fast.due_wall_ns(17600000) == 1000 + 1000000000ull);
  Pacer p(16e6, 0, 5000000);
  p.start(0, 0);
  CHECK(p.ahead_ns(16000, 500000) == 500000);  // 1 ms simulated at 0.5 ms wall
  CHECK(p.ahead_ns(16000, 3000000) == -2000000);
  CHECK(p.ahead_ns(16000, 21000000) == -5000000);  // 20 ms behind: 15 ms given up
  CHECK(p.lag_max_ns() == 20000000);
  CHECK(p.slipped_ns() == 15000000);
  CHECK(p.due_wall_ns(16000) == 16000000);
}

TEST_CASE("pacer maps a wall time back to its cycle and simulated time") {
  Pacer fast(16e6, 100000, 5000000);  // +10 %: 17.6 million cycles a second
  fast.start(1000, 5000);
  CHECK(fast.cycle_at_wall_ns(5000 + 1000000000ull) == 1000 + 17600000);
  CHECK(fast.cycle_at_wall_ns(5000) == 1000);
  CHECK(fast.cycle_at_wall_ns(0) == 1000);  // before the anchor: the anchor's cycle
  for (uint64_t cycle : {1000ull, 17601ull, 123456789ull}) {
    const uint64_t back = fast.cycle_at_wall_ns(fast.due_wall_ns(cycle));
    CHECK(back <= cycle);
    CHECK(cycle - back <= 1);  // the ns rounding, below a cycle
  }
  CHECK(fast.sim_ns(17600000) == 1000000000ull);

  Pacer p(16e6, 0, 5000000);
  p.start(0, 0);
  CHECK(p.cycle_at_wall_ns(1000000) == 16000);
  CHECK(p.ahead_ns(16000, 21000000) == -5000000);  // 15 ms given up: the anchor moves
  CHECK(p.cycle_at_wall_ns(16000000) == 16000);
  CHECK(p.cycle_at_wall_ns(p.due_wall_ns(32000)) == 32000);
}

TEST_CASE("pacer finds the first cycle at a simulated time, and host bytes keep their arrival time") {
  for (double ppm : {0.0, 2500.0, -5000.0, 100000.0}) {
    Pacer p(16e6, ppm, 5000000);
    p.start(0, 0);
    for (uint64_t ns : {0ull, 1ull, 62ull, 63ull, 1000000ull, 1234567ull, 999999999ull, 123456789012ull}) {
      const uint64_t cycle = p.cycle_at_sim_ns(ns);
      INFO("ppm " << ppm << " ns " << ns << " cycle " << cycle);
      CHECK(p.sim_ns(cycle) >= ns);
      if (cycle > 0) CHECK(p.sim_ns(cycle - 1) < ns);
    }
  }
  Pacer p(16e6, 0, 50000000);
  p.start(0, 1000000);  // cycle 0 due at wall 1 ms
  // Read at wall 3 ms: they came at simulated 2 ms, whether the simulation stands before that
  // (it takes them when it gets there) or after it (it takes them at once).
  CHECK(host_arrival_ns(p, 3000000) == 2000000);
  CHECK(host_arrival_ns(p, 500000) == 0);  // before the anchor: its time
}

TEST_CASE("trace writer formats header and rows") {
  FILE *stream = std::tmpfile();
  REQUIRE(stream);
  {
    TraceWriter t;
    t.attach(stream);
    t.header("uno", 16000000, "0", 4, 3200);
    t.step(0, 123, true, -5, 7);
    t.dir(1, 18446744073709551615ull, false, 42);
    t.endstop(2, 9, true, 3200);
    t.bounce(2, 10, false, 3200);
    t.enable(3, 0, true);
    t.sleep(1, 11, false);
    t.reset(2, 11, true);
    t.frame_end(12, 3);
    t.comment("end cycle=11");
    t.flush();
  }
  CHECK(read_back(stream) ==
        "# stepchoir-vboard trace v1 board=uno f_cpu=16000000 clock_ppm=0 motors=4 travel_steps=3200\n"
        "event,motor,cycle,value,position,width\n"
        "step,0,123,1,-5,7\n"
        "dir,1,18446744073709551615,0,42,\n"
        "endstop,2,9,1,3200,\n"
        "bounce,2,10,0,3200,\n"
        "enable,3,0,1,,\n"
        "sleep,1,11,0,,\n"
        "reset,2,11,1,,\n"
        "frame,0,12,0,,3\n"
        "# end cycle=11\n");
  std::fclose(stream);
}

TEST_CASE("profiler measures interrupts-off windows and ISR invocations") {
  // Flash 256 bytes, 4 vectors of 4 bytes; __vector_2 body at 0x40..0x50.
  CpuProfiler prof(256, 4, 4, {{2, 0x40, 0x50}});
  auto step = [&](uint32_t pc0, uint32_t pc1, uint64_t c0, uint64_t c1, bool i0, bool i1, bool reti) {
    prof.on_step({pc0, pc1, c0, c1, true, reti, i0, i1});
  };
  step(0x80, 0x82, 0, 10, false, true, false);    // boot: SEI at cycle 10
  step(0x82, 0x84, 10, 11, true, false, false);   // CLI at 10
  step(0x84, 0x86, 11, 31, false, true, false);   // SEI, window 10..31
  step(0x86, 0x08, 31, 36, true, false, false);   // interrupt taken: vector slot 2 at 36
  step(0x08, 0x40, 36, 39, false, false, false);  // JMP
  step(0x40, 0x4e, 39, 60, false, false, false);  // body
  step(0x4e, 0x88, 60, 64, false, true, true);    // RETI
  prof.finish(64, true);
  CHECK(prof.boot_irq_off_cycles() == 10);
  CHECK(prof.irq_off_max_cycles() == 28);  // 36..64
  CHECK(prof.irq_off_max_pc_bytes() == 0x08);
  const IsrStats &isr = prof.isr_stats()[2];
  CHECK(isr.entries == 1);
  CHECK(isr.body_cycles == 25);
  CHECK(isr.max_cycles == 28);
  CHECK(isr.inclusive_cycles == 28);
  CHECK(isr.max_irq_off_cycles == 28);
}

TEST_CASE("virtual board: steps, shared switch, enable and trace rows") {
  BoardConfig board;
  REQUIRE(board_config_for("uno", board));
  REQUIRE(board.motors.size() == 4);
  FILE *stream = std::tmpfile();
  TraceWriter trace;
  trace.attach(stream);
  ModelSettings settings;
  settings.travel_steps = 4;
  settings.start_position_steps = 2;
  VirtualBoard model(board, settings, trace);
  FakeDriver driver;
  model.set_driver(&driver);
  model.settle_initial_switches();

  size_t step_pin = 0, dir_pin = 0, enable_pin = 0;
  for (size_t i = 0; i < model.watched_pins().size(); ++i) {
    const WatchedPin &w = model.watched_pins()[i];
    if (w.pin.same_as(board.motors[0].step)) step_pin = i;
    if (w.pin.same_as(board.motors[0].dir)) dir_pin = i;
    if (w.pin.same_as(board.motors[0].enable)) enable_pin = i;
  }
  CHECK(model.watched_pins()[enable_pin].users.size() == 4);  // D8 shared by all sockets
  CHECK(model.switch_inputs().size() == 3);                    // X, Y, Z: one shared input each

  auto pulse = [&](uint64_t at) {
    model.on_output_pin(step_pin, true, at);
    model.on_output_pin(step_pin, false, at + 5);
  };
  pulse(10);  // disabled: does not move
  CHECK(model.motors()[0].carriage.lost_steps() == 1);
  model.on_output_pin(enable_pin, false, 20);
  model.on_output_pin(dir_pin, true, 30);
  pulse(40);
  pulse(50);  // reaches 4 = travel: switch pressed
  REQUIRE(driver.levels.size() == 1);
  CHECK_FALSE(driver.levels[0].second);
  model.on_output_pin(dir_pin, false, 60);
  pulse(70);  // back to 3: released
  REQUIRE(driver.levels.size() == 2);
  CHECK(driver.levels[1].second);
  for (int i = 0; i < 4; ++i) pulse(80 + 10 * i);  // down to -1: the same input, pressed again
  REQUIRE(driver.levels.size() == 3);
  CHECK(model.motors()[0].carriage.position_steps() == -1);
  CHECK(model.motors()[0].carriage.overshoot_steps() == 1);
  trace.flush();
  const std::string text = read_back(stream);
  CHECK(text.find("step,0,10,0,2,5\n") != std::string::npos);
  CHECK(text.find("enable,0,20,0,,\nenable,1,20,0,,\nenable,2,20,0,,\nenable,3,20,0,,\n") != std::string::npos);
  CHECK(text.find("endstop,0,50,1,4,\n") != std::string::npos);
  CHECK(text.find("step,0,50,1,4,5\n") != std::string::npos);
  CHECK(text.find("endstop,0,70,0,3,\n") != std::string::npos);
  CHECK(text.find("endstop,0,100,1,0,\n") != std::string::npos);
  std::fclose(stream);
}

TEST_CASE("virtual board: a step while asleep, waking, disabled or in reset is lost") {
  BoardConfig board;
  REQUIRE(board_config_for("uno", board));
  std::string error;
  REQUIRE(wire_driver_pin(board, 1, 14, true, error));   // motor 1's SLEEP on A0 (PC0)
  REQUIRE(wire_driver_pin(board, 1, 15, false, error));  // ... its RESET on A1 (PC1)
  CHECK(board.motors[1].sleep.port == 'C');
  CHECK(board.motors[1].reset.bit == 1);
  CHECK_FALSE(wire_driver_pin(board, 4, 14, true, error));
  CHECK(error == "--sleep-pin 4=14: the uno has motors 0-3");
  CHECK_FALSE(wire_driver_pin(board, 0, 20, false, error));
  CHECK(error == "--reset-pin 0=20: the uno has Arduino pins 0-19");
  FILE *stream = std::tmpfile();
  TraceWriter trace;
  trace.attach(stream);
  ModelSettings settings;
  settings.wake_cycles = 100;
  VirtualBoard model(board, settings, trace);
  size_t step = 0, enable = 0, sleep = 0, reset = 0;
  for (size_t i = 0; i < model.watched_pins().size(); ++i) {
    const PinRef &p = model.watched_pins()[i].pin;
    if (p.same_as(board.motors[1].step)) step = i;
    if (p.same_as(board.motors[1].enable)) enable = i;
    if (p.same_as(board.motors[1].sleep)) sleep = i;
    if (p.same_as(board.motors[1].reset)) reset = i;
  }
  REQUIRE(model.watched_pins()[sleep].initial_level);  // pulled up: awake until the firmware says
  auto pulse = [&](uint64_t at) {
    model.on_output_pin(step, true, at);
    model.on_output_pin(step, false, at + 5);
  };
  const Carriage &c = model.motors()[1].carriage;
  model.on_output_pin(enable, false, 10);  // enabled, awake since power-up
  pulse(20);
  CHECK(c.steps() == 1);
  model.on_output_pin(sleep, false, 30);
  pulse(40);  // asleep
  model.on_output_pin(sleep, true, 50);
  pulse(60);   // waking until 150
  pulse(149);
  pulse(150);  // awake
  CHECK(c.steps() == 2);
  CHECK(c.lost_steps() == 3);
  model.on_output_pin(reset, false, 200);
  pulse(210);  // in reset
  model.on_output_pin(reset, true, 220);
  pulse(230);
  model.on_output_pin(enable, true, 240);
  pulse(250);  // disabled
  CHECK(c.steps() == 3);
  CHECK(c.lost_steps() == 5);
  trace.flush();
  const std::string text = read_back(stream);
  CHECK(text.find("sleep,1,30,0,,\nstep,1,40,0,") != std::string::npos);
  CHECK(text.find("sleep,1,50,1,,\n") != std::string::npos);
  CHECK(text.find("reset,1,200,0,,\n") != std::string::npos);
  CHECK(text.find("reset,1,220,1,,\n") != std::string::npos);
  CHECK(model.summary_lines()[1].find(" lost_steps=5 ") != std::string::npos);
  std::fclose(stream);
}

TEST_CASE("virtual board starts with a touched switch pressed") {
  BoardConfig board;
  REQUIRE(board_config_for("mega", board));
  TraceWriter trace;
  ModelSettings settings;
  settings.start_position_steps = 0;
  settings.switch_active_low = false;
  VirtualBoard model(board, settings, trace);
  model.settle_initial_switches();
  REQUIRE(model.switch_inputs().size() == 6);
  for (const SwitchInput &input : model.switch_inputs()) {
    const bool is_min = !input.users[0].max_end;
    CHECK(input.contact.pressed() == is_min);
    CHECK(input.contact.pin_level() == is_min);  // active high
  }
}

TEST_CASE("line noise: no rates pass every byte once, and rates give about their share, reproducibly") {
  LineNoise clean({}, 1);
  for (int b = 0; b < 256; ++b) {
    const LineOutcome o = clean.pass(static_cast<uint8_t>(b));
    CHECK(o.byte == b);
    CHECK(o.count == 1);
  }
  LineNoiseRates rates;
  rates.drop = 0.01;
  rates.corrupt = 0.02;
  rates.duplicate = 0.03;
  LineNoise a(rates, 7), b(rates, 7);
  const int n = 100000;
  int changed = 0, dropped = 0, doubled = 0;
  for (int i = 0; i < n; ++i) {
    const uint8_t in = static_cast<uint8_t>(i * 37);
    const LineOutcome x = a.pass(in), y = b.pass(in);
    CHECK(x.byte == y.byte);  // same seed, same faults
    CHECK(x.count == y.count);
    changed += x.byte != in;
    dropped += x.count == 0;
    doubled += x.count == 2;
  }
  CHECK(changed == static_cast<int>(a.corrupted()));  // a corrupted byte always differs
  CHECK(dropped == static_cast<int>(a.dropped()));
  CHECK(doubled == static_cast<int>(a.duplicated()));
  CHECK(std::abs(dropped - 0.01 * n) < 0.002 * n);
  CHECK(std::abs(changed - 0.02 * n) < 0.002 * n);
  CHECK(std::abs(doubled - 0.03 * n) < 0.002 * n);
}
