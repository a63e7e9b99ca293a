// play_console.h: the console for `stepchoir play`: a row a song motor (the note it plays now
// and its Hz, from the plan's events at the player's position; its board), each board's link
// and song clock, where the song is, warnings (late entries, a lost board) and a message when a
// lost board is back. Drawn on the terminal (terminal.h) from player 0's progress callback on
// the main thread (also while player 0 reopens its lost board).
//
// Keys: space (or p) pauses and resumes, Esc stops the song (play has no stage to panic), q quits.
#ifndef STEPCHOIR_HOST_CLI_PLAY_CONSOLE_H
#define STEPCHOIR_HOST_CLI_PLAY_CONSOLE_H

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "cli/console_model.h"
#include "cli/console_view.h"
#include "cli/terminal.h"
#include "player/plan.h"
#include "player/player.h"

namespace stepchoir {

// The keys' help line.
extern const char *const kPlayKeysHelp;

class PlayConsole {
 public:
  // Takes the terminal (Terminal; throws as it does). boards: each board's port and its song
  // motors' count; events: by board, as its player has them (board motor numbers, time order);
  // a4_hz: the rig's. Called from: PlayCommand::run, on the main thread, before the players run.
  PlayConsole(std::vector<PlayBoard> boards, std::vector<std::vector<PlanEvent>> events, double a4_hz);

  // Board b's player's stats now. Called from: board b's player thread, in its progress
  // callback, and update(). Never waits (skips a publication while the main thread reads).
  void publish(size_t board, const PlayerStats &s) noexcept;
  // Board b's player ended: ok false while the song goes on means the board is lost.
  // Called from: board b's player thread, after Player::run.
  void ended(size_t board, bool ok) noexcept;
  // Takes p's stats as board b's, applies the keys typed since the last call, then redraws at
  // p's place in the song. False once q or Esc was pressed. Called from: the main thread about
  // every 100 ms: player 0's progress callback (b 0), and after player 0 ended, while another
  // board plays on, with that board's latest progress.
  bool update(const PlayerProgress &p, size_t b = 0);

 private:
  struct Shared {  // one a board, written by its player thread
    std::mutex lock;
    PlayerStats stats;
    std::atomic<bool> lost{false};
  };
  std::vector<PlayBoard> boards_;
  std::vector<std::vector<PlanEvent>> events_;
  double a4_hz_;
  std::vector<std::unique_ptr<Shared>> shared_;
  std::vector<uint64_t> frames_before_;
  std::vector<uint64_t> reconnects_;  // by board, at the previous redraw: a rise is a board back
  uint64_t last_us_ = 0;
  ConsoleFooter footer_;
  bool quit_ = false;
  Terminal terminal_;
};

// The play console when stdin and stdout are terminals, else (or when the terminal cannot: said
// on stdout) none. Called from: PlayCommand::run, unless --quiet or --plain.
std::unique_ptr<PlayConsole> open_play_console(std::vector<PlayBoard> boards, std::vector<std::vector<PlanEvent>> events,
                                               double a4_hz);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_PLAY_CONSOLE_H
