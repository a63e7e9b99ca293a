// gcode_command.h: the `stepchoir gcode` subcommand (song file -> G-code file for a 3D printer).
#ifndef STEPCHOIR_HOST_SONG_GCODE_COMMAND_H
#define STEPCHOIR_HOST_SONG_GCODE_COMMAND_H

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "cli/tab_options.h"

namespace stepchoir {

// The subcommand's options, filled by CLI11.
struct GcodeCommand {
  CLI::App *app = nullptr;
  std::string song, out, printer, printer_file, steps_per_mm, volume, max_feed, channels, kinematics, flavor;
  double steps_per_cycle = 0;
  bool home = false, fold_octaves = false, use_g1 = false, extruder = false, keep_limits = false;
  TabArgs tab;

  // Reads the song, plans and writes the G-code; returns the exit code (errors on stderr).
  // Called by main after parsing.
  int run() const;
};

// Adds `gcode` to the command line. Called by main before parsing.
std::unique_ptr<GcodeCommand> add_gcode_command(CLI::App &app);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_SONG_GCODE_COMMAND_H
