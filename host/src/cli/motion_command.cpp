// motion_command.cpp: see motion_command.h.
#include "cli/motion_command.h"

#include <cmath>
#include <cstdio>

#include "board/motion.h"
#include "config/rig.h"

namespace stepchoir {

MotionCommands add_motion_commands(CLI::App &app, const std::function<void(CLI::App *)> &board_options) {
  MotionCommands c;
  c.home = app.add_subcommand("home", "Run each motor with end switches to a switch, measure its rail where both ends "
                                      "have one, and leave the carriage in the middle");
  board_options(c.home);
  c.home->add_option("--motor,-m", c.motors, "Motor index (repeatable; default: every motor with switches)");
  c.jog = app.add_subcommand("jog", "Move one motor's carriage by a distance (mm, turns or steps; negative: down), on "
                                    "the acceleration ramp, stopping at a switch ahead");
  board_options(c.jog);
  c.jog->add_option("--motor,-m", c.motor, "Motor index")->default_val(0);
  auto *how = c.jog->add_option_group("distance");
  how->add_option("--mm", c.mm, "Millimetres (steps_per_mm)");
  how->add_option("--turns", c.turns, "Turns of the motor (steps_per_turn)");
  how->add_option("--steps", c.steps, "Steps");
  how->require_option(1);
  c.jog->add_flag("--ignore-switch", c.ignore_switch,
                  "Do not stop at a pressed switch ahead (to leave an end whose switch is one input for both ends)");
  c.center = app.add_subcommand("center", "Declare one motor's carriage to be in the middle of its rail (after jog)");
  board_options(c.center);
  c.center->add_option("--motor,-m", c.motor, "Motor index")->default_val(0);
  return c;
}

int MotionCommands::run(Board &board, const Caps &caps, const BoardSettings *settings, const std::string &port) const {
  board.send(watchdog_payload(sc::kWatchdogDefaultMs));  // a move stops if this program dies
  if (home->parsed()) {
    for (int m : motors)
      if (m < 0 || m >= caps.motor_count) {
        std::fprintf(stderr, "stepchoir home: --motor %d: the board has motors 0-%d\n", m, caps.motor_count - 1);
        return 2;
      }
    home_board(board, caps, settings, port, motors, say_line);
    return 0;
  }
  if (motor < 0 || motor >= caps.motor_count) {
    std::fprintf(stderr, "stepchoir %s: --motor %d: the board has motors 0-%d\n", jog->parsed() ? "jog" : "center",
                 motor, caps.motor_count - 1);
    return 2;
  }
  const uint8_t m = static_cast<uint8_t>(motor);
  const MotionSettings ms = motor_motion(settings, m);
  if (center->parsed()) {
    const int32_t middle = static_cast<int32_t>(motor_travel(settings, m) / 2);
    board.send(set_position_payload(m, middle));
    if (auto err = board.wait_reply(sc::kMsgError, 200)) {
      std::fprintf(stderr, "stepchoir center: the board refused: %s\n", sc::error_name((*err)[1]));
      return 1;
    }
    say_line(port + ": motor " + std::to_string(m) + ": the carriage is the middle of its rail, position " +
        std::to_string(middle));
    return 0;
  }
  const double want = steps != 0 ? double(steps) : turns != 0 ? turns * ms.steps_per_turn : mm * ms.steps_per_mm;
  const int64_t n = std::llround(want);
  const MoveResult r = move_motor(board, port, m, n, ms.max_speed, ms, !ignore_switch);
  if (r.end == sc::kMoveEndSwitch) {
    say_line(port + ": motor " + std::to_string(m) + ": stopped at the switch ahead after " + std::to_string(r.steps) +
        " of " + std::to_string(std::llabs(n)) + " steps (" + mm_text(r.steps, ms) + ")" +
        (r.steps <= 1 ? ": it reads pressed; --ignore-switch moves off it" : ""));
    return 0;
  }
  say_line(port + ": motor " + std::to_string(m) + ": moved " + std::to_string(r.steps) + " steps (" + mm_text(r.steps, ms) +
      "), position " + std::to_string(r.position));
  return 0;
}

}  // namespace stepchoir
