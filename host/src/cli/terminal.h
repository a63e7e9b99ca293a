// terminal.h: the consoles' terminal (curses): taken whole while a Terminal lives, keys read one
// at a time, styled lines (console_view.h) drawn. Console (live, jam) and PlayConsole (play)
// draw through it. Main thread only; never a real-time thread.
#ifndef STEPCHOIR_HOST_CLI_TERMINAL_H
#define STEPCHOIR_HOST_CLI_TERMINAL_H

#include <cstddef>
#include <cstdio>
#include <vector>

#include "cli/console_view.h"

namespace stepchoir {

class Terminal {
 public:
  static constexpr int kEscape = 27;  // a lone Esc (an arrow's bytes come as one key)
  static constexpr int kNoKey = -1;

  // Takes the terminal: the alternate screen, no echo, keys one at a time (Ctrl-C and
  // Ctrl-Z stay signals), a hidden cursor; stderr goes to a temporary file until the terminal
  // is given back (a library's stray message would scribble on the screen), then is printed.
  // Throws std::runtime_error when stdin or stdout is no terminal, or TERM is unknown or names
  // one that cannot move its cursor (dumb).
  Terminal();
  // Gives the terminal back as it was (also on an exception or a signal's stop), then prints
  // what stderr got meanwhile.
  ~Terminal();
  Terminal(const Terminal &) = delete;
  Terminal &operator=(const Terminal &) = delete;

  // The next key (a character, KEY_UP, ...; kEscape), waiting up to timeout_ms; kNoKey when none.
  int key(int timeout_ms);
  // The screen's size now (0 when unknown).
  size_t rows() const;
  size_t cols() const;
  // Draws lines (at most rows(), each at most cols() wide) in place of what was there.
  void draw(const std::vector<ScreenLine> &lines);

 private:
  int saved_stderr_ = -1;
  std::FILE *stderr_log_ = nullptr;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_TERMINAL_H
