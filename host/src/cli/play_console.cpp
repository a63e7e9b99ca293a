// play_console.cpp: the console for `stepchoir play` (see play_console.h).
#include "cli/play_console.h"

#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <utility>

#include "cli/play_report.h"
#include "live/midi_in.h"

namespace stepchoir {

const char *const kPlayKeysHelp = "space:pause/resume  Esc:stop  q:quit";

PlayConsole::PlayConsole(std::vector<PlayBoard> boards, std::vector<std::vector<PlanEvent>> events, double a4_hz)
    : boards_(std::move(boards)),
      events_(std::move(events)),
      a4_hz_(a4_hz),
      frames_before_(boards_.size(), 0),
      reconnects_(boards_.size(), 0) {
  for (size_t b = 0; b < boards_.size(); ++b) shared_.push_back(std::make_unique<Shared>());
  footer_.keys = kPlayKeysHelp;
  // Until the first progress call (each board's clock sync first: a second or more), the song's
  // motors silent and the title saying why.
  ConsoleModel m = play_model(events_, boards_, -1, a4_hz_);
  m.song = "syncing with the board" + std::string(boards_.size() > 1 ? "s" : "");
  const size_t rows = terminal_.rows(), cols = terminal_.cols();
  if (rows > 0 && cols > 0) terminal_.draw(console_lines(m, footer_, rows, cols));
}

void PlayConsole::publish(size_t board, const PlayerStats &s) noexcept {
  if (board >= shared_.size()) return;
  std::unique_lock<std::mutex> hold(shared_[board]->lock, std::try_to_lock);
  if (hold.owns_lock()) shared_[board]->stats = s;
}

void PlayConsole::ended(size_t board, bool ok) noexcept {
  if (board < shared_.size() && !ok) shared_[board]->lost.store(true);
}

std::unique_ptr<PlayConsole> open_play_console(std::vector<PlayBoard> boards, std::vector<std::vector<PlanEvent>> events,
                                               double a4_hz) {
  if (!::isatty(0) || !::isatty(1)) return nullptr;
  try {
    return std::make_unique<PlayConsole>(std::move(boards), std::move(events), a4_hz);
  } catch (const std::exception &e) {
    std::printf("play: %s: the progress line instead\n", e.what());
    return nullptr;
  }
}

bool PlayConsole::update(const PlayerProgress &p, size_t board) {
  if (p.stats) publish(board, *p.stats);
  for (int key = terminal_.key(0); key != Terminal::kNoKey; key = terminal_.key(0)) {
    if (key == ' ' || key == 'p') {
      toggle_play_pause();
    } else if (key == 'q') {
      quit_ = true;
    } else if (key == Terminal::kEscape) {
      quit_ = true;
      footer_.notices.push_back("stop: every motor silenced");
    }
  }
  for (size_t b = 0; b < boards_.size(); ++b) {
    std::lock_guard<std::mutex> hold(shared_[b]->lock);
    boards_[b].stats = shared_[b]->stats;
    boards_[b].lost = shared_[b]->lost.load();
    if (boards_[b].stats.reconnects > reconnects_[b])
      footer_.notices.push_back(boards_[b].name + ": the board is back; the song goes on from where it is");
    reconnects_[b] = boards_[b].stats.reconnects;
  }
  ConsoleModel m = play_model(events_, boards_, p.position_s, a4_hz_);
  m.song = std::string(p.paused ? "paused " : "playing ") + clock_text(p.position_s) + " / " +
           clock_text(p.duration_s) + (p.loop > 0 ? "  loop " + std::to_string(p.loop + 1) : "");
  // Frames a second since the previous redraw.
  const uint64_t now = monotonic_us();
  const double dt_s = last_us_ ? (now - last_us_) / 1e6 : 0;
  for (size_t b = 0; b < m.links.size(); ++b) {
    if (dt_s > 0) m.links[b].frames_per_s = (m.links[b].frames_sent - frames_before_[b]) / dt_s;
    frames_before_[b] = m.links[b].frames_sent;
  }
  last_us_ = now;
  const size_t rows = terminal_.rows(), cols = terminal_.cols();
  if (rows > 0 && cols > 0) terminal_.draw(console_lines(m, footer_, rows, cols));
  return !quit_;
}

}  // namespace stepchoir
