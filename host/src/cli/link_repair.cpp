// link_repair.cpp: see link_repair.h.
#include "cli/link_repair.h"

#include <stdexcept>

#include "board/link.h"
#include "live/midi_in.h"

namespace stepchoir {

bool repair_link(LiveSession &session, size_t b, const std::string &path, size_t motors, const BoardSettings *settings,
                 std::vector<std::unique_ptr<Board>> &boards, LinkRepair &r,
                 const std::function<void(const std::string &)> &say, const std::function<void(const std::string &)> &note) {
  using State = LinkRepair::State;
  using Cause = LinkRepair::Cause;
  const BoardStats &st = session.board_stats(b);
  if (r.state == State::kUp) {
    // Silent: the reader, listening now, has heard nothing for so long.
    const uint64_t read = st.read_us.load(std::memory_order_acquire);  // before heard_us (the reader's order)
    const uint64_t heard = st.heard_us.load(), now_us = monotonic_us();
    const bool failed = st.write_failed.load() || st.read_failed.load();
    const bool silent = heard && now_us < read + kReaderGapUs && now_us > heard + uint64_t(Board::kSilentMs) * 1000;
    if (!failed && !st.restarted.load() && !silent) return false;
    r.cause = failed ? Cause::kLost : st.restarted.load() ? Cause::kRestarted : Cause::kSilent;
    say(path + (r.cause == Cause::kLost        ? ": link lost; reconnecting"
                : r.cause == Cause::kRestarted ? ": the board restarted; setting it up again"
                                               : ": the board stopped answering; waiting for it in silence"));
    r.state = State::kParking;
  }
  if (r.state == State::kParking) {
    if (!session.detach_link(b)) {
      note(path + ": the board's threads are still using the lost link; waiting");
      return true;
    }
    if (r.cause == Cause::kLost) boards[b].reset();
    r.quiet_until = std::chrono::steady_clock::now() + std::chrono::milliseconds(Board::kQuietWaitMs);
    r.state = State::kReopening;
  }
  const auto now = std::chrono::steady_clock::now();
  try {
    std::unique_ptr<Board> board;
    Caps caps;
    if (r.cause == Cause::kSilent) {
      // Nothing goes to the board meanwhile (its threads are parked): a bootloader that bytes
      // held lets the firmware start, which says so. One short listen a call.
      auto reply = boards[b]->wait_reply(sc::kMsgCaps, 20);
      if (!reply) {
        if (now < r.quiet_until) return true;
        throw std::runtime_error("no word from it in " + std::to_string(Board::kQuietWaitMs) + " ms of silence");
      }
      caps = parse_caps(reply->data(), reply->size());
      board = std::move(boards[b]);
    } else {
      if (now < r.next_try) return true;
      // A board that restarted with its link up keeps its link: asked, it answers once its
      // firmware runs. Else the port is opened again (a reset and its bootloader, waited out).
      const bool kept = r.cause == Cause::kRestarted;
      board = kept ? std::move(boards[b]) : std::make_unique<Board>(open_link(path));
      caps = kept ? board->hello() : board->greet(Board::kBootWaitMs, 600);
    }
    if (caps.motor_count != motors)
      throw std::runtime_error("it has " + std::to_string(caps.motor_count) + " motors, not " + std::to_string(motors));
    if (settings) configure_motors(*board, caps, *settings, path);
    session.attach_link(b, &board->link());
    boards[b] = std::move(board);
    r.state = State::kUp;
    say(path + (r.cause == Cause::kLost ? ": reconnected" : ": set up again"));
    return false;
  } catch (const std::exception &e) {
    note(path + ": " + e.what());
    if (r.cause != Cause::kLost) {  // it does not answer on the old link: open the port again
      r.cause = Cause::kLost;
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
