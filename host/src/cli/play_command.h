// play_command.h: the `stepchoir play`, `render` and `jam` subcommands (a song file through the
// motors, in real time or as fast as the virtual board runs, or with a keyboard on top).
#ifndef STEPCHOIR_HOST_PLAYER_PLAY_COMMAND_H
#define STEPCHOIR_HOST_PLAYER_PLAY_COMMAND_H

#include <CLI/CLI.hpp>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "cli/tab_options.h"

namespace stepchoir {

// Options both commands share: what of the song plays, and how.
struct SongSelection {
  double tempo = 1.0, start_s = 0;
  int transpose = 0;
  std::vector<int> tracks, channels, mute_tracks, mute_channels;  // channels 1-16 as musicians count
  double min_note_ms = 10;
  int drums = -1;                          // board motor for percussion bursts, -1: none
  std::vector<std::string> keep, voices;   // --keep melody,bass,inner; --voices t2,c10
  TabArgs tab;                             // a .tab song's tempo and tuning
};

struct PlayCommand {
  CLI::App *play = nullptr, *render = nullptr, *jam = nullptr;
  std::string song;
  std::string config;  // rig file ("" = the default location, if a file is there)
  SongSelection sel;
  // play
  std::vector<std::string> ports;  // boards (none: the rig's, else the virtual board)
  std::vector<std::string> vboards;  // without ports: the virtual boards to start (rig_vboards)
  std::string vboard_trace, vboard_link;    // vboard_link: empty = its default
  double clock_ppm = 0, sync_s = 1.0;
  double reconnect_s = -1;  // play: a lost board is retried this long (< 0: PlayerOptions' default)
  double lead_ms = 0;  // 0: kLeadMs, or kClockLeadMs following a MIDI clock
  bool loop = false, quiet = false, no_auto_tune = false;
  int dry_run_motors = 0;  // > 0: print the plan for that many motors, play nothing
  // render
  std::string out_wav, out_png, keep_trace;
  // jam
  std::string midi, midi_api;  // "": the rig file's [midi] input and api (virtual, alsa)
  std::string policy;           // "": the rig file's [allocation] policy (poly)
  std::vector<int> song_motors{0, 1};  // pool numbers: the boards' motors in board order
  bool midi_clock = false;             // the song follows the MIDI input's clock
  // A note goes to the board this long before it plays: room for the host's stalls. Following a
  // MIDI clock, a note's time is the clock's grid laid that far ahead: a shorter lead fits it
  // through more ticks after a tempo change.
  static constexpr double kLeadMs = 300, kClockLeadMs = 100;
  bool plain = false;                  // play, jam: the progress line, not the console, on a terminal

  // Called by main after parsing; returns the exit code (errors on stderr). stop: Ctrl-C
  // (the q key sets it too).
  int run(std::atomic<bool> &stop) const;
};

// Adds `play`, `render` and `jam` to the command line. Called by main before parsing.
std::unique_ptr<PlayCommand> add_play_commands(CLI::App &app);

// Toggles pause in a running `play` (SIGUSR1 does the same, for scripts). Called from: the
// signal handler main installs.
void toggle_play_pause();

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_PLAYER_PLAY_COMMAND_H
