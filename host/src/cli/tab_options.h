// tab_options.h: the command-line options of a guitar tab (.tab) song, which carries neither
// tempo nor tuning: `--tempo-bpm` and `--tuning`, shared by play, render, jam and gcode.
#ifndef STEPCHOIR_HOST_CLI_TAB_OPTIONS_H
#define STEPCHOIR_HOST_CLI_TAB_OPTIONS_H

#include <CLI/CLI.hpp>

#include <string>

#include "song/song.h"

namespace stepchoir {

struct TabArgs {
  double bpm = TabOptions{}.bpm;
  std::string tuning;  // "E2,A2,D3,G3,B3,E4"; empty: standard tuning
};

// Called by the commands' setup, before parsing.
inline void add_tab_options(CLI::App &app, TabArgs &a) {
  app.add_option("--tempo-bpm", a.bpm, "A .tab song's tempo, quarter notes a minute")
      ->check(CLI::Range(1.0, 1000.0))->default_val(a.bpm);
  app.add_option("--tuning", a.tuning, "A .tab song's open strings, low to high (default E2,A2,D3,G3,B3,E4, as a "
                                       "guitar sounds)");
}

// The reader's options from the command line. Called by the commands' run. Throws SongError
// for a bad --tuning.
inline TabOptions tab_options(const TabArgs &a) {
  TabOptions o;
  o.bpm = a.bpm;
  if (!a.tuning.empty()) o.tuning = parse_tuning(a.tuning);
  return o;
}

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_TAB_OPTIONS_H
