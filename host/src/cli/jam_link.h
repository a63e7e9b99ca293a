// jam_link.h: the song player's side of a board the live path drives (`stepchoir jam`, live's
// setlist): frames go to the board's live writer, which sends them when no live note waits;
// bytes come from its live reader (LiveSession::forward_replies must have been called).
#ifndef STEPCHOIR_HOST_CLI_JAM_LINK_H
#define STEPCHOIR_HOST_CLI_JAM_LINK_H

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <utility>

#include "board/board.h"
#include "board/link.h"
#include "config/rig.h"
#include "live/session.h"

namespace stepchoir {

class JamLink : public Link {
 public:
  JamLink(LiveSession &session, size_t board, std::string name) : session_(session), board_(board), name_(std::move(name)) {}
  // Called from: the song player's thread. Waits (up to a second) while the writer's song
  // queue is full.
  bool write(const uint8_t *data, size_t len) override {
    for (int i = 0; i < 1000; ++i) {
      if (session_.send_song_frame(board_, data, len)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  }
  long read(uint8_t *data, size_t len, int timeout_ms) override {
    return session_.read_board_bytes(board_, data, len, timeout_ms);
  }
  std::string name() const override { return name_ + " (song)"; }
  // The writer sends a queued frame within its 1 ms idle wait, or when the budget has room.
  uint64_t written_at_us() override { return session_.song_frame_written_us(board_, 50); }
  bool queues_writes() const override { return true; }

 private:
  LiveSession &session_;
  size_t board_;
  std::string name_;
};

// The song player's on_reopen (PlayerOptions) for board b of a session whose link keeper
// (cli/link_repair.h) also sets up a board that restarted: configures the rig file's motors
// unless the keeper attached a link since the last call (it configured them). Called from: the
// song player's thread, once the board answered again.
inline std::function<void(Board &, const Caps &)> configure_unless_kept(const LiveSession &session, size_t b,
                                                                       const BoardSettings &settings, std::string path) {
  return [&session, b, &settings, path = std::move(path),
          seen = std::make_shared<uint32_t>(session.board_stats(b).reconnects.load())](Board &board, const Caps &caps) {
    const uint32_t attached = session.board_stats(b).reconnects.load();
    if (attached != *seen) {
      *seen = attached;
      return;
    }
    configure_motors(board, caps, settings, path);
  };
}

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_JAM_LINK_H
