// test_safety_link.cpp: the real firmware on the virtual board stays safe whatever the host
// does: the watchdog, stop-all, notes out of range, garbage on the line, overload, a killed host,
// and timed notes on the board's clock (uno and mega).
#include "safety_rig.h"

using namespace safety_rig;

TEST_CASE("safety: uno board clock: `at` notes start on their tick") {
  // Board ticks count from when the firmware started its timer, a fixed ~1 ms after reset, so
  // ticks and trace cycles differ by one constant: two `at` notes must show the same offset.
  Rig r("safety-clock-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(1000.0, r.caps.f_cpu_hz);
  // the default lead covers a busy machine's round trip; the second note starts later still
  const uint32_t at1 = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
  const uint32_t at2 = e2e::start_note_at(r.b, 1, period_q8, r.caps.f_cpu_hz, 0.1);
  e2e::wait_board_time(r.b, at2 + r.ticks(0.02));
  r.b.send(e2e::tone_payload(0, 0));
  r.b.send(e2e::tone_payload(1, 0));
  const tr::Trace t = r.finish();
  REQUIRE(!t.motor[0].steps.empty());
  REQUIRE(!t.motor[1].steps.empty());
  // each note's offset from its grid, not its first edge alone: one edge may wait behind an
  // interrupt (20 cycles or so)
  const int64_t offset1 = e2e::grid_cycle_offset(t.motor[0], at1, period_q8);
  const int64_t offset2 = e2e::grid_cycle_offset(t.motor[1], at2, period_q8);
  std::printf("uno clock: trace cycles - board ticks = %lld and %lld for two `at` notes\n", (long long)offset1,
              (long long)offset2);
  CHECK(std::abs(offset1 - offset2) <= 16);  // within 1 us
  CHECK(offset1 > 0);
  CHECK(offset1 < 16000 * 5);  // the timer starts within a few ms of reset
}

TEST_CASE("safety: uno watchdog (300 ms default) stops the note and disables the drivers") {
  check_watchdog(kDefaultWatchdogMs);
}

TEST_CASE("safety: uno watchdog set to 100 ms stops the note within 100 ms") { check_watchdog(100); }

TEST_CASE("safety: uno stop-all silences a 4 kHz note within 400 us and disables the drivers (4 tries)") {
  Rig r("safety-stopall-uno", "uno", {});
  r.b.send(e2e::watchdog_payload(0));
  const uint32_t period_q8 = hz_to_period_q8(4000.0, r.caps.f_cpu_hz);
  const double ticks_per_us = r.caps.f_cpu_hz / 1e6;
  const double byte_ticks = 10.0 * r.caps.f_cpu_hz / sc::kBaud;  // one 8N1 byte on the wire
  // clock request A, stop-all, clock request B back to back: the stop-all frame is complete on
  // the wire this long after A is
  const double stop_end_after_a = byte_ticks * double(frame({sc::kMsgStopAll}).size());
  struct Try {
    uint32_t at, t_a, t_b;
    uint8_t status_flags, motor_flags;
  };
  std::vector<Try> tries;
  for (int i = 0; i < 4; ++i) {  // the host's timing falls at a different phase of the steps each time
    Try k{};
    k.at = e2e::start_note_at(r.b, 0, period_q8, r.caps.f_cpu_hz);
    e2e::wait_board_time(r.b, k.at + r.ticks(0.02 + 0.0013 * i));
    e2e::send_back_to_back(r.b, {{sc::kMsgClockReq, 0x31}, {sc::kMsgStopAll}, {sc::kMsgClockReq, 0x32}});
    const auto clocks = e2e::read_replies(r.b, sc::kMsgClock, 2);
    REQUIRE(clocks[0][1] == 0x31);
    REQUIRE(clocks[1][1] == 0x32);
    k.t_a = sc::get_u32(&clocks[0][2]);
    k.t_b = sc::get_u32(&clocks[1][2]);
    const auto st = r.b.status();
    REQUIRE(st);
    REQUIRE(st->motors.size() == r.caps.motor_count);
    k.status_flags = st->head.flags;
    k.motor_flags = st->motors[0].flags;
    tries.push_back(k);
  }
  const tr::Trace t = r.finish();

  const tr::MotorTrace &m = t.motor[0];
  REQUIRE(m.steps.size() > 200);
  const int64_t offset = e2e::cycle_offset(m, tries[0].at);  // board ticks -> trace cycles
  for (size_t i = 0; i < tries.size(); ++i) {
    const Try &k = tries[i];
    const double t_stop = double(k.t_a) + double(offset) + stop_end_after_a;  // trace cycles
    // this try's last step: the next try's note starts on its `at` tick (give or take a few cycles)
    const uint64_t next_start =
        i + 1 < tries.size() ? uint64_t(tries[i + 1].at + offset) - r.ticks(0.001) : t.end_cycle + 1;
    const tr::Step *last = nullptr;
    for (const auto &s : m.steps)
      if (s.rise_cycle < next_start) last = &s;
    REQUIRE(last);
    const double last_us = (double(last->rise_cycle) - t_stop) / ticks_per_us;
    const tr::LevelChange *disabled = e2e::first_enable_change(m, uint64_t(k.t_a + offset), 1);
    const double disabled_us = disabled ? (double(disabled->cycle) - t_stop) / ticks_per_us : 1e9;
    std::printf("uno stop-all try %zu: last step %.2f us, ENABLE high %.2f us after the stop-all frame ended; the "
                "clock request right after it decoded %.1f us after it ended (60 us of wire; board ticks + %lld = "
                "trace cycles)\n",
                i, last_us, disabled_us, (double(k.t_b) + double(offset) - t_stop) / ticks_per_us, (long long)offset);
    INFO("try " << i << ": last step " << last_us << " us, ENABLE high " << disabled_us
                << " us after the stop-all frame ended");
    CHECK(last_us >= -2.0 * period_q8 / 256.0 / ticks_per_us);  // still playing when the stop came
    CHECK(last_us <= 400.0);  // measured about 200 us: the main loop decodes the frame after
    CHECK(disabled_us <= 400.0);  // the bytes queued before it
    CHECK((k.status_flags & sc::kStatusDriversEnabled) == 0);
    CHECK((k.motor_flags & sc::kMotorSounding) == 0);
  }
}

TEST_CASE("safety: uno refuses 10 kHz (above the firmware's range) and keeps answering") {
  Rig r("safety-refuse-uno", "uno", {});
  r.b.send(e2e::tone_payload(0, hz_to_period_q8(10000.0, r.caps.f_cpu_hz)));
  const auto err = r.b.wait_reply(sc::kMsgError, 500);
  REQUIRE(err);
  CHECK((*err)[1] == sc::kErrPeriodRange);
  CHECK(r.b.status(500));
  const tr::Trace t = r.finish();
  CHECK(t.motor[0].steps.empty());
}

TEST_CASE("safety: uno playing the shortest period the firmware takes still answers and obeys stop-all") {
  check_busy(16e6 * 256.0 / sc::kPeriodQ8Min);
}

TEST_CASE("safety: uno survives 300 kB of garbage at full speed - hello - status and a tone still right") {
  Rig r("safety-garbage-uno", "uno", {});
  const Caps before = r.caps;
  const std::vector<uint8_t> junk = e2e::garbage_bytes(300000, 20240607);
  const uint32_t t_junk = e2e::board_ticks(r.b, 0x51);
  for (size_t at = 0; at < junk.size(); at += 4096)
    REQUIRE(r.b.link().write(junk.data() + at, std::min<size_t>(4096, junk.size() - at)));
  // resync, then hello (as Board::hello does, counting the tries): answered once the garbage is
  // through; a try gets 2 s of wall time, several seconds of board time
  std::optional<Caps> answer;
  int tries = 0;
  while (!answer && tries < 3) {
    ++tries;
    r.b.resync();
    r.b.send({sc::kMsgHello});
    if (const auto reply = r.b.wait_reply(sc::kMsgCaps, 2000)) answer = parse_caps(reply->data(), reply->size());
  }
  REQUIRE(answer);
  const Caps after = *answer;
  const uint32_t t_hello = e2e::board_ticks(r.b, 0x52);
  const auto st = r.b.status();
  REQUIRE(st);
  std::printf("uno garbage: %zu bytes, hello answered at try %d, %.3f s of board time after the garbage began; "
              "frames ok %u bad %u, uart overruns %u, last error %u\n",
              junk.size(), tries, double(t_hello - t_junk) / r.caps.f_cpu_hz, st->head.frames_ok,
              st->head.frames_bad, st->head.uart_overruns, st->head.last_error);
  // the board really took every byte in: 300 kB at 1 Mbaud are 3 s on the wire
  CHECK(double(t_hello - t_junk) >= 0.95 * junk.size() * 10.0 / sc::kBaud * r.caps.f_cpu_hz);
  CHECK(after.protocol_version == sc::kProtocolVersion);
  CHECK(after.protocol_version == before.protocol_version);
  CHECK(after.motor_count == 4);
  CHECK(after.motor_count == before.motor_count);
  CHECK(after.f_cpu_hz == before.f_cpu_hz);
  CHECK(after.queue_size == before.queue_size);
  CHECK(after.endstops == std::vector<uint8_t>{7, 7, 7, 0});
  CHECK(after.board_name == "uno_cnc_shield_v3");
  CHECK(st->head.frames_bad > 0);

  const uint32_t period_q8 = hz_to_period_q8(440.0, r.caps.f_cpu_hz);
  const uint32_t t_tone = e2e::board_ticks(r.b, 0x53);
  r.b.send(e2e::tone_payload(0, period_q8));
  e2e::wait_board_time(r.b, t_tone + r.ticks(0.6));  // the clock requests keep the watchdog fed
  r.b.send(e2e::tone_payload(0, 0));
  const tr::Trace t = r.finish();

  size_t early = 0;  // steps before the tone: the garbage must never have moved a motor
  for (const auto &m : t.motor)
    for (const auto &s : m.steps)
      if (s.rise_cycle < t_tone) ++early;
  CHECK(early == 0);
  const auto edges = tr::rise_cycles_in_window(t.motor[0].steps, t_tone + r.ticks(0.02), t_tone + r.ticks(0.6));
  REQUIRE(edges.size() >= 200);
  const tr::PitchFit f = tr::fit_edges(edges, period_q8 / 256.0, t.f_cpu_hz);
  std::printf("uno tone after garbage: %zu edges, %.5f cents, p99 %.3f us\n", edges.size(), f.cents_error,
              f.residual_p99_us);
  INFO("tone after the garbage: " << f.cents_error << " cents, p99 residual " << f.residual_p99_us << " us");
  CHECK(std::abs(f.cents_error) < 0.05);
}

TEST_CASE("safety: uno overloaded by four fast motors still answers - obeys stop-all and keeps count") {
  // 4 x 3 kHz is more steps than the step ISR can time exactly: edges come late, but the main
  // loop must keep its share (frames, stop-all, watchdog) and positions must stay right.
  Rig r("safety-overload-uno", "uno", {"--travel-steps", "100000", "--start-position", "50000"});
  r.b.send(e2e::watchdog_payload(0));
  sc::ConfigBody c = e2e::motor_config(0, 100000);
  for (uint8_t m = 0; m < 4; ++m) {
    c.motor = m;
    r.b.send(config_payload(c));
  }
  std::vector<sc::PeriodEntry> chord;
  for (uint8_t m = 0; m < 4; ++m) chord.push_back({m, hz_to_period_q8(3000.0, r.caps.f_cpu_hz)});
  r.b.send(periods_payload(chord));
  const uint32_t t0 = e2e::board_ticks(r.b, 3);
  e2e::wait_board_time(r.b, t0 + r.ticks(0.3));
  r.b.send({sc::kMsgClockReq, 0x44});
  const auto clock = r.b.wait_reply(sc::kMsgClock, 2000);
  CHECK(clock);
  r.b.send({sc::kMsgStopAll});
  const auto st = r.b.status(2000);
  REQUIRE(st);
  CHECK((st->head.flags & sc::kStatusDriversEnabled) == 0);
  const tr::Trace t = r.finish();
  for (uint8_t m = 0; m < 4; ++m) {
    INFO("motor " << int(m));
    REQUIRE(!t.motor[m].steps.empty());
    CHECK((st->motors[m].flags & sc::kMotorSounding) == 0);
    // the firmware's count and the carriage agree (both started mid-rail, neither hit an end)
    CHECK(st->motors[m].position_steps - 50000 == t.motor[m].steps.back().position - 50000);
    // nothing after stop-all: the last step comes before the status reply's board time
    CHECK(t.motor[m].steps.size() < 3000u * 2u);
  }
}

TEST_CASE("safety: uno with four motors at the top of the range still stops on the watchdog") {
  // MIDI 105-108 on all four motors, 15,400 steps a second: more than the step ISR can time,
  // so it keeps the main loop out as long as its overload guards allow. When the host goes
  // quiet the watchdog (main loop) must still stop every motor on time.
  Rig r("safety-top-chord-uno", "uno", {"--trace-frames"});
  std::vector<sc::PeriodEntry> chord;
  for (uint8_t m = 0; m < 4; ++m) chord.push_back({m, hz_to_period_q8(note_hz(108 - m), r.caps.f_cpu_hz)});
  r.b.send(periods_payload(chord));  // and then nothing: the host is gone
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  const tr::Trace t = r.finish();
  REQUIRE(!t.frame_ends.empty());
  const uint64_t last_frame = t.frame_ends.back();
  const double watchdog_s = kDefaultWatchdogMs / 1000.0;
  REQUIRE((double(t.end_cycle) - double(last_frame)) / t.f_cpu_hz > watchdog_s + 0.1);  // the run went on past it
  for (int m = 0; m < 4; ++m) {
    INFO("motor " << m);
    REQUIRE(t.motor[m].steps.size() > 100);  // it was playing
    const double after_s = (double(t.motor[m].steps.back().rise_cycle) - double(last_frame)) / t.f_cpu_hz;
    INFO("last step " << after_s * 1000 << " ms after the last frame");
    CHECK(after_s > watchdog_s - 0.01);   // it played on until the watchdog
    CHECK(after_s <= watchdog_s + 0.01);  // and stopped then
    std::printf("top chord uno motor %d: last step %.1f ms after the last frame\n", m, after_s * 1000);
  }
}

TEST_CASE("safety: mega host killed with SIGKILL mid-chord - every motor stops within the watchdog time") {
  // Five `stepchoir tone` processes (the real host binary, heartbeats and all) each hold one
  // motor of a chord; then all are killed at once with SIGKILL, the way a crash or the kernel
  // would end them. From the board's trace: every motor's last step comes within the default
  // watchdog time (plus one period) of the last frame that reached the board, and the drivers
  // are disabled then.
  const std::string trace_path = e2e::scratch("safety-sigkill-mega.csv");
  e2e::StoppableVboard vb({"--board", "mega", "--seconds", "60", "--trace", trace_path, "--trace-frames", "--quiet"});
  const std::string bin = std::string(STEPCHOIR_VBOARD).substr(0, std::string(STEPCHOIR_VBOARD).rfind('/'));
  const double hz[] = {220.0, 277.18, 329.63, 440.0, 554.37};
  std::vector<std::unique_ptr<stepchoir::ChildProcess>> hosts;
  for (int m = 0; m < 5; ++m) {
    // One process at a time on the link: each greets the board, starts its note, then only
    // sends heartbeats. Wait for the note before the next one opens the port: the board does
    // not reset on open here, so each waits Board::kBootWaitMs for capabilities that do not
    // come, then asks.
    hosts.push_back(std::make_unique<stepchoir::ChildProcess>(
        std::vector<std::string>{bin + "/stepchoir", "tone", "--port", vb.pty(), "--motor", std::to_string(m), "--hz",
                                 std::to_string(hz[m])},
        false));
    std::this_thread::sleep_for(std::chrono::milliseconds(Board::kBootWaitMs + 300));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (auto &host : hosts) kill(host->pid(), SIGKILL);
  for (auto &host : hosts) host->wait();
  std::this_thread::sleep_for(std::chrono::milliseconds(800));
  REQUIRE(vb.stop() == 0);

  const tr::Trace t = tr::read_trace(trace_path);
  REQUIRE(!t.frame_ends.empty());
  const uint64_t last_frame = t.frame_ends.back();
  const double watchdog_s = kDefaultWatchdogMs / 1000.0;
  for (int m = 0; m < 5; ++m) {
    INFO("motor " << m);
    REQUIRE(t.motor[m].steps.size() > 20);  // it was playing
    const uint64_t last_step = t.motor[m].steps.back().rise_cycle;
    const double after_s = (double(last_step) - double(last_frame)) / t.f_cpu_hz;
    INFO("last step " << after_s * 1000 << " ms after the last frame");
    CHECK(after_s > watchdog_s - 1.0 / hz[m] - 0.002);  // it played on until the watchdog
    CHECK(after_s <= watchdog_s + 1.0 / hz[m]);          // and stopped then
    std::printf("sigkill mega motor %d: last step %.1f ms after the last frame\n", m, after_s * 1000);
  }
  // The shared enables go off (high: RAMPS enables are active low) once the watchdog fires.
  bool disabled = false;
  for (int m = 0; m < 5; ++m)
    for (const auto &e : t.motor[m].enables)
      disabled = disabled || (e.cycle > last_frame && e.value == 1 &&
                              (double(e.cycle) - double(last_frame)) / t.f_cpu_hz <= watchdog_s + 0.001);
  CHECK(disabled);
}
