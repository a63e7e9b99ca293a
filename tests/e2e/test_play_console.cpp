// test_play_console.cpp: `stepchoir play`'s console end to end, under tmux (console_pane.h),
// with the real firmware on virtual boards. The console is up while the clock is synced. Esc
// stops the song: status 0, the terminal given back, and the trace shows no step after the
// stop. A board lost mid-song: a warning names it while its port is reopened, the song's clock
// goes on, the console says when it is back, and the board sounds again; on two boards, the
// first lost for good, the console lives on from the second. A host stalled past
// the lead: the console says notes came late, as often as play reports at its exit. Two
// boards: their motors' rows, labelled with their board, and a link row each. TERM=dumb: the
// progress line, and why. (Pause and q: test_console.cpp.)
#include <catch2/catch.hpp>

#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "console_pane.h"
#include "e2e_util.h"
#include "score.h"
#include "trace.h"
#include "vboard_process.h"

using namespace console_pane;
namespace tr = sc::trace;

namespace {

// Two voices, 2 minutes: a long way from its end at any moment these tests look at.
const std::string kCanon = std::string(STEPCHOIR_SONGS_DIR) + "/canon.sng";
// Melody, bass and inner voices for 43 s: the arranger gives every motor of two Unos notes.
const std::string kBlues = std::string(STEPCHOIR_SONGS_DIR) + "/band-blues.mid";

// Where the song is by the title ("stepchoir play  playing 0:12 / 2:05"), in whole seconds, and
// its length; -1 when the title shows no song playing.
double position_s(const std::string &screen, double *duration_s = nullptr) {
  const std::string title = "stepchoir play  playing ";
  const size_t at = screen.find(title);
  int m = 0, s = 0, dm = 0, ds = 0;
  if (at == std::string::npos ||
      std::sscanf(screen.c_str() + at + title.size(), "%d:%d / %d:%d", &m, &s, &dm, &ds) != 4)
    return -1;
  if (duration_s) *duration_s = dm * 60 + ds;
  return m * 60 + s;
}

// Waits (up to 30 s: a greeting, a clock sync) for the song to play at at_s or later; the screen.
std::string wait_playing(TmuxSession &tmux, double at_s) {
  return tmux.wait_until([&](const std::string &s) { return position_s(s) >= at_s; }, 30);
}

// The number just after `words` in text ("ttyACM0: notes came late 3 times": 3); -1 when
// absent.
long count_after(const std::string &text, const std::string &words) {
  const size_t at = text.find(words);
  if (at == std::string::npos) return -1;
  const size_t from = at + words.size();
  size_t end = from;
  while (end < text.size() && text[end] >= '0' && text[end] <= '9') ++end;
  return end == from ? -1 : std::stol(text.substr(from, end - from));
}

// The screen's row of a board's link: it starts with its label and a space; "" when none.
std::string link_row(const std::string &screen, const std::string &label) {
  for (const std::string &row : rows_of(screen))
    if (row.compare(0, label.size() + 1, label + " ") == 0) return row;
  return "";
}

// Whether row ends with " " + label.
bool ends_with_label(const std::string &row, const std::string &label) {
  const std::string tail = " " + label;
  return row.size() >= tail.size() && row.compare(row.size() - tail.size(), tail.size(), tail) == 0;
}

// Every STEP rise of every motor of t, on the machine's monotonic clock (s). Meaningful while
// the board kept real time (pacing_slipped_us 0: the caller checks).
std::vector<double> step_times(const tr::Trace &t) {
  std::vector<double> out;
  for (const tr::MotorTrace &m : t.motor)
    for (const tr::Step &s : m.steps) out.push_back(t.wall_seconds(t.real_seconds(s.rise_cycle)));
  std::sort(out.begin(), out.end());
  return out;
}

// The trace at `path` once its board stopped, laid on the monotonic clock. *slipped_s, when
// given, gets the real time the board gave up catching up on (a busy machine): its later edges
// lie that much early on the monotonic clock. Requires it to be under 50 ms (past that, a check
// in real time measures the machine).
tr::Trace paced_trace(const std::string &path, double *slipped_s = nullptr) {
  const tr::Trace t = tr::read_trace(path);
  REQUIRE(t.has_wall_start);
  INFO("the board fell up to " << tr::pacing_lag_max_us(t) << " us behind real time and gave up "
                               << tr::pacing_slipped_us(t) << " us of it");
  REQUIRE(tr::pacing_slipped_us(t) < 50000);
  if (slipped_s) *slipped_s = tr::pacing_slipped_us(t) / 1e6;
  return t;
}

}  // namespace

TEST_CASE("play: the console is up while syncing, and Esc stops the song: status 0, the terminal back, no step after",
          "[e2e][play][console][pacing]") {
  const std::string trace = e2e::scratch("play-console-esc.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace, "--quiet", "--no-measure"});
  TmuxSession tmux(stepchoir_in_pane("play " + kCanon + " --port " + vb.pty(), false), 80, 24);
  // While the board's clock is synced (a second or more), the console is up, every motor silent.
  std::string screen = tmux.wait_for("stepchoir play  syncing with the board", 30);
  expect_text(screen, "stepchoir play  syncing with the board\n");
  CHECK(row_starts(screen, 0, " 0  --"));
  CHECK(row_starts(screen, 3, " 3  --"));
  screen = wait_playing(tmux, 3);
  double duration = 0;
  const double at_stop = position_s(screen, &duration);
  INFO("the screen:\n" << screen);
  REQUIRE(at_stop >= 3);
  REQUIRE(duration > at_stop + 10);  // left alone, the song would sound on well past the checks below
  double stop_s = 0;
  quit_and_check_terminal(tmux, "play: stopped, every motor silent", "Escape", &stop_s);
  wait_ms(1000);  // the board runs on: a motor left sounding, or a queued note, would step
  REQUIRE(vb.stop() == 0);

  double slipped_s = 0;
  const tr::Trace t = paced_trace(trace, &slipped_s);
  const std::vector<double> steps = step_times(t);
  REQUIRE(!steps.empty());
  const size_t before = static_cast<size_t>(std::count_if(steps.begin(), steps.end(), [&](double s) {
    return s > stop_s - 2 && s <= stop_s;
  }));
  const double last_after_ms = (steps.back() + slipped_s - stop_s) * 1e3;
  std::printf("play console: Esc: %zu steps in the 2 s before it, the last step %.1f ms after it\n", before,
              last_after_ms);
  CHECK(before > 100);  // the song sounded up to the key
  // The key reaches the console at its next redraw (every 100 ms, on the player's progress) once
  // curses has told a lone Esc from an arrow (50 ms); the player then sends a silence and stop-all
  // at once (a few ms on the link), and the board obeys on receipt. 250 ms is less than the 300 ms
  // lead: a board left to play out its queue, or to its watchdog, would step past it.
  CHECK(last_after_ms < 250);
  CHECK(t.wall_seconds(t.real_seconds(t.end_cycle)) > stop_s + 0.9);  // the trace covers the silence
}

TEST_CASE("play: a board lost mid-song is named on the console while its port is reopened, and said back",
          "[e2e][play][console][pacing]") {
  // --link: the board's pty under a path of its own, where the board started again appears.
  const std::string link = e2e::scratch("pc-lost.pty"), trace = e2e::scratch("pc-lost-after.csv");
  auto vb = std::make_unique<VboardProcess>(
      std::vector<std::string>{"--board", "uno", "--link", link, "--quiet", "--no-measure"});
  // 132 columns: the warning names the board by its whole path, here a long scratch one.
  TmuxSession tmux(stepchoir_in_pane("play " + kCanon + " --port " + link, false), 132, 24);
  std::string screen = wait_playing(tmux, 2);
  {
    INFO("the screen:\n" << screen);
    REQUIRE(position_s(screen) >= 2);
  }
  vb.reset();  // the board gone, its pty closed
  const std::string lost = link + ": link lost; reopening the port, the song goes on without it";
  screen = tmux.wait_for(lost, 10);
  const double lost_s = now_s(), lost_at = position_s(screen);
  expect_text(screen, lost);
  CHECK(link_row(screen, "pc-lost.pty").find(" reconnecting ") != std::string::npos);
  // While the port is reopened the console lives on, and the song's clock goes on.
  wait_ms(1500);
  screen = tmux.screen();
  expect_text(screen, lost);
  CHECK(position_s(screen) >= lost_at + 1);

  vb = std::make_unique<VboardProcess>(
      std::vector<std::string>{"--board", "uno", "--link", link, "--trace", trace, "--quiet", "--no-measure"});
  const double back_s = now_s();
  screen = tmux.wait_for(": the board is back", 15);
  expect_text(screen, link + ": the board is back; the song goes on from where it is");
  CHECK(screen.find(lost) == std::string::npos);
  const std::string row = link_row(screen, "pc-lost.pty");
  {
    INFO("the screen:\n" << screen);
    CHECK(row.find(" ok ") != std::string::npos);
    CHECK(row.find("reconn 1") != std::string::npos);
    // The song carries on where it is by then, not where the board was lost (1 s: the title's
    // whole seconds).
    CHECK(position_s(screen) >= lost_at + (now_s() - lost_s) - 1);
  }
  wait_ms(2000);
  const std::string out = quit_and_check_terminal(tmux, "play: stopped, every motor silent");
  CHECK(out.find("reconnects 1") != std::string::npos);
  REQUIRE(vb->stop() == 0);

  // The board that came back sounds the song again.
  const std::vector<double> steps = step_times(paced_trace(trace));
  const size_t after =
      static_cast<size_t>(std::count_if(steps.begin(), steps.end(), [&](double s) { return s > back_s; }));
  std::printf("play console: lost board back: %zu steps after it came back\n", after);
  CHECK(after > 100);
}

TEST_CASE("play: on two boards, the first lost for good, the console lives on from the other and says so",
          "[e2e][play][console][pacing]") {
  const std::string link_a = e2e::scratch("pc-gone-a.pty"), trace_b = e2e::scratch("pc-gone-b.csv");
  auto a = std::make_unique<VboardProcess>(
      std::vector<std::string>{"--board", "uno", "--link", link_a, "--quiet", "--no-measure"});
  VboardProcess b({"--board", "uno", "--trace", trace_b, "--quiet", "--no-measure"});
  // Half tempo: 86 s, so that the song plays on well past the player's retries of board A (5 s).
  TmuxSession tmux(stepchoir_in_pane("play " + kBlues + " --tempo 0.5 --reconnect-s 5 --port " + link_a + " --port " +
                                         b.pty(),
                                     false),
                   132, 24);
  std::string screen = wait_playing(tmux, 2);
  {
    INFO("the screen:\n" << screen);
    REQUIRE(position_s(screen) >= 2);
  }
  a.reset();  // board A gone, for good
  const std::string lost = link_a + " is lost: its notes are dropped, the other boards play on";
  screen = tmux.wait_for(lost, 20);
  const double lost_s = now_s(), lost_at = position_s(screen);
  expect_text(screen, lost);
  CHECK(link_row(screen, "pc-gone-a.pty").find(" lost ") != std::string::npos);
  // Board A's player has ended: the console is drawn from board B's progress, and its keys work.
  wait_ms(1500);
  screen = tmux.screen();
  expect_text(screen, lost);
  CHECK(position_s(screen) >= lost_at + 1);
  const std::string out = quit_and_check_terminal(tmux, "play: " + b.pty() + ": stopped, every motor silent", "q",
                                                  nullptr, 1);
  CHECK(out.find("play: " + link_a + ": board lost") != std::string::npos);
  REQUIRE(b.stop() == 0);
  // Board B played on after A was given up.
  const std::vector<double> steps = step_times(paced_trace(trace_b));
  CHECK(std::count_if(steps.begin(), steps.end(), [&](double s) { return s > lost_s; }) > 100);
}

TEST_CASE("play: a host stalled past the lead: the console says notes came late, as often as play reports",
          "[e2e][play][console][pacing]") {
  const std::string trace = e2e::scratch("play-console-late.csv");
  VboardProcess vb({"--board", "uno", "--trace", trace, "--quiet", "--no-measure"});
  TmuxSession tmux(stepchoir_in_pane("play " + kBlues + " --port " + vb.pty(), false), 80, 24);
  std::string screen = wait_playing(tmux, 2);
  {
    INFO("the screen:\n" << screen);
    REQUIRE(position_s(screen) >= 2);
    CHECK(screen.find("came late") == std::string::npos);  // on time so far
  }
  // The host stopped for a second, over three times the 300 ms lead: the entries due in its last
  // 0.7 s (the song has a few a second) reach the board after their time, and the board answers
  // `late` once for each pass of its loop that took some (a count of times, not of notes).
  const pid_t pid = tmux.command_pid();
  REQUIRE(pid > 0);
  REQUIRE(::kill(pid, SIGSTOP) == 0);
  wait_ms(1000);
  REQUIRE(::kill(pid, SIGCONT) == 0);
  const double cont_s = now_s();
  const std::string warning = ": notes came late ";
  screen = tmux.wait_for(warning, 10);
  // The count settles once the board has answered what came late.
  long shown = count_after(screen, warning), before = -2;
  for (int i = 0; i < 10 && shown != before; ++i) {
    before = shown;
    wait_ms(700);
    screen = tmux.screen();
    shown = count_after(screen, warning);
  }
  {
    INFO("the screen:\n" << screen);
    CHECK(screen.find(" (host fell behind: longer --lead-ms)") != std::string::npos);
    CHECK(shown > 0);
  }
  const std::string out = quit_and_check_terminal(tmux, "play: stopped, every motor silent");
  // play's report at its exit: "play: stopped, ...; N entries in M frames, late K, ...".
  const size_t report = out.find("play: stopped");
  REQUIRE(report != std::string::npos);
  const std::string line = out.substr(report, out.find('\n', report) - report);
  const long reported = count_after(line, " frames, late ");
  INFO(line);
  std::printf("play console: late: %ld times on the console, %ld in play's report\n", shown, reported);
  CHECK(reported == shown);
  REQUIRE(vb.stop() == 0);

  // The song sounds on after the stall.
  const std::vector<double> steps = step_times(paced_trace(trace));
  CHECK(std::count_if(steps.begin(), steps.end(), [&](double s) { return s > cont_s + 0.5; }) > 100);
}

TEST_CASE("play: on two boards the console shows each board's motors labelled with it, and a link row each",
          "[e2e][play][console]") {
  const std::string trace_a = e2e::scratch("pc-two-a.csv"), trace_b = e2e::scratch("pc-two-b.csv");
  VboardProcess a({"--board", "uno", "--trace", trace_a, "--quiet", "--no-measure"});
  VboardProcess b({"--board", "uno", "--trace", trace_b, "--quiet", "--no-measure"});
  // A pty's label: its path under /dev ("pts/3").
  REQUIRE(a.pty().rfind("/dev/", 0) == 0);
  REQUIRE(b.pty().rfind("/dev/", 0) == 0);
  const std::string label_a = a.pty().substr(5), label_b = b.pty().substr(5);
  TmuxSession tmux(stepchoir_in_pane("play " + kBlues + " --port " + a.pty() + " --port " + b.pty(), false), 80, 24);
  // Three seconds into the song, board B's motors (4-7): one of them sounding.
  std::string screen = tmux.wait_until([](const std::string &s) {
    if (position_s(s) < 3) return false;
    for (int m = 4; m < 8; ++m)
      if (row_sounds(motor_row(s, m))) return true;
    return false;
  }, 30);
  INFO("the screen:\n" << screen);
  for (int m = 0; m < 8; ++m) {
    INFO("motor " << m);
    const std::string row = motor_row(screen, m);
    CHECK(ends_with_label(row, m < 4 ? label_a : label_b));
    // Its board's status came (asked four times a second): the row's endstop hits, a count.
    REQUIRE(row.size() > 34);
    const std::string ends = row.substr(27, 5);
    const size_t digit = ends.find_first_not_of(' ');
    CHECK(digit != std::string::npos);
    CHECK(ends.find_first_not_of("0123456789", digit == std::string::npos ? 0 : digit) == std::string::npos);
  }
  CHECK(motor_row(screen, 8).empty());
  for (const std::string &label : {label_a, label_b}) {
    INFO("board " << label);
    CHECK(link_row(screen, label).find(" ok ") != std::string::npos);
    CHECK(link_row(screen, label).find(" ends ") != std::string::npos);
  }
  size_t clocks = 0;
  for (const std::string &row : rows_of(screen)) clocks += row.find("  song clock ") == 0;
  CHECK(clocks == 2);
  const std::string out = quit_and_check_terminal(tmux, "play: " + a.pty() + ": stopped, every motor silent");
  CHECK(out.find("play: " + b.pty() + ": stopped, every motor silent") != std::string::npos);
  REQUIRE(a.stop() == 0);
  REQUIRE(b.stop() == 0);
  // Both boards sounded the song.
  for (const std::string &path : {trace_a, trace_b}) {
    size_t steps = 0;
    for (const tr::MotorTrace &m : tr::read_trace(path).motor) steps += m.steps.size();
    INFO(path);
    CHECK(steps > 100);
  }
}

TEST_CASE("play: on a terminal that cannot move its cursor, the progress line instead, and why",
          "[e2e][play][console]") {
  VboardProcess vb({"--board", "uno", "--quiet", "--no-measure"});
  TmuxSession tmux(stepchoir_in_pane("play " + kCanon + " --port " + vb.pty(), false).insert(0, "TERM=dumb "), 80, 24);
  const std::string screen = tmux.wait_for("] late 0", 30);
  expect_text(screen, "play: the console needs a terminal that moves its cursor (TERM): the progress line instead");
  expect_text(screen, "playing 0:");
  CHECK(screen.find("stepchoir play  ") == std::string::npos);
  CHECK(tmux.format("#{alternate_on}") == "0\n");
  quit_and_check_terminal(tmux, "play: stopped, every motor silent");
}
