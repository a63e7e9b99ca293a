// test_play_restart.cpp: `stepchoir play` when its board restarts at once, with no bootloader
// (an Uno flashed over ISP, or optiboot after a brown-out, which starts the firmware straight
// away), while a dense song plays: the real binary, the real firmware on the virtual board
// behind the 16U2 model. The song's entries that play sends between the restart and the
// moment it sees the board's new clock reach the restarted board timed on the old clock,
// seconds ahead on the new one; play drops them once it has set the board up again, or they
// would hold the song's next entries behind them in the board's queue. A board reset through
// its bootloader: test_play.cpp; `jam`: test_jam_reset.cpp.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "board/child_process.h"
#include "e2e_util.h"
#include "known_board.h"
#include "play_checks.h"
#include "smf_builder.h"
#include "trace.h"
#include "vboard_process.h"

using namespace stepchoir;
using namespace play_checks;
using e2e::scratch;

namespace {

// Four tracks of staccato sixteenths at 120 bpm (on for half of each), each track an eighth of
// a sixteenth after the last, so that its notes' starts and ends interleave: an entry goes to the board every 15.6 ms, 64 a second, under what
// the board's queue holds for a 0.3 s lead, so play always has an entry to send. 6 s. The
// pitches never repeat as a pattern (a fixed draw), so that the trace's notes line up with the
// song's at one offset only.
std::string write_dense_song(const std::string &name) {
  const uint8_t lowest[4] = {60, 48, 67, 55};
  uint32_t draw = 12345;
  constexpr uint32_t kStep = 120, kOn = 60;  // ticks at 480 a quarter
  std::vector<smf::Track> tracks(1);
  tracks[0].tempo(0, 500000).end();
  for (uint8_t ch = 0; ch < 4; ++ch) {
    smf::Track t;
    for (uint32_t i = 0; i < 48; ++i) {
      draw = draw * 1103515245u + 12345u;
      const uint8_t note = static_cast<uint8_t>(lowest[ch] + (draw >> 16) % 12);
      t.ev(i == 0 ? ch * kStep / 8 : kStep - kOn, {static_cast<uint8_t>(0x90 | ch), note, 100});
      t.ev(kOn, {static_cast<uint8_t>(0x80 | ch), note, 0});
    }
    tracks.push_back(t.end());
  }
  const std::string path = scratch(name);
  const smf::Bytes bytes = smf::file(1, 480, tracks);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char *>(bytes.data()),
                                              static_cast<std::streamsize>(bytes.size()));
  return path;
}

}  // namespace

TEST_CASE("play: an Uno that restarts without a bootloader mid-song - the entries sent on its old clock are "
          "dropped, and the song sounds again within a second",
          "[play][safety][pacing]") {
  const std::string song = write_dense_song("play-restart.mid");
  const std::string trace_path = scratch("play-restart.csv");
  const e2e::KnownBoard known("play-restart", 0x0807060504030231, 0.0);  // a second of sync
  VboardProcess vb({"--board", "uno", "--auto-reset", "--no-bootloader", "--eeprom", known.eeprom, "--trace",
                    trace_path, "--quiet"});
  ChildProcess play({STEPCHOIR_BIN, "play", song, "--port", vb.pty(), "--quiet"}, true);
  // Its open (hello waits out the bootloader a board might have), a second of sync and the lead
  // (the song's first note about 3.3 s after the open), then about a second into the song: the
  // restart.
  std::this_thread::sleep_for(std::chrono::milliseconds(4500));
  const auto [out, status] = press_reset_until_played(play, vb);
  INFO(out);
  REQUIRE(status == 0);
  CHECK(out.find("reconnects 1") != std::string::npos);
  // No entry waited behind another past its time, and the board's queue never overflowed.
  CHECK(out.find("late 0, queue full 0") != std::string::npos);
  const auto t = sc::trace::read_trace(trace_path);
  REQUIRE(t.mcu_resets.size() == 2);  // play's open, then the restart
  const uint64_t restart = t.mcu_resets[1];
  std::vector<uint64_t> steps;
  for (const auto &m : t.motor)
    for (const auto &st : m.steps) steps.push_back(st.rise_cycle);
  std::sort(steps.begin(), steps.end());
  const auto after = std::upper_bound(steps.begin(), steps.end(), restart);
  REQUIRE(after != steps.begin());  // the song had begun
  REQUIRE(after != steps.end());
  // Set up again (hello, the watchdog, a clock sync from the crystal remembered) and the lead:
  // about 0.55 s. Entries sent on the old clock in the way hold the song up for seconds.
  const double back_s = double(*after - restart) / t.f_cpu_hz;
  INFO("the song sounded again " << back_s << " s after the restart");
  CHECK(back_s < 1.0);
  // From there to its end the song never stops: some motor steps every 15.6 ms.
  double longest_gap_s = 0;
  for (auto it = after + 1; it != steps.end(); ++it)
    longest_gap_s = std::max(longest_gap_s, double(*it - *(it - 1)) / t.f_cpu_hz);
  CHECK(longest_gap_s < 0.1);
  // Its last second and a half, on time against each other and in tune, and each note's steps
  // ending with it.
  const Plan plan = plan_for(song, static_cast<size_t>(t.motors));
  const sc::trace::ScoreCheck c = check_song("play, after the board's restart", t, plan, plan.duration_s - 1.5);
  CHECK(c.max_release_late_us < 100.0);
}
