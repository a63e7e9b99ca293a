// console_pane.h: the consoles' end-to-end tests' terminal: a command in a tmux pane of its own
// (a private tmux server, detached, as over ssh), keys typed into it, its screen read back, and
// checks on the screen's rows and on the terminal given back. Used by test_console.cpp (live,
// jam, play) and test_play_console.cpp (play's console).
#ifndef STEPCHOIR_TESTS_E2E_CONSOLE_PANE_H
#define STEPCHOIR_TESTS_E2E_CONSOLE_PANE_H

#include <catch2/catch.hpp>
#include <sys/types.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "board/child_process.h"
#include "e2e_util.h"

namespace console_pane {

inline void wait_ms(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

// The machine's monotonic clock (s): the clock of Sender::now_s and of a trace's wall_seconds.
inline double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// A private tmux server (its own socket, no user configuration, no status bar) with one
// detached session of cols x rows running `command`; killed with everything in it at the end.
class TmuxSession {
 public:
  TmuxSession(const std::string &command, int cols, int rows)
      : socket_("stepchoir-e2e-" + std::to_string(::getpid())), conf_(e2e::scratch("tmux.conf")) {
    std::ofstream(conf_) << "set -g status off\n";
    tmux({"-f", conf_, "new-session", "-d", "-s", "console", "-x", std::to_string(cols), "-y", std::to_string(rows),
          command});
  }
  ~TmuxSession() {
    try {
      tmux({"kill-server"});
    } catch (const std::exception &) {
    }
  }
  TmuxSession(const TmuxSession &) = delete;
  TmuxSession &operator=(const TmuxSession &) = delete;

  // The pane's screen, a line a row (wrapped lines joined).
  std::string screen() { return tmux({"capture-pane", "-p", "-J", "-t", "console"}); }
  // Types a key (tmux's names: "Space", "Escape", "q"); the time (now_s) once tmux has it.
  double key(const std::string &k) {
    tmux({"send-keys", "-t", "console", k});
    return now_s();
  }
  // A format of the pane: "#{alternate_on}", "#{cursor_flag}".
  std::string format(const std::string &f) { return tmux({"display-message", "-p", "-t", "console", f}); }
  // The process the pane's shell runs (the command under test); 0 when there is none yet.
  pid_t command_pid() {
    const std::string shell = format("#{pane_pid}");
    const std::string pid = shell.substr(0, shell.find('\n'));
    std::ifstream children("/proc/" + pid + "/task/" + pid + "/children");
    long child = 0;
    return children >> child ? static_cast<pid_t>(child) : 0;
  }
  // Waits up to timeout_s for a screen that `shows`; that screen (the last one on failure).
  template <class F>
  std::string wait_until(F shows, double timeout_s = 20) {
    std::string s;
    for (const double give_up = now_s() + timeout_s;;) {
      s = screen();
      if (shows(s) || now_s() > give_up) break;
      wait_ms(100);
    }
    return s;
  }
  std::string wait_for(const std::string &text, double timeout_s = 20) {
    return wait_until([&](const std::string &s) { return s.find(text) != std::string::npos; }, timeout_s);
  }

 private:
  std::string tmux(std::vector<std::string> args) {
    args.insert(args.begin(), {"/usr/bin/tmux", "-L", socket_});
    stepchoir::ChildProcess p(args, true);
    std::string out, line;
    while (p.read_line(&line, 5000)) out += line + "\n";
    if (p.wait() != 0) throw std::runtime_error("tmux " + args[3] + " failed");
    return out;
  }
  std::string socket_, conf_;
};

// A shell command for a tmux pane: `stepchoir ARGS` (jack: on the test's JACK server), then its
// exit status ("EXIT=0") and whether the terminal reads lines and echoes again ("TTY: icanon
// echo"); then the pane stays, with its screen.
inline std::string stepchoir_in_pane(const std::string &args, bool jack = true) {
  const char *jack_server = std::getenv("JACK_DEFAULT_SERVER");
  if (jack && !jack_server) throw std::runtime_error("no JACK server");
  return std::string(jack ? std::string("env JACK_DEFAULT_SERVER=") + jack_server + " " : "") + STEPCHOIR_BIN + " " + args +
         "; echo \"EXIT=$?\"; echo \"TTY: $(stty -a | tr ' ;' '\\n\\n' | grep -x -e icanon -e -icanon -e echo -e -echo | "
         "tr '\\n' ' ')\"; sleep 600";
}

// The screen's rows, in order.
inline std::vector<std::string> rows_of(const std::string &screen) {
  std::vector<std::string> rows;
  size_t at = 0;
  for (size_t end; (end = screen.find('\n', at)) != std::string::npos; at = end + 1)
    rows.push_back(screen.substr(at, end - at));
  return rows;
}

// Motor m's row (it starts with the motor's number, "%2d  "); "" when the screen has none.
inline std::string motor_row(const std::string &screen, int m) {
  char start[8];
  std::snprintf(start, sizeof start, "%2d  ", m);
  for (const std::string &row : rows_of(screen))
    if (row.compare(0, 4, start) == 0) return row;
  return "";
}

// Whether the screen's row of motor m starts with `text`.
inline bool row_starts(const std::string &screen, int m, const std::string &text) {
  const std::string row = motor_row(screen, m);
  return !row.empty() && row.compare(0, text.size(), text) == 0;
}

// Whether motor m's row shows a note and its Hz (" 0  A4      440.00     +0 ...").
inline bool row_sounds(const std::string &row) {
  return row.size() > 20 && row[4] >= 'A' && row[4] <= 'G' && row.find('.') != std::string::npos;
}

// Whether some motor's row among the first `motors` shows a note and its Hz.
inline bool some_motor_sounds(const std::string &screen, int motors = 4) {
  for (int m = 0; m < motors; ++m)
    if (row_sounds(motor_row(screen, m))) return true;
  return false;
}

// Checks that the screen shows text / that motor m's row starts with text; the screen with a failure.
inline void expect_text(const std::string &screen, const std::string &text) {
  INFO("the screen:\n" << screen);
  CHECK(screen.find(text) != std::string::npos);
}
inline void expect_row(const std::string &screen, int m, const std::string &text) {
  INFO("the screen:\n" << screen);
  CHECK(row_starts(screen, m, text));
}

// Types `key` (q by default; *key_s, when given, gets when: now_s), then checks that the command
// said `goodbye`, exited with `status` and gave the terminal back: reading lines and echoing,
// out of the alternate screen, the cursor shown. The screen after the exit.
inline std::string quit_and_check_terminal(TmuxSession &tmux, const std::string &goodbye, const std::string &key = "q",
                                           double *key_s = nullptr, int status = 0) {
  const double at = tmux.key(key);
  if (key_s) *key_s = at;
  const std::string screen = tmux.wait_for("TTY:");
  expect_text(screen, goodbye);
  expect_text(screen, "EXIT=" + std::to_string(status) + "\n");
  expect_text(screen, "TTY: icanon echo");
  CHECK(tmux.format("#{alternate_on}") == "0\n");
  CHECK(tmux.format("#{cursor_flag}") == "1\n");
  return screen;
}

}  // namespace console_pane

#endif  // STEPCHOIR_TESTS_E2E_CONSOLE_PANE_H
