// jam_console.h: the console (console.h) for `stepchoir jam`: the keyboard's motors (numbered
// as the rig counts them, with the song's), each board's link and its song clock, and where
// the song is. Drawn from the song player's progress callback on the main thread, which is
// then the keyboard session's stage queue's one producer; no real-time thread draws or waits.
#ifndef STEPCHOIR_HOST_CLI_JAM_CONSOLE_H
#define STEPCHOIR_HOST_CLI_JAM_CONSOLE_H

#include <atomic>
#include <string>
#include <vector>

#include "cli/console.h"
#include "cli/console_model.h"
#include "live/midi_in.h"
#include "live/session.h"
#include "player/player.h"

namespace stepchoir {

class JamConsole {
 public:
  // Takes the terminal (Console; throws as it does). sources: the keyboard's pool, its boards'
  // names, each motor's rig number and travel, the allocator's configuration; learn_path: the
  // rig file learned controls go to. Called from: jam, on the main thread, once the session runs.
  JamConsole(ConsoleSources sources, std::string learn_path);

  // Board b's song clock as its player's fit has it now. Called from: board b's player
  // thread, in its progress callback. Does not allocate or lock.
  void publish_clock(size_t board, const PlayerStats &s) noexcept;
  // Applies the keys typed since the last call, then redraws. False once q was pressed.
  // Called from: player 0's progress callback (the main thread), about every 100 ms.
  bool update(LiveSession &session, const PlayerProgress &p, const MidiIn *midi);

 private:
  ConsoleSources sources_;
  Console console_;
  ConsoleSampler sampler_;
  std::vector<std::atomic<double>> ppm_, residual_us_;  // by board
  std::vector<std::atomic<bool>> has_clock_;            // by board
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_JAM_CONSOLE_H
