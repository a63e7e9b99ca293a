// motion_command.h: `stepchoir home`, `jog` and `center`: a carriage to the middle of its rail
// before a song (board/motion.h), on the board at --port (or the rig file's first board).
#ifndef STEPCHOIR_HOST_CLI_MOTION_COMMAND_H
#define STEPCHOIR_HOST_CLI_MOTION_COMMAND_H

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

#include "board/board.h"
#include "config/config.h"

namespace stepchoir {

struct MotionCommands {
  CLI::App *home = nullptr, *jog = nullptr, *center = nullptr;
  std::vector<int> motors;  // home: --motor (repeatable; none = every motor with switches)
  int motor = 0;            // jog, center
  double mm = 0, turns = 0;
  long steps = 0;
  bool ignore_switch = false;
  // Runs the command that was parsed on an open, greeted board whose motors the rig file
  // configured. Returns the exit code; throws std::runtime_error for a board's refusal.
  int run(Board &board, const Caps &caps, const BoardSettings *settings, const std::string &port) const;
  bool parsed() const { return home->parsed() || jog->parsed() || center->parsed(); }
};

// Adds the three subcommands to app; `board_options` adds --port and --config to each.
// Called from: main, once, before parsing.
MotionCommands add_motion_commands(CLI::App &app, const std::function<void(CLI::App *)> &board_options);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_MOTION_COMMAND_H
