// link_repair.h: one board's way back after its link failed, for the commands that run a
// LiveSession (live, jam).
#ifndef STEPCHOIR_HOST_CLI_LINK_REPAIR_H
#define STEPCHOIR_HOST_CLI_LINK_REPAIR_H

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "board/board.h"
#include "config/rig.h"
#include "live/session.h"

namespace stepchoir {

// One board's way back after its link failed: repair_link parks the board's threads (the old
// link may close only once they no longer touch it: a serial write can block for a second),
// then reopens the port every 500 ms until a board with as many motors is greeted, configures
// its motors again (the open reset it: it runs on defaults) and hands the session the new link,
// which restores what should be sounding. One step a call, so the caller's console keeps its
// keys meanwhile.
//
// A board that restarted with its link up (BoardStats::restarted: its reset button) goes the
// same way without the reopen: its threads parked, it is asked for its capabilities on the
// link it has, configured again and handed back, which restores what should be sounding. A
// board that stopped answering (BoardStats::heard_us, Board::kSilentMs: a Mega reset with its
// link up, held in its bootloader by the bytes that kept coming) keeps its link too, but gets
// nothing on it until its firmware announces itself (Board::kQuietWaitMs at most). If either
// does not answer there, its port is opened again as after a loss.
struct LinkRepair {
  enum class State : uint8_t { kUp, kParking, kReopening } state = State::kUp;
  enum class Cause : uint8_t { kLost, kRestarted, kSilent } cause = Cause::kLost;
  std::chrono::steady_clock::time_point next_try{}, quiet_until{};
};

// Called from: the thread that keeps the session's links (live's main loop, jam's link keeper),
// every pass, for board b on `path` with `motors` motors (`settings`: the rig file's, or null).
// boards[b] owns the board's link; a new one replaces it. say: what the performer reads (lost,
// reconnected); note: detail for the log. True while board b is being reconnected.
bool repair_link(LiveSession &session, size_t b, const std::string &path, size_t motors, const BoardSettings *settings,
                 std::vector<std::unique_ptr<Board>> &boards, LinkRepair &r,
                 const std::function<void(const std::string &)> &say, const std::function<void(const std::string &)> &note);

// A thread that runs repair_link for every board of a session, every 20 ms, until destroyed
// (jam: its players run on other threads). boards[b] owns board b's link, as for repair_link;
// say: what the performer reads. Called from: the command's main thread (create, destroy).
class LinkKeeper {
 public:
  struct Port {
    std::string path;
    size_t motors = 0;
    const BoardSettings *settings = nullptr;  // the rig file's, or null
  };
  LinkKeeper(LiveSession &session, std::vector<Port> ports, std::vector<std::unique_ptr<Board>> &boards,
             std::function<void(const std::string &)> say);
  ~LinkKeeper();
  LinkKeeper(const LinkKeeper &) = delete;
  LinkKeeper &operator=(const LinkKeeper &) = delete;

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_LINK_REPAIR_H
