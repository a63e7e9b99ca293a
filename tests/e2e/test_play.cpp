// test_play.cpp: `stepchoir play`, `render` and `jam` end to end: the real binary, the real
// firmware on the virtual board, and every planned note checked in the board's trace against
// the song file: onset, release and pitch, in real time (the trace's cycles divided by the
// simulated crystal's real rate). The firmware's timed entries the player builds on: test_at.cpp.
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <thread>

#include "analysis.h"
#include "board/child_process.h"
#include "core/midi_event.h"
#include "core/pitch.h"
#include "e2e_more.h"
#include "e2e_util.h"
#include "play_checks.h"
#include "jack_rig.h"
#include "known_board.h"
#include "live_checks.h"
#include "player/plan.h"
#include "score.h"
#include "smf_builder.h"
#include "song/song.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using e2e::scratch;

using namespace play_checks;

TEST_CASE("play: a multi-track MIDI file, every note on time and in tune, with the host stalled", "[play][pacing]") {
  const std::string song = write_test_song("play-multitrack.mid");
  const std::string trace_path = scratch("play-multitrack.csv");
  ChildProcess play({STEPCHOIR_BIN, "play", song, "--vboard", "uno", "--vboard-trace", trace_path, "--quiet"}, true);
  // Artificial scheduling load on the host: the player is stopped for 20-80 ms at random,
  // again and again (the virtual board, a separate process, keeps running).
  std::atomic<bool> done{false};
  int stalls = 0;
  std::thread staller([&] {
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> stall_ms(20, 80), run_ms(30, 150);
    // Past the clock sync (up to 3 s for a board met for the first time behind a USB bridge).
    std::this_thread::sleep_for(std::chrono::milliseconds(3500));
    while (!done.load()) {
      const pid_t pid = play.pid();
      if (pid <= 0 || kill(pid, SIGSTOP) != 0) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(stall_ms(rng)));
      kill(pid, SIGCONT);
      ++stalls;
      std::this_thread::sleep_for(std::chrono::milliseconds(run_ms(rng)));
    }
  });
  const std::string out = play.read_rest(60000);
  done = true;
  staller.join();
  REQUIRE(play.wait() == 0);
  INFO(out);
  CHECK(out.find("late 0,") != std::string::npos);
  CHECK(out.find("0 bad frames, 0 UART overruns") != std::string::npos);
  const auto t = sc::trace::read_trace(trace_path);
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors));
  CHECK(plan.unplayed.empty());
  REQUIRE(plan.notes.size() == 16 + 4 + 4);
  const sc::trace::ScoreCheck c = check_song("play, host stalled", t, plan);
  std::printf("play, host stalled: %d stalls of 20-80 ms\n", stalls);
  CHECK(stalls > 10);
  // (Tempo and pitch against real time: the auto-tune tests, on a lighter load.)
  CHECK(c.max_release_late_us < 100.0);    // every note ends on its time
  CHECK(c.max_release_early_us < 100.0);
}

TEST_CASE("render: a sample song through the firmware as fast as it runs, to a WAV and a picture", "[play][pacing]") {
  const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/furelise.sng";
  const std::string wav = scratch("render.wav"), png = scratch("render.png"), trace_path = scratch("render.csv");
  std::remove(wav.c_str());
  std::remove(png.c_str());
  int status = -1;
  const auto start = std::chrono::steady_clock::now();
  const std::string out = run_stepchoir({"render", song, "-o", wav, "--png", png, "--trace", trace_path}, &status);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(out);
  REQUIRE(status == 0);
  std::ifstream w(wav, std::ios::binary);
  char riff[4] = {};
  w.read(riff, 4);
  CHECK(std::string(riff, 4) == "RIFF");
  CHECK(std::ifstream(png).good());
  const auto t = sc::trace::read_trace(trace_path);
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors));
  CHECK(plan.unplayed.empty());
  const sc::trace::ScoreCheck c = check_song("render", t, plan);
  std::printf("render: %.1f s of song in %.1f s\n", plan.duration_s, wall_s);
  CHECK(std::fabs(c.tempo_ppm) < 50.0);  // board time: the nominal clock exactly
  CHECK(c.max_cents < 0.05);
}

TEST_CASE("play: the board reset mid-song (virtual board restarted): the host reconnects, configures the rig "
          "file's motors again and carries on",
          "[play][safety][pacing]") {
  const std::string song = write_test_song("play-reset.mid");
  const std::string link = scratch("play-reset.pty");
  const std::string trace2 = scratch("play-reset-after.csv");
  // Motor 0 on a TB6600 (5 us pulses), from the file --config names: the restarted board has
  // its 2 us default until the host configures it again.
  const std::string rig = scratch("play-reset.toml");
  std::ofstream(rig) << "[[boards]]\nport = \"" << link << "\"\n[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 5\n";
  // A board the host has met before (its id in its EEPROM, its crystal in the host's memory),
  // so that its sync takes a second, whatever the link.
  const e2e::KnownBoard known("play-reset", 0x0807060504030201, 0.0);
  const std::string &eeprom = known.eeprom;
  // The boards reset when play opens them, as an Uno does: play waits out the bootloader
  // (1.4 s) both times.
  auto vb = std::make_unique<VboardProcess>(
      std::vector<std::string>{"--board", "uno", "--auto-reset", "--eeprom", eeprom, "--link", link, "--quiet"});
  ChildProcess play(
      {STEPCHOIR_BIN, "play", song, "--tracks", "1,2", "--tempo", "0.5", "--port", link, "--config", rig, "--quiet"},
      true);
  // the bootloader, a second of sync, then into the song
  std::this_thread::sleep_for(std::chrono::milliseconds(3600));
  vb.reset();  // the board goes away (SIGTERM: power off) ...
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  vb = std::make_unique<VboardProcess>(std::vector<std::string>{"--board", "uno", "--auto-reset", "--eeprom", eeprom,
                                                                "--link", link, "--trace", trace2, "--quiet"});
  const std::string out = play.read_rest(60000);  // ... and comes back
  const int status = play.wait();
  vb->stop();
  INFO(out);
  REQUIRE(status == 0);
  CHECK(out.find("reconnects 1") != std::string::npos);
  CHECK(out.find("is board 0807060504030201, met before") != std::string::npos);
  // After the reconnection the song goes on in its own time: the notes that start after the
  // new board came up play, on time against each other.
  const auto t = sc::trace::read_trace(trace2);
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors), 0.5, {1, 2});
  const double song_s = plan.duration_s;
  // The plan's last notes: those that start in the song's last 3.5 seconds (the new board is
  // up and synced before: the song was under a second in when the board went away for 0.5 s,
  // and the new board, after its bootloader and a second of sync, plays from about 3 s on).
  // Two of them start on a silent motor: check_score fixes its line (offset and tempo) on
  // those. With one only it takes the tempo as exact, and the host's rate, measured against a
  // wall clock the machine may stall, can be tens of ppm off: a legato onset a second later
  // then falls more than the 50 us the check looks back before the line.
  const double from_s = song_s - 3.5;
  const std::vector<sc::trace::ScoreNote> checked = score_of(plan);
  REQUIRE(std::count_if(checked.begin(), checked.end(), [&](const auto &n) { return n.on_s >= from_s; }) >= 8);
  REQUIRE(std::count_if(checked.begin(), checked.end(),
                        [&](const auto &n) { return n.on_s >= from_s && n.after_silence == 1; }) >= 2);
  check_song("play, after the board came back", t, plan, from_s);
  // The TB6600's pulse on the board that came back (its other motors keep the default).
  check_tb6600_pulses(t, 0, 1);
}

TEST_CASE("play: a Mega reset with its link up (its button) mid-song, held in its bootloader by the song's bytes "
          "- play hears nothing, opens its port again and plays on; play itself stopped for 4 s first is no silence",
          "[play][safety][pacing]") {
  const std::string song = write_test_song("play-mega-button.mid");
  const std::string trace_path = scratch("play-mega-button.csv"), rig = scratch("play-mega-button.toml");
  const e2e::KnownBoard known("play-mega-button", 0x0807060504030221, 0.0);  // a second of sync
  VboardProcess vb({"--board", "mega", "--auto-reset", "--eeprom", known.eeprom, "--trace", trace_path, "--quiet"});
  // Motor 1, which plays the song's end, on a TB6600 with 10 us pulses: a Mega's step ISR,
  // busier than an Uno's, already stretches the default 2 us pulse to about 8 us.
  std::ofstream(rig) << "[[boards]]\nport = \"" << vb.pty() << "\"\n[[boards.motors]]\ndriver = \"a4988\"\n"
                     << "[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 10\n";
  ChildProcess play(
      {STEPCHOIR_BIN, "play", song, "--tracks", "1,2", "--tempo", "0.2", "--config", rig, "--quiet"}, true);
  // The bootloader (0.8 s), a second of sync, then under a second into the song: play stopped
  // (SIGSTOP) for longer than a silence; its board heard nothing meanwhile, and play did not
  // listen. Then the button.
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  REQUIRE(::kill(play.pid(), SIGSTOP) == 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(4000));
  REQUIRE(::kill(play.pid(), SIGCONT) == 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  const auto [out, status] = press_reset_until_played(play, vb);
  INFO(out);
  REQUIRE(status == 0);
  CHECK(out.find("reconnects 1") != std::string::npos);
  const auto t = sc::trace::read_trace(trace_path);
  // play's open, the button, and play's open again once the board had been silent for 3.5 s:
  // its bootloader then sees no byte and starts the firmware 0.8 s later. (None after the stop.)
  REQUIRE(t.mcu_resets.size() == 3);
  const double silent_s = double(t.mcu_resets[2] - t.mcu_resets[1]) / t.f_cpu_hz;
  INFO("play opened the port again " << silent_s << " s after the button");
  CHECK((silent_s > 3.4 && silent_s < 4.5));
  // The song goes on in its own time once the board is back: the notes of its last 5 s, on time
  // against each other and in tune, and motor 1 with its long pulses again (motor 2 keeps the
  // default).
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors), 0.2, {1, 2});
  INFO("the song lasts " << plan.duration_s << " s");
  const double from_s = plan.duration_s - 5.0;
  const std::vector<sc::trace::ScoreNote> checked = score_of(plan);
  REQUIRE(std::count_if(checked.begin(), checked.end(), [&](const auto &n) { return n.on_s >= from_s; }) >= 5);
  check_song("play, after the Mega's reset", t, plan, from_s);
  check_tb6600_pulses(t, 1, 2, t.mcu_resets[2]);
}

TEST_CASE("jam: a song on two motors and a JACK keyboard on the other two, both right", "[play][jam][pacing]") {
  JackServer jack(1024);
  Sender keys;
  const std::string song = write_test_song("jam.mid");
  const std::string trace_path = scratch("jam.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"});
  // The melody and the bass (tracks 1 and 2) on motors 0 and 1, the keyboard on 2 and 3.
  ChildProcess jam({STEPCHOIR_BIN, "jam", song, "--tracks", "1,2", "--midi-api", "jack", "--midi", Sender::kPort,
                    "--port", vb.pty(), "--song-motors", "0,1", "--quiet"},
                   true);
  std::string said;
  const std::string line = wait_for_line(jam, "jam: the song on motors 0,1", &said);
  INFO(said);
  REQUIRE(line.find("on motors 2,3") != std::string::npos);
  // The keyboard, while the song plays (it starts a second and a bit after that line).
  using Key = Sender::Key;
  const std::vector<Key> script = {{1.6, 1.9, 60}, {2.2, 2.6, 64}, {2.2, 2.6, 67}, {3.0, 3.3, 72}, {3.5, 3.9, 55}};
  keys.play(script);
  const std::string out = jam.read_rest(60000);
  REQUIRE(jam.wait() == 0);
  vb.stop();
  INFO(out);
  const auto t = sc::trace::read_trace(trace_path);
  // The song: every note of its plan on motors 0 and 1, on time and in tune, nothing else there.
  const Plan plan = plan_for(song, 2, 1.0, {1, 2});
  REQUIRE(plan.unplayed.empty());
  // Jam follows the refined clock as play does (its round trips pass through the live path's
  // queue, whose writer tells when each truly left), once settled: every note within 0.5 cent.
  const sc::trace::ScoreCheck c = check_song("jam, the song", t, plan, 0, PitchCheck::kSettled);
  CHECK(c.max_release_late_us < 100.0);
  // The keyboard: each key's note on motor 2 or 3 at its pitch, for about as long as it was held.
  std::vector<sc::trace::NoteSegment> live;
  for (int m : {2, 3})
    for (const auto &seg : sc::trace::segment_notes(t.motor.at(static_cast<size_t>(m)).steps, t.f_cpu_hz))
      live.push_back(seg);
  // One segment a key (a carriage turning round at the end of its rail may split one in two).
  CHECK(live.size() >= script.size());
  CHECK(live.size() <= script.size() + 2);
  for (const Key &k : script) {
    INFO("key " << int{k.note});
    const auto it = std::find_if(live.begin(), live.end(), [&](const sc::trace::NoteSegment &seg) {
      return std::fabs(seg.midi_note - k.note) < 0.01;  // within a cent
    });
    REQUIRE(it != live.end());
    const double held_s = static_cast<double>(it->end_cycle - it->start_cycle) / t.f_cpu_hz;
    CHECK(held_s == Approx(k.off_s - k.on_s).margin(0.03));
  }
}

TEST_CASE("play: a black-MIDI file (every key at once, 3,000 notes a second) ends silent in bounded memory",
          "[play][safety][pacing]") {
  // 8 s: all 128 keys at once for the first second, then 30 new notes every 10 ms, each 10-50
  // ms long, on 16 channels; note-ons and offs interleaved as such files have them.
  const uint16_t ppq = 480;  // 120 bpm: a tick is 1.04 ms
  std::mt19937 rng(42);
  std::vector<std::pair<uint32_t, std::vector<uint8_t>>> ev;  // absolute tick, message
  for (int k = 0; k < 128; ++k) {
    ev.push_back({0, {static_cast<uint8_t>(0x90 | (k % 16)), static_cast<uint8_t>(k), 100}});
    ev.push_back({960, {static_cast<uint8_t>(0x80 | (k % 16)), static_cast<uint8_t>(k), 0}});
  }
  size_t notes = 128;
  for (uint32_t tick = 960; tick < 7680; tick += 10)
    for (int i = 0; i < 30; ++i, ++notes) {
      const auto ch = static_cast<uint8_t>(rng() % 16), key = static_cast<uint8_t>(rng() % 128);
      ev.push_back({tick, {static_cast<uint8_t>(0x90 | ch), key, static_cast<uint8_t>(1 + rng() % 127)}});
      ev.push_back({tick + 10 + static_cast<uint32_t>(rng() % 40), {static_cast<uint8_t>(0x80 | ch), key, 0}});
    }
  std::stable_sort(ev.begin(), ev.end(), [](const auto &a, const auto &b) { return a.first < b.first; });
  smf::Track track;
  uint32_t last = 0;
  for (const auto &e : ev) {
    smf::vlq(track.bytes, e.first - last);
    track.bytes.insert(track.bytes.end(), e.second.begin(), e.second.end());
    last = e.first;
  }
  track.end(0);
  const auto bytes = smf::file(0, ppq, {track});
  const std::string song = scratch("black.mid"), trace_path = scratch("black.csv");
  std::ofstream(song, std::ios::binary).write(reinterpret_cast<const char *>(bytes.data()),
                                               static_cast<std::streamsize>(bytes.size()));
  int status = -1;
  const std::string out = run_stepchoir({"play", song, "--vboard", "uno", "--vboard-trace", trace_path, "--quiet"}, &status);
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  INFO(out);
  REQUIRE(status == 0);
  std::printf("black MIDI: %zu notes in %zu bytes; peak memory of the test's children %ld MiB\n%s", notes, bytes.size(),
              usage.ru_maxrss / 1024, out.c_str());
  CHECK(out.find("not played:") != std::string::npos);  // the notes left out are listed
  CHECK(out.find("0 UART overruns") != std::string::npos);
  // Every entry made on its time, though all four motors may sound at the top of their range
  // (the step ISR takes entries from the queue itself; they go at least 70 ms ahead).
  CHECK(out.find(", late 0,") != std::string::npos);
  CHECK(usage.ru_maxrss < 256 * 1024);  // KiB: bounded, whatever the file
  // At the end nothing sounds: no step after the song's last note ends.
  const auto t = sc::trace::read_trace(trace_path);
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors));
  CHECK(plan.notes.size() > 500);
  const sc::trace::ScoreCheck c = check_played(t, plan);
  print_figures("black MIDI", c);
  // No step after the song's end, plus a millisecond. The board's clock is the song's: its
  // first chord struck on the board's tick (the trace's first step), and the song runs at the
  // rate the player keeps (its report's timeline ppm). Not from fitting the notes to the
  // trace: most of these are too short and too low to leave two steps.
  uint64_t first_cycle = UINT64_MAX;
  for (const auto &m : t.motor)
    if (!m.steps.empty()) first_cycle = std::min(first_cycle, m.steps.front().rise_cycle);
  REQUIRE(first_cycle != UINT64_MAX);
  const size_t at = out.find("timeline ");
  REQUIRE(at != std::string::npos);
  const double timeline_ppm = std::stod(out.substr(at + 9));
  const double song_end_s = t.real_seconds(first_cycle) + plan.duration_s * (1 + timeline_ppm / 1e6);
  for (size_t m = 0; m < t.motor.size(); ++m) {
    INFO("motor " << m);
    if (!t.motor[m].steps.empty()) CHECK(t.real_seconds(t.motor[m].steps.back().rise_cycle) < song_end_s + 0.001);
  }
  CHECK(t.real_seconds(t.end_cycle) > song_end_s);  // the run went on past it
}

TEST_CASE("play: pause and resume (SIGUSR1), loop, and Ctrl-C leave the motors right", "[play][pacing]") {
  const std::string song = write_test_song("play-loop.mid");  // 3.6 s
  const std::string trace_path = scratch("play-loop.csv");
  ChildProcess play({STEPCHOIR_BIN, "play", song, "--loop", "--vboard", "uno", "--vboard-trace", trace_path, "--quiet"},
                    true);
  std::string line;
  REQUIRE(play.read_line(&line, 20000));  // "play: no --port: ..."
  // The clock sync (up to 3 s for a board met for the first time behind a USB bridge), the
  // lead, a second of song.
  std::this_thread::sleep_for(std::chrono::milliseconds(4300));
  kill(play.pid(), SIGUSR1);                                      // pause
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  kill(play.pid(), SIGUSR1);                                      // resume
  std::this_thread::sleep_for(std::chrono::milliseconds(4500));   // the rest, and into the second time
  const int rc = play.signal_and_wait(SIGINT);
  const std::string out = play.read_rest(5000);
  INFO(out);
  CHECK(rc == 0);
  CHECK(out.find("stopped, every motor silent") != std::string::npos);
  const auto t = sc::trace::read_trace(trace_path);
  // All steps of all motors in time order: the pause is the one long silence.
  std::vector<uint64_t> all;
  for (const auto &m : t.motor)
    for (const auto &st : m.steps) all.push_back(st.rise_cycle);
  std::sort(all.begin(), all.end());
  REQUIRE(all.size() > 100);
  double longest_gap_s = 0;
  for (size_t i = 1; i < all.size(); ++i)
    longest_gap_s = std::max(longest_gap_s, static_cast<double>(all[i] - all[i - 1]) / t.f_cpu_hz);
  CHECK(longest_gap_s > 1.2);  // paused for 1.5 s (less the lead it takes to come back)
  CHECK(longest_gap_s < 2.0);
  // Looped: the melody's first note (C5, on at 0 s) sounds at least twice, the song is longer
  // played than it lasts.
  size_t c5 = 0;
  for (const auto &m : t.motor)
    for (const auto &seg : sc::trace::segment_notes(m.steps, t.f_cpu_hz)) c5 += std::fabs(seg.midi_note - 72) < 0.05;
  CHECK(c5 >= 4);  // C5 is in the melody three times: twice a loop at least
  const double played_s = static_cast<double>(all.back() - all.front()) / t.f_cpu_hz;
  CHECK(played_s > 3.6 + 1.2);
  // Ctrl-C: nothing steps after the silence the player sends at once (the virtual board ran on
  // until the player had exited and stopped it).
  CHECK(t.end_cycle - all.back() > static_cast<uint64_t>(0.002 * t.f_cpu_hz));
}

TEST_CASE("render: the three sample songs play through the firmware, every note on time", "[play][pacing]") {
  // Canon (2:18) twice as fast, the others as written. (At four times as fast, a short note
  // two motors played in unison measured up to 0.069 cent off from its 42 edges: one edge's
  // lateness, fitted.) The three renders run at once: each paces its board on the board's own
  // time, so a board slowed by the others only takes longer.
  struct Render {
    std::string name, tempo, trace_path;
    std::unique_ptr<ChildProcess> run;
  };
  std::vector<Render> renders;
  for (const auto &[name, tempo] : std::vector<std::pair<std::string, std::string>>{
           {"canon.sng", "2"}, {"9th.sng", "1"}, {"furelise.sng", "1"}}) {
    Render r{name, tempo, scratch("render-" + name + ".csv"), nullptr};
    r.run = std::make_unique<ChildProcess>(
        std::vector<std::string>{STEPCHOIR_BIN, "render", std::string(STEPCHOIR_SONGS_DIR) + "/" + name, "--tempo", tempo,
                                 "-o", scratch("render-" + name + ".wav"), "--trace", r.trace_path},
        true);
    renders.push_back(std::move(r));
  }
  for (Render &r : renders) {
    INFO(r.name);
    const std::string out = r.run->read_rest(120000);
    INFO(out);
    REQUIRE(r.run->wait() == 0);
    const std::string song = std::string(STEPCHOIR_SONGS_DIR) + "/" + r.name;
    const auto t = sc::trace::read_trace(r.trace_path);
    PlanOptions o;
    o.tempo_scale = std::atof(r.tempo.c_str());
    o.motors.assign(static_cast<size_t>(t.motors), MotorConfig{});
    const Plan plan = plan_song(read_song_file(song), o);
    CHECK(plan.unplayed.empty());
    const sc::trace::ScoreCheck c = check_song(("render " + r.name).c_str(), t, plan);
    CHECK(c.max_cents < 0.05);
    CHECK(c.max_release_late_us < 100.0);
    CHECK(c.max_release_early_us < 100.0);
  }
}
