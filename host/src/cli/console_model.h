// console_model.h: what the live console (and the plain status line) shows, as a plain
// snapshot: a row a motor, a row a board's link, latency, the MIDI input and its last events,
// preset, stage transpose, setlist, and warnings in plain words.
//
// ConsoleSampler fills a ConsoleModel from a LiveSession on the main thread (it reads the
// session's atomics: never a lock, never the real-time threads' time); the pieces that compute
// (pitch and cents from a period, a link's health and rate, event text, warnings) are pure and
// tested without a terminal (tests/host/test_console.cpp). console_view.h lays a model out on
// a screen; console.h draws it with curses.
#ifndef STEPCHOIR_HOST_CLI_CONSOLE_MODEL_H
#define STEPCHOIR_HOST_CLI_CONSOLE_MODEL_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "live/allocator.h"
#include "live/board_link.h"
#include "live/session.h"
#include "player/plan.h"
#include "player/player.h"

namespace stepchoir {

struct ConsoleMotor {
  size_t number = 0;           // the rig's number for it (jam: counted with the song's motors)
  int note = -1;               // the MIDI note it plays (transposed, folded), -1 when silent
  double hz = 0;               // what it plays now: its period on its board's clock
  double cents = 0;            // now against the note's own pitch (tuning included): bend, vibrato, glide
  bool muted = false;          // muted on stage (a console key or a learned control)
  bool has_position = false;   // a status reply said where the carriage is
  int32_t position_steps = 0;  // 0 .. travel_steps, the middle at travel_steps / 2
  uint32_t travel_steps = 0;   // the rail (config/rig.h motor_travel)
  bool switch_fault = false;   // the board ignores its stuck end switch
  uint16_t reversals = 0;      // endstop hits: its reversals at a switch or a soft limit (wraps; with has_position)
  bool song = false;           // a setlist song plays it, not the keyboard
  std::string board;           // play: the port of the board it is on ("" : not shown)
};

struct ConsoleLink {
  std::string name;             // the port
  std::string health;           // "ok", "no answer", "watchdog", "write failed", "read failed", "reconnecting"
  bool healthy = false;         // health is "ok"
  uint64_t frames_sent = 0;
  double frames_per_s = 0;      // over the time since the previous sample
  uint64_t board_errors = 0;    // error replies
  std::string last_error;       // the latest one's name ("" when none)
  uint32_t bad_frames = 0;      // frames the board refused (CRC, framing)
  uint32_t reconnects = 0;
  uint16_t reversals = 0;       // endstop hits of all its motors: reversals at a switch or a soft limit (wraps)
  bool has_clock = false;       // jam: the song player's fit of the board's clock
  double clock_ppm = 0;         // its rate against the nominal crystal
  double clock_residual_us = 0; // how far the samples sit from the fit
};

struct ConsoleEvent {
  std::string text;     // "on  ch1 C4 64", "cc1 ch2 = 127"
  uint64_t age_ms = 0;  // how long ago it came
};

struct ConsoleModel {
  std::string command = "live";       // live | jam | play (play: no MIDI, latency, preset, setlist)
  std::string song;                   // jam: where the song is ("playing 0:12 / 1:30"); live: ""
  std::vector<ConsoleMotor> motors;   // the pool's, in pool order
  std::vector<ConsoleLink> links;     // by board
  uint64_t latency_p50_us = 0, latency_p99_us = 0;
  uint64_t events = 0;                // MIDI events the engine applied
  std::string midi_input;             // its name; "" while it is gone
  std::vector<ConsoleEvent> recent;   // the last events, newest first
  int preset = -1;                    // index, -1 without presets
  size_t preset_count = 0;
  int preset_program = 0;             // 1-128, as the keyboard shows it
  std::string preset_name;
  int transpose = 0;                  // the stage transpose, semitones
  int setlist_item = -1;              // index, -1 without a setlist
  size_t setlist_count = 0;
  std::string setlist_name;
  std::vector<std::string> warnings;  // plain words, most urgent first
};

// What the sampler needs besides the session; the main thread keeps it up to date.
struct ConsoleSources {
  std::string command = "live";
  std::vector<std::string> board_names;  // by board
  std::vector<bool> reconnecting;        // by board: its link failed and its port is being reopened
  std::vector<uint32_t> travel_steps;    // by pool motor
  std::vector<size_t> motor_numbers;     // by pool motor: the rig's number (empty: the pool's)
  AllocatorConfig music;                 // each motor's clock and tuning, A4 (a preset's replaces it)
  std::string midi_input;                // "" while the input is gone
  uint64_t midi_dropped = 0;             // events the MIDI callback could not queue
  // jam: by board, the song player's clock (has_clock false where there is none), and where
  // the song is.
  std::vector<ConsoleLink> clocks;
  std::string song;
  // live: the setlist's item (index, -1 without a setlist), its size and the item's name, and
  // the pool motors its song plays now (bit m: motor m).
  int setlist_item = -1;
  size_t setlist_count = 0;
  std::string setlist_name;
  uint32_t song_motors = 0;
};

// "C4", "F#5": a MIDI note's name (middle C is C4), "--" for none (-1). Pure.
std::string motor_note_name(int note);

// Fills row->note, hz and cents for a motor that plays `note` (-1: silent) at period_q8 (board
// ticks q8, 0: silent) with `music`'s clock and tuning at a4_hz. Pure.
void motor_pitch(int note, uint32_t period_q8, const MotorConfig &music, double a4_hz, ConsoleMotor *row);

// A MIDI channel message in a few characters: "on  ch1 C4 64", "off ch1 C4", "cc7 ch1 = 100",
// "prog ch1 5" (1-128), "bend ch1 +2048", "pres ch1 90", "poly ch1 C4 90". Pure.
std::string describe_event(uint8_t status, uint8_t data1, uint8_t data2);

// A board link's row from its stats: health (reconnecting: the main thread is reopening its
// port; a status reply within the last 2.5 s is an answer), counters, frames/s from the
// frames sent since frames_before, dt_s ago (0: no rate yet). Pure but for the atomics' reads.
ConsoleLink link_row(const BoardStats &st, const std::string &name, bool reconnecting, uint64_t now_us,
                     uint64_t frames_before, double dt_s);

// Keeps what the warnings need across samples: a counter that rose in the last kRecentS is
// news (errors, bad frames, dropped events); a state (link lost, MIDI gone, stuck switch)
// warns while it lasts.
class WarningTracker {
 public:
  static constexpr double kRecentS = 10;
  // Sets m->warnings from m and the MIDI callback's dropped count, now_us on any clock that
  // only moves on. Called from: ConsoleSampler, tests.
  void update(ConsoleModel *m, uint64_t midi_dropped, uint64_t now_us);

 private:
  struct Counter {
    uint64_t value = 0;
    uint64_t rose_us = 0;  // when it last rose, 0: never
  };
  bool rose(Counter *c, uint64_t value, uint64_t now_us);
  std::vector<Counter> errors_, bad_;
  Counter dropped_;
  bool first_ = true;
};

// Fills models from a session: one a redraw. Called from: the main thread (run_live, jam's
// progress callback). Allocates (strings); reads only atomics of the session.
class ConsoleSampler {
 public:
  ConsoleModel sample(const LiveSession &session, const ConsoleSources &sources, uint64_t now_us);

 private:
  std::vector<uint64_t> frames_;  // by board, at the previous sample
  uint64_t last_us_ = 0;
  WarningTracker warnings_;
};

// What `stepchoir play` knows of one board while the song plays.
struct PlayBoard {
  std::string name;      // the port
  size_t motors = 0;     // its motors that play the song (plan motors, in board order)
  PlayerStats stats;     // its player's, as last published
  bool lost = false;     // its player gave up (the board is gone): its notes are dropped
  std::vector<uint8_t> board_motor;     // by plan motor: its number on the board
  std::vector<uint32_t> travel_steps;   // by plan motor: its rail (config/rig.h motor_travel)
};

// The play console's model at position_s of the song: a row a song motor of every board (numbered
// across the boards in order), its note and Hz those of its latest event at or before position_s
// (A4 at a4_hz; silent: note -1), its carriage and endstop hits from the board's latest status
// reply; a link row a board from its player's stats (frames, errors, endstop hits,
// reconnects, song clock; frames_per_s 0: the caller rates them); warnings for late entries, a
// board being reopened (its stats' reconnecting) and boards lost for good. events: by board, plan_events() with the board's motor numbers, in time order.
// Pure. Called from: PlayConsole, tests.
ConsoleModel play_model(const std::vector<std::vector<PlanEvent>> &events, const std::vector<PlayBoard> &boards,
                        double position_s, double a4_hz);

// The plain status line (no console: --plain, or stdout not a terminal): each motor's note,
// each link's health and frames, events and latency. Pure.
std::string status_line(const ConsoleModel &m);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_CONSOLE_MODEL_H
