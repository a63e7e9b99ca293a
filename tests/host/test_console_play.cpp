// test_console_play.cpp: play's console model, without a terminal: each motor's row from the
// plan's events at the player's position, the board being reopened, a pty's rows, and each
// carriage with its endstop hits from the board's status. Built into test_live; live's console:
// test_console.cpp, test_console_live.cpp.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "cli/console_model.h"
#include "cli/console_view.h"
#include "core/pitch.h"

using namespace stepchoir;

TEST_CASE("console: play's rows from the plan's events at the player's position", "[console][play]") {
  // Board A: motors 0 and 1; board B: motor 0. Events by board, in time order, board motor numbers.
  auto on = [](double t, uint8_t m, double pitch) { return PlanEvent{t, m, false, pitch}; };
  auto off = [](double t, uint8_t m) { return PlanEvent{t, m, true, 0}; };
  const std::vector<std::vector<PlanEvent>> events{
      {on(0.0, 0, 69), on(0.5, 1, 60), off(1.0, 0), on(1.5, 0, 72.2), off(2.0, 1)},
      {on(1.0, 0, 57)}};
  std::vector<PlayBoard> boards{{"/dev/ttyACM0", 2, {}, false, {}, {}}, {"/dev/ttyACM1", 1, {}, false, {}, {}}};
  boards[1].stats.frames_sent = 42;
  boards[1].stats.clock_samples = 3;
  boards[1].stats.ppm = 2493.7;

  ConsoleModel m = play_model(events, boards, 0.7, 440.0);
  REQUIRE(m.motors.size() == 3);
  CHECK(m.motors[0].note == 69);
  CHECK(m.motors[0].hz == Approx(440.0));
  CHECK(m.motors[1].note == 60);
  CHECK(m.motors[1].hz == Approx(note_hz(60)));
  CHECK(m.motors[2].note == -1);  // board B's first note comes at 1.0 s
  CHECK(m.motors[2].number == 2);
  CHECK(m.motors[2].board == "/dev/ttyACM1");
  REQUIRE(m.links.size() == 2);
  CHECK(m.links[1].frames_sent == 42);
  CHECK(m.links[1].has_clock);
  CHECK_FALSE(m.links[0].has_clock);
  CHECK(m.warnings.empty());

  m = play_model(events, boards, 1.2, 440.0);  // motor 0 silent, board B sounding
  CHECK(m.motors[0].note == -1);
  CHECK(m.motors[1].note == 60);
  CHECK(m.motors[2].note == 57);
  m = play_model(events, boards, 2.5, 432.0);  // a pitch between notes, another A4
  CHECK(m.motors[0].note == 72);
  CHECK(m.motors[0].cents == Approx(20.0));
  CHECK(m.motors[0].hz == Approx(note_hz(72.2, 432.0)));
  CHECK(m.motors[1].note == -1);

  // A lost board and late entries, in plain words; the screen: no MIDI, latency or preset.
  boards[1].lost = true;
  boards[0].stats.late_reported = 3;
  m = play_model(events, boards, 2.5, 440.0);
  m.song = "playing 0:02 / 0:03";
  REQUIRE(m.warnings.size() == 2);
  CHECK(m.warnings[0] == "/dev/ttyACM0: notes came late 3 times (host fell behind: longer --lead-ms)");
  CHECK(m.warnings[1].find("/dev/ttyACM1 is lost") == 0);
  CHECK(m.links[1].health == "lost");
  ConsoleFooter footer;
  footer.keys = "keys";
  const std::vector<ScreenLine> lines = console_lines(m, footer, 24, 80);
  CHECK(lines[0].text == "stepchoir play  playing 0:02 / 0:03");
  CHECK(lines[2].text.rfind(" 0  C5      529.33    +20  ", 0) == 0);  // no status yet: no count, no carriage
  CHECK(lines[2].text.find_first_not_of(' ', 27) == lines[2].text.size() - 7);
  CHECK(lines[2].text.find("ttyACM0") != std::string::npos);
  for (const ScreenLine &l : lines) {
    CHECK(l.text.find("MIDI") == std::string::npos);
    CHECK(l.text.find("latency") == std::string::npos);
  }
  CHECK(lines.back().text == "keys");
}

TEST_CASE("console: play says in plain words which board is being reopened, and labels a pty's rows",
          "[console][play]") {
  const std::vector<std::vector<PlanEvent>> events{{PlanEvent{0.0, 0, false, 69}}, {PlanEvent{0.0, 0, false, 57}}};
  std::vector<PlayBoard> boards{{"/dev/pts/3", 1, {}, false, {}, {}}, {"/tmp/uno.pty", 1, {}, false, {}, {}}};
  boards[1].stats.reconnecting = true;
  boards[1].stats.reconnects = 1;
  const ConsoleModel m = play_model(events, boards, 0.5, 440.0);
  REQUIRE(m.links.size() == 2);
  CHECK(m.links[0].health == "ok");
  CHECK(m.links[1].health == "reconnecting");
  CHECK_FALSE(m.links[1].healthy);
  REQUIRE(m.warnings.size() == 1);
  CHECK(m.warnings[0] == "/tmp/uno.pty: link lost; reopening the port, the song goes on without it");
  const std::vector<ScreenLine> lines = console_lines(m, ConsoleFooter{}, 24, 80);
  REQUIRE(lines.size() >= 6);
  // A pty's rows name it by its path under /dev ("pts/3"), not its last part alone ("3").
  CHECK(lines[2].text.rfind(" 0  A4      440.00     +0  ", 0) == 0);
  CHECK(lines[2].text.substr(lines[2].text.size() - 6) == " pts/3");
  CHECK(lines[3].text.substr(lines[3].text.size() - 8) == " uno.pty");
  CHECK(lines[4].text.rfind("pts/3 ", 0) == 0);
  CHECK(lines[5].text.rfind("uno.pty ", 0) == 0);
  CHECK(lines[5].text.find("reconnecting") != std::string::npos);
}

TEST_CASE("console: play's rows show each carriage and its endstop hits from the board's status", "[console][play]") {
  // The song plays board motors 1 and 3 (plan motors 0 and 1) on a 400-step rail and an
  // unlimited one; the board's status reply, as the player keeps it.
  const std::vector<std::vector<PlanEvent>> events{{PlanEvent{0.0, 0, false, 69}, PlanEvent{0.0, 1, false, 57}}};
  std::vector<PlayBoard> boards{{"/dev/ttyACM0", 2, {}, false, {1, 3}, {400, 0}}};
  ConsoleModel m = play_model(events, boards, 0.5, 440.0);
  CHECK_FALSE(m.motors[0].has_position);  // no status reply yet: blank
  std::vector<ScreenLine> lines = console_lines(m, ConsoleFooter{}, 24, 80);
  CHECK(lines[2].text.substr(0, 34) == " 0  A4      440.00     +0         ");

  PlayerStats &s = boards[0].stats;
  s.has_status = true;
  s.motor_position[1] = 100;
  s.motor_reversals[1] = 7;
  s.motor_position[3] = -250;
  s.motor_reversals[3] = 0;
  s.motor_flags[3] = sc::kMotorEndstopFault;
  s.motor_position[0] = 999;  // a motor the song does not play
  s.motor_reversals[0] = 5;
  s.board_reversals = 12;
  m = play_model(events, boards, 0.5, 440.0);
  REQUIRE(m.motors.size() == 2);
  CHECK(m.motors[0].has_position);
  CHECK(m.motors[0].position_steps == 100);
  CHECK(m.motors[0].travel_steps == 400);
  CHECK(m.motors[0].reversals == 7);
  CHECK_FALSE(m.motors[0].switch_fault);
  CHECK(m.motors[1].position_steps == -250);
  CHECK(m.motors[1].reversals == 0);
  CHECK(m.motors[1].switch_fault);
  CHECK(m.links[0].reversals == 12);
  lines = console_lines(m, ConsoleFooter{}, 24, 80);
  // Row 0: its hits, then its carriage a quarter along the rail, then the board.
  CHECK(lines[2].text.substr(0, 34) == " 0  A4      440.00     +0      7  ");
  const std::string bar = lines[2].text.substr(34, lines[2].text.find(" ttyACM0") - 34);
  REQUIRE(bar.size() >= 7);
  CHECK(bar.front() == '|');
  CHECK(bar.back() == '|');
  const size_t at = bar.find('o');  // the carriage ('|' ends, ':' the middle)
  REQUIRE(at != std::string::npos);
  CHECK(std::fabs(double(at - 1) / double(bar.size() - 3) - 0.25) < 0.05);
  CHECK(lines[2].text.size() <= 80);
  CHECK(lines[2].text.substr(lines[2].text.size() - 8) == " ttyACM0");
  // Row 1: no rail (unlimited travel): its position in steps; its stuck switch said.
  CHECK(lines[3].text.find("pos -250") != std::string::npos);
  CHECK(lines[3].text.find("switch stuck") != std::string::npos);
  CHECK(lines[4].text.find("ends 12") != std::string::npos);
}
