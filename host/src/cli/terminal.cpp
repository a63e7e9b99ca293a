// terminal.cpp: the consoles' terminal, with curses (see terminal.h).
#include "cli/terminal.h"

#include <unistd.h>

#include <stdexcept>

#define NCURSES_NOMACROS  // functions, not macros named erase, clear, move, timeout ...
#include <curses.h>

namespace stepchoir {
namespace {

constexpr int kEscapeDelayMs = 50;  // a lone Esc is a key this soon; an arrow's bytes come closer

// Colour pairs, by LineStyle (0: the terminal's own colours).
constexpr short kPairOf[] = {0, 0, 0, 1, 0, 2, 3, 0};

// curses attributes for a style: colours where the terminal has them, else bold, dim, reverse.
attr_t attributes(LineStyle s, bool colour) {
  const short pair = kPairOf[static_cast<int>(s)];
  attr_t a = colour && pair ? COLOR_PAIR(pair) : A_NORMAL;
  switch (s) {
    case LineStyle::kTitle:
    case LineStyle::kKeys: return a | A_REVERSE;
    case LineStyle::kHeading: return a | A_UNDERLINE;
    case LineStyle::kSounding:
    case LineStyle::kWarning: return a | A_BOLD;
    case LineStyle::kMuted: return a | A_DIM;
    default: return a;
  }
}

}  // namespace

Terminal::Terminal() {
  if (!::isatty(0) || !::isatty(1)) throw std::runtime_error("the console needs a terminal");
  SCREEN *screen = newterm(nullptr, stdout, stdin);
  if (!screen) throw std::runtime_error("the console cannot use this terminal (TERM)");
  set_term(screen);
  // A terminal that cannot move its cursor (TERM=dumb) would get every screen written one
  // after the other.
  char *const cup = tigetstr("cup");
  if (cup == nullptr || cup == reinterpret_cast<char *>(-1)) {
    endwin();
    delscreen(set_term(nullptr));
    throw std::runtime_error("the console needs a terminal that moves its cursor (TERM)");
  }
  cbreak();
  noecho();
  nonl();
  keypad(stdscr, TRUE);
  set_escdelay(kEscapeDelayMs);
  curs_set(0);
  if (has_colors()) {
    start_color();
    use_default_colors();
    init_pair(1, COLOR_GREEN, -1);   // a sounding motor
    init_pair(2, COLOR_RED, -1);     // warnings
    init_pair(3, COLOR_CYAN, -1);    // messages
  }
  std::fflush(stderr);
  stderr_log_ = std::tmpfile();
  if (stderr_log_) {
    saved_stderr_ = ::dup(2);
    ::dup2(::fileno(stderr_log_), 2);
  }
}

Terminal::~Terminal() {
  endwin();
  delscreen(set_term(nullptr));
  if (!stderr_log_) return;
  std::fflush(stderr);
  ::dup2(saved_stderr_, 2);
  ::close(saved_stderr_);
  std::rewind(stderr_log_);
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, stderr_log_)) > 0;) std::fwrite(buf, 1, n, stderr);
  std::fclose(stderr_log_);
}

int Terminal::key(int timeout_ms) {
  wtimeout(stdscr, timeout_ms);
  const int k = wgetch(stdscr);
  return k == ERR ? kNoKey : k;
}

size_t Terminal::rows() const {
  const int r = getmaxy(stdscr);
  return r > 0 ? static_cast<size_t>(r) : 0;
}

size_t Terminal::cols() const {
  const int c = getmaxx(stdscr);
  return c > 0 ? static_cast<size_t>(c) : 0;
}

void Terminal::draw(const std::vector<ScreenLine> &lines) {
  const int rows = getmaxy(stdscr), cols = getmaxx(stdscr);
  const bool colour = has_colors();
  werase(stdscr);
  for (size_t i = 0; i < lines.size() && static_cast<int>(i) < rows; ++i) {
    wattrset(stdscr, static_cast<int>(attributes(lines[i].style, colour)));
    // The bottom right cell stays empty: writing it would scroll some terminals.
    const int room = static_cast<int>(i) == rows - 1 ? cols - 1 : cols;
    mvwaddnstr(stdscr, static_cast<int>(i), 0, lines[i].text.c_str(), room);
  }
  wattrset(stdscr, A_NORMAL);
  wrefresh(stdscr);
}

}  // namespace stepchoir
