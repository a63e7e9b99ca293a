// live_cli.h: the `stepchoir live` command: MIDI in, motors out, the console (or a status
// line), clean exit.
#ifndef STEPCHOIR_HOST_LIVE_CLI_H
#define STEPCHOIR_HOST_LIVE_CLI_H

#include <atomic>
#include <string>
#include <vector>

#include "board/board.h"
#include "config/config.h"

namespace stepchoir {

// Empty strings: not given on the command line (the config file's value, else its default).
struct LiveOptions {
  std::string config;                    // TOML file ("" = the default location, if a file is there)
  std::string midi;                      // MidiIn selector: index, name substring, virtual[:NAME]
  std::string midi_api;                  // alsa | jack
  std::vector<std::string> ports;        // boards; none (and none in the file): the virtual board
  std::string policy;                    // poly | channel | mono
  std::string vboard_board;              // board the virtual board simulates ("": the rig
                                         // file's, one per board: config/rig.h rig_vboards)
  std::string vboard_trace;              // the virtual board's trace CSV ("" = none)
  bool quiet = false;                    // no console, no status line
  bool plain = false;                    // the status line even on a terminal (no console)
  bool learn = false;                    // MIDI learn from standard input (cli/learn_prompt.h)
};

// Runs until *stop is set (Ctrl-C, SIGTERM) or a board's link fails; silences every motor
// before it returns. Returns the process exit status; prints errors on stderr.
// Called from: main().
int run_live(const LiveOptions &options, const std::atomic<bool> &stop);

// `stepchoir ports`' MIDI part: the inputs of one API, one "index: name" a line, or why none.
// Called from: main().
void print_midi_inputs(const std::string &midi_api);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_CLI_H
