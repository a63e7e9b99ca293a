// link_repair.cpp: see link_repair.h.
#include "cli/link_repair.h"

#include <stdexcept>

#include "board/link.h"

namespace stepchoir {

bool repair_link(LiveSession &session, size_t b, const std::string &path, size_t motors, const BoardSettings *settings,
                 std::vector<std::unique_ptr<Board>> &boards, LinkRepair &r,
                 const std::function<void(const std::string &)> &say, const std::function<void(const std::string &)> &note) {
  using State = LinkRepair::State;
  const BoardStats &st = session.board_stats(b);
  if (r.state == State::kUp) {
    const bool failed = st.write_failed.load() || st.read_failed.load();
    if (!failed && !st.restarted.load()) return false;
    say(path + (failed ? ": link lost; reconnecting" : ": the board restarted; setting it up again"));
    r.restarted = !failed;
    r.state = State::kParking;
  }
  if (r.state == State::kParking) {
    if (!session.detach_link(b)) {
      note(path + ": the board's threads are still using the lost link; waiting");
      return true;
    }
    if (!r.restarted) boards[b].reset();
    r.state = State::kReopening;
  }
  const auto now = std::chrono::steady_clock::now();
  if (now < r.next_try) return true;
  try {
    // A board that restarted with its link up keeps its link: asked, it answers once its
    // firmware runs. Else the port is opened again (a reset and its bootloader, waited out).
    std::unique_ptr<Board> board = r.restarted ? std::move(boards[b]) : std::make_unique<Board>(open_link(path));
    const Caps caps = r.restarted ? board->hello() : board->greet(Board::kBootWaitMs, 600);
    if (caps.motor_count != motors)
      throw std::runtime_error("it has " + std::to_string(caps.motor_count) + " motors, not " + std::to_string(motors));
    if (settings) configure_motors(*board, caps, *settings, path);
    session.attach_link(b, &board->link());
    boards[b] = std::move(board);
    r.state = State::kUp;
    say(path + (r.restarted ? ": set up again" : ": reconnected"));
    return false;
  } catch (const std::exception &e) {
    note(path + ": " + e.what());
    if (r.restarted) {  // it does not answer on the old link: open the port again
      r.restarted = false;
      boards[b].reset();
    }
    r.next_try = now + std::chrono::milliseconds(500);
    return true;
  }
}

LinkKeeper::LinkKeeper(LiveSession &session, std::vector<Port> ports, std::vector<std::unique_ptr<Board>> &boards,
                       std::function<void(const std::string &)> say)
    : thread_([this, &session, ports = std::move(ports), &boards, say = std::move(say)] {
        std::vector<LinkRepair> repairs(ports.size());
        const auto note = [](const std::string &) {};
        while (!stop_.load()) {
          for (size_t b = 0; b < ports.size(); ++b)
            repair_link(session, b, ports[b].path, ports[b].motors, ports[b].settings, boards, repairs[b], say, note);
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
      }) {}

LinkKeeper::~LinkKeeper() {
  stop_ = true;
  thread_.join();
}

}  // namespace stepchoir
