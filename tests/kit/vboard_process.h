// vboard_process.h: the virtual board (STEPCHOIR_VBOARD: build/bin/stepchoir-vboard, the real
// firmware in simavr) as a child process of an end-to-end test or a benchmark, with its pty.
#ifndef STEPCHOIR_TESTS_KIT_VBOARD_PROCESS_H
#define STEPCHOIR_TESTS_KIT_VBOARD_PROCESS_H

#include <signal.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "board/child_process.h"

class VboardProcess {
 public:
  // Starts the virtual board with `args` after the binary name; waits (up to 30 s) for the
  // line it prints first, "pty: PATH".
  explicit VboardProcess(const std::vector<std::string> &args) : child_(with_binary(args), true) {
    std::string line;
    if (!child_.read_line(&line, 30000)) throw std::runtime_error("virtual board printed no pty line");
    if (line.rfind("pty: ", 0) != 0) throw std::runtime_error("virtual board said: " + line);
    pty_ = line.substr(5, line.find_last_not_of("\r") - 4);
  }

  // Stops the board (SIGTERM: its trace is written) if it still runs.
  ~VboardProcess() { stop(); }
  VboardProcess(const VboardProcess &) = delete;
  VboardProcess &operator=(const VboardProcess &) = delete;

  // Ends the board with SIGTERM (it then finishes its trace) and waits: its exit status, -1 if
  // a signal killed it (the vboard exits 0 on SIGTERM, 2 when the AVR crashed).
  int stop() { return child_.signal_and_wait(SIGTERM); }
  // Waits for the board to exit (e.g. after --seconds); its exit status (again on later
  // calls), -1 if a signal killed it.
  int wait() { return child_.wait(); }
  // True while the process runs.
  bool running() { return child_.running(); }
  // Its process id (a test may raise its scheduling priority: a real board never waits for the
  // machine's other work).
  pid_t pid() { return child_.pid(); }
  const std::string &pty() const { return pty_; }

 private:
  // A test's board starts its firmware at once and is not reset by the test's open of its
  // pty, unless the test asks for a real board's reset and bootloader ("--auto-reset").
  static std::vector<std::string> with_binary(const std::vector<std::string> &args) {
    std::vector<std::string> all{STEPCHOIR_VBOARD};
    all.insert(all.end(), args.begin(), args.end());
    if (std::find(args.begin(), args.end(), "--auto-reset") == args.end())
      all.insert(all.end(), {"--no-auto-reset", "--no-bootloader"});
    return all;
  }
  stepchoir::ChildProcess child_;
  std::string pty_;
};

#endif  // STEPCHOIR_TESTS_KIT_VBOARD_PROCESS_H
