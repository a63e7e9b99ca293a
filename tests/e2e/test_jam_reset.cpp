// test_jam_reset.cpp: `stepchoir jam` when its board resets with its USB link up (the reset
// button, or a brown-out from the motor supply) while a song plays and a key is held: the real
// binary, a JACK keyboard, the real firmware on the virtual board. An Uno's optiboot starts the
// firmware after its 1.375 s whatever the host sends; a Mega's stk500v2 waits for 5 s with no
// byte from the host, which jam must give it. jam's link keeper sets the board up again. The same for `live`: test_live_rig.cpp; for `play`: test_play.cpp.
#include <catch2/catch.hpp>

#include <signal.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <string>
#include <thread>

#include "board/child_process.h"
#include "core/midi_event.h"
#include "e2e_util.h"
#include "jack_rig.h"
#include "known_board.h"
#include "live_checks.h"
#include "play_checks.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
using e2e::scratch;

namespace {

// What differs between the two boards: the song's tempo (long enough to go on after the Mega's
// wait), how long the key stays held after the button, when it sounds again, and how much of
// the song's end is checked.
struct ResetCase {
  std::string board;
  uint64_t id;
  const char *tempo;
  double tempo_factor;
  int hold_after_button_ms;
  double back_min_s, back_max_s;
  double checked_s;
};

}  // namespace

TEST_CASE("jam: the board reset with its link up (its button) mid-song is set up again from the rig file, once, "
          "the song plays on and the held key sounds again - an Uno after its bootloader, a Mega once jam goes quiet",
          "[play][jam][safety][pacing]") {
  // Uno: its 1.375 s bootloader. Mega: jam hears nothing for 3.5 s and goes quiet, then the
  // bootloader's 5 s of silence and the set-up.
  const ResetCase c = GENERATE(ResetCase{"uno", 0x0807060504030211, "0.5", 0.5, 4000, 1.375, 2.5, 3.5},
                               ResetCase{"mega", 0x0807060504030231, "0.2", 0.2, 11000, 7.4, 10.5, 5.0});
  INFO(c.board);
  JackServer jack(1024);
  Sender keys;  // the keyboard, silent
  const std::string song = write_test_song("jam-button-" + c.board + ".mid");
  const std::string trace_path = scratch("jam-button-" + c.board + ".csv"),
                    rig = scratch("jam-button-" + c.board + ".toml");
  // A board met before (a second of sync), reset by the open as an Uno or a Mega is; motor 0 a
  // TB6600.
  const e2e::KnownBoard known("jam-button-" + c.board, c.id, 0.0);
  VboardProcess vb({"--board", c.board, "--auto-reset", "--eeprom", known.eeprom, "--trace", trace_path, "--quiet"});
  std::ofstream(rig) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n[[boards]]\nport = \""
                     << vb.pty() << "\"\n[[boards.motors]]\ndriver = \"tb6600\"\npulse_us = 5\n";
  ChildProcess jam({STEPCHOIR_BIN, "jam", song, "--tracks", "1,2", "--tempo", c.tempo, "--config", rig,
                    "--song-motors", "0,1", "--quiet"},
                   true);
  std::string said;
  REQUIRE(wait_for_line(jam, "jam: the song on motors 0,1", &said) != "");
  // A key held on the keyboard's motors across the reset; a second of sync and the lead, then
  // under a second into the song: the button.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  keys.send(stepchoir::note_on(0, 60, 100));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  REQUIRE(::kill(vb.pid(), SIGUSR1) == 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(c.hold_after_button_ms));
  keys.send(stepchoir::note_off(0, 60));
  const std::string out = said + jam.read_rest(60000);
  REQUIRE(jam.wait() == 0);
  REQUIRE(vb.stop() == 0);
  INFO(out);
  CHECK(out.find("reconnects 1") != std::string::npos);
  // One reset, one set-up, said once: the song player's hello afterwards is no restart.
  const auto times = [&out](const std::string &what) {
    size_t n = 0;
    for (size_t at = out.find(what); at != std::string::npos; at = out.find(what, at + 1)) ++n;
    return n;
  };
  CHECK(times(c.board == "uno" ? ": the board restarted; setting it up again"
                               : ": the board stopped answering; waiting for it in silence") == 1);
  CHECK(times(": set up again") == 1);
  const auto t = sc::trace::read_trace(trace_path);
  REQUIRE(t.mcu_resets.size() == 2);  // jam's open, then the button: the board came back without a reopen
  // The song goes on in its own time once the board is back (its bootloader, a hello, its
  // motors configured, a second of sync): the notes of the song's end, on time against each
  // other and in tune.
  const Plan plan = plan_for(song, 2, c.tempo_factor, {1, 2});  // the song motors
  INFO("the song lasts " << plan.duration_s << " s");
  check_song("jam, after the board's reset", t, plan, plan.duration_s - c.checked_s);
  // Motor 0's pulses after the reset: the TB6600's 5 us again, the rig file's setting sent anew
  // (motor 1 keeps the default).
  check_tb6600_pulses(t, 0, 1, t.mcu_resets[1]);
  // The held key, loud (velocity 100: in unison on two of the keyboard's motors): before the
  // button, and again once the board is set up again, until its release.
  const double reset_s = double(t.mcu_resets[1]) / t.f_cpu_hz;
  size_t found = 0;
  for (size_t m = 2; m < static_cast<size_t>(t.motors); ++m) {
    const auto notes = sc::trace::segment_notes(t.motor[m].steps, t.f_cpu_hz);
    if (notes.empty()) continue;
    ++found;
    REQUIRE(notes.size() == 2);
    CHECK(double(notes[0].end_cycle) / t.f_cpu_hz < reset_s);
    const double back_s = double(notes[1].start_cycle) / t.f_cpu_hz - reset_s;
    INFO("the held key sounded again on motor " << m << " " << back_s << " s after the button");
    CHECK(back_s > c.back_min_s);
    CHECK(back_s < c.back_max_s);
    for (const auto &n : notes) CHECK(std::fabs(n.midi_note - 60) < live_checks::kPitchToleranceSemitones);
    CHECK(double(notes[1].end_cycle - notes[1].start_cycle) / t.f_cpu_hz > 1.0);
  }
  CHECK(found == 2);
}
