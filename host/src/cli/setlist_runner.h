// setlist_runner.h: live's setlist: the performer steps through the rig file's [setlist] items
// (setlist_next and setlist_previous, from a learned controller or a console key). Entering an
// item selects its preset and starts its song, jam style: one Player a board on the song's
// motors, its frames through the live writer (cli/jam_link.h), while the keyboard plays the
// other motors. Stepping away from a song ends it; a song that ends leaves the item as it is.
#ifndef STEPCHOIR_HOST_CLI_SETLIST_RUNNER_H
#define STEPCHOIR_HOST_CLI_SETLIST_RUNNER_H

#include <atomic>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "board/board.h"
#include "config/board_memory.h"
#include "config/config.h"
#include "live/session.h"
#include "player/plan.h"
#include "player/player.h"
#include "player/start_gate.h"

namespace stepchoir {

// One board of the live pool, as the setlist's songs need it.
struct SetlistBoard {
  std::string path;                         // its port, for names and messages
  Caps caps;                                // from its hello
  const BoardSettings *settings = nullptr;  // the rig file's entry, if any
  std::optional<BoardRecord> known;         // a board met before: its crystal (board_memory.h)
  std::optional<uint64_t> id;               // its id, when it has one: each song's measure of its
                                            // crystal is remembered under it
};

class SetlistRunner {
 public:
  // Reads and plans every song (its motors' ranges from the rig file). Throws std::runtime_error
  // "WHERE: ..." for a song motor the pool lacks or a song that cannot be read.
  // Called from: run_live, before the session starts.
  SetlistRunner(std::vector<SetlistItem> items, std::vector<SetlistBoard> boards, double a4_hz);
  ~SetlistRunner();
  SetlistRunner(const SetlistRunner &) = delete;
  SetlistRunner &operator=(const SetlistRunner &) = delete;

  // Whether an item plays a song: the session must then forward every board's replies.
  bool has_songs() const;
  // Enters item 0 the first time; then applies the setlist presses since the last call
  // (LiveSession::take_setlist_steps), clamped to the list, and notices a song's end. Prints
  // "live: setlist N/M NAME" on entering an item. Called from: run_live's loop, the main thread
  // (the stage queue's producer), every 100 ms.
  void poll(LiveSession &session);
  // Where the runner's messages ("setlist N/M NAME") go from now on; by default a "live: "
  // line on stdout. Called from: run_live (the console takes them), before poll().
  void set_say(std::function<void(const std::string &)> say) { say_ = std::move(say); }
  // Ends a song that plays (every player stopped and joined, its motors given back).
  // Called from: run_live, before session.stop().
  void stop(LiveSession &session);

  size_t position() const { return position_; }
  size_t size() const { return items_.size(); }
  const SetlistItem &item() const { return items_[position_]; }
  bool song_playing() const { return !threads_.empty(); }
  // The pool motors the song plays now (bit m: motor m), 0 without a song.
  uint32_t song_motors() const { return song_playing() ? plans_[position_].pool_motors : 0; }

 private:
  // A song item's plan split per board: each board's events (board motor = its song_ids[i])
  // and the board motors it plays.
  struct SongPlan {
    std::vector<std::vector<PlanEvent>> events;
    std::vector<std::vector<uint8_t>> song_ids;
    double duration_s = 0;
    uint32_t pool_motors = 0;
  };
  void enter(size_t index, LiveSession &session);
  // Every song's end (its own, a step away, stop): what each player measured of its board's
  // crystal, unless it lost the board for good, is where the board's next song starts, and is
  // remembered (config/board_memory.h) for a board with an id, as play does.
  void end_song(LiveSession &session);

  std::vector<SetlistItem> items_;
  std::vector<SetlistBoard> boards_;
  std::vector<SongPlan> plans_;  // one an item (empty for an item without a song)
  double a4_hz_;
  bool started_ = false;
  size_t position_ = 0;
  // The song that plays: one player and thread a board.
  std::atomic<bool> stop_song_{false}, pause_{false};
  std::atomic<size_t> finished_{0};
  std::unique_ptr<StartGate> gate_;
  std::vector<std::unique_ptr<Player>> players_;
  std::vector<size_t> player_boards_;  // players_[k] plays on boards_[player_boards_[k]]
  std::vector<char> board_ok_;  // board b's player did not lose it for good (its thread's run(); read after join)
  std::vector<std::thread> threads_;
  std::function<void(const std::string &)> say_ = [](const std::string &line) {
    std::printf("live: %s\n", line.c_str());
    std::fflush(stdout);
  };
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_SETLIST_RUNNER_H
