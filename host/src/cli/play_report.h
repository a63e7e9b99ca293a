// play_report.h: what `stepchoir play`, `render` and `jam` print: the plan, the arrangement,
// the progress line and the report at the end; and the keys that pause and stop a song.
#ifndef STEPCHOIR_HOST_CLI_PLAY_REPORT_H
#define STEPCHOIR_HOST_CLI_PLAY_REPORT_H

#include <termios.h>
#include <unistd.h>

#include <optional>
#include <string>

#include "config/board_memory.h"
#include "player/plan.h"
#include "player/player.h"
#include "song/song.h"

namespace stepchoir {

// "1:05" for 65 s. Called from: the progress line, the plan's summary.
std::string clock_text(double s);

// The dry run's summary: per track and channel, notes kept (and of them folded, and as which
// role), and notes left out by reason. Called from: PlayCommand::run.
void report_arrangement(const Song &song, const Plan &plan);

// Prints what the plan leaves out. Called from: PlayCommand::run.
void report_plan(const std::string &cmd, const Song &song, const Plan &plan, size_t motors);

// The progress line on stderr ("playing 0:12 / 1:05 [###...] late 0"). Called from: the
// player's progress callback.
void print_progress(const PlayerProgress &p);

// The report at the end of one board's song: entries, frames, errors, the board's clock and
// its own counters. who: the command, or "play: PORT" with several boards. Called from:
// PlayCommand::run.
void report_player(const std::string &who, const PlayerStats &s, bool ok, bool stopped, bool real_time);

// A board on a port: reads its id (giving a new board one) and what the host remembers of it,
// and says so ("play: board ID met before: crystal +2493.7 ppm"). A board memory that cannot
// be read is reported and left aside. Called from: PlayCommand::run, after the greeting.
void recall(const std::string &cmd, const std::string &port, Board &board, std::optional<uint64_t> *id,
            std::optional<BoardRecord> *known);

// Keeps what the song measured of board id's crystal (config/board_memory.h); a failure is
// reported, not fatal. Called from: PlayCommand::run, after the song.
void remember(const std::string &cmd, uint64_t id, const BoardRecord &record);

// Toggles pause (the keys, SIGUSR1). Defined by play_command.cpp.
void toggle_play_pause();

// Keys on a terminal: space or p pauses and resumes, q stops. Raw mode while it lives.
class Keys {
 public:
  // Called from: PlayCommand::run. Does nothing when stdin is no terminal.
  Keys() {
    if (!::isatty(0) || tcgetattr(0, &saved_) != 0) return;
    termios raw = saved_;
    raw.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 0;
    active_ = tcsetattr(0, TCSANOW, &raw) == 0;
  }
  ~Keys() {
    if (active_) tcsetattr(0, TCSANOW, &saved_);
  }
  // Called from: the progress callback. Applies the keys pressed since; true on q.
  bool poll() {
    if (!active_) return false;
    char c;
    while (::read(0, &c, 1) == 1) {
      if (c == ' ' || c == 'p') toggle_play_pause();
      if (c == 'q') return true;
    }
    return false;
  }

 private:
  termios saved_{};
  bool active_ = false;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_PLAY_REPORT_H
