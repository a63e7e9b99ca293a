// jam_side.h: `stepchoir jam`'s live side: every board greeted for a song command (BoardRun),
// and the live path over the keyboard's motors of every board (start_jam).
#ifndef STEPCHOIR_HOST_CLI_JAM_SIDE_H
#define STEPCHOIR_HOST_CLI_JAM_SIDE_H

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "board/board.h"
#include "cli/console_model.h"
#include "config/board_memory.h"
#include "config/rig.h"
#include "live/midi_in.h"
#include "live/session.h"
#include "player/midi_clock.h"
#include "song/song.h"

namespace stepchoir {

// One board of play, render or jam: greeted and configured from the rig file.
struct BoardRun {
  std::string path;
  std::unique_ptr<Board> board;
  Caps caps;
  const BoardSettings *settings = nullptr;
  std::vector<uint8_t> song_ids;  // its motors that play the song
  std::vector<uint8_t> live_ids;  // jam: its motors the keyboard plays
  std::optional<uint64_t> id;     // a board on a port: its id (config/board_memory.h)
  std::optional<BoardRecord> known;
};

// What jam runs besides the song's players. Built and destroyed in member order, backwards on
// the way out: the MIDI input goes before the session and the clock queues it feeds.
struct JamSide {
  // --midi-clock: one clock queue and timeline a board's player.
  std::vector<std::unique_ptr<ClockQueue>> clock_queues;
  std::unique_ptr<LiveSession> session;
  std::unique_ptr<MidiIn> midi_in;
  std::vector<std::unique_ptr<MidiClockTimeline>> timelines;
  ConsoleSources console_sources;  // what jam's console shows besides the session
};

// The live path owns every board's link (its writer sends live notes first); the song goes
// through it (JamLink). The keyboard plays every board's live_ids, one pool, at each board's
// remembered crystal's rate, with the rig file's motors, policy, presets and controls (their
// motor numbers the pool's, as jam prints them: a motor the song plays is left out, with a
// warning). Opens the MIDI input (midi_selector on api_name), with --midi-clock a timeline a
// board over song_tempo, starts the session and prints jam's line of which motors play what. Throws what the rig file's presets or controls get
// wrong. Called from: `stepchoir jam`, once every board is greeted.
JamSide start_jam(const std::vector<BoardRun> &boards, const Rig &rig, Policy policy, const std::string &api_name,
                  const std::string &midi_selector, bool midi_clock, const std::vector<TempoPoint> &song_tempo);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_JAM_SIDE_H
