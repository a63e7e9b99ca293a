// child_process.h: a program run as a child process, with its stdout readable line by line or
// sent to /dev/null; the one spawner of the host (the virtual board) and the tests (jackd,
// `stepchoir live`, the virtual board).
#ifndef STEPCHOIR_HOST_BOARD_CHILD_PROCESS_H
#define STEPCHOIR_HOST_BOARD_CHILD_PROCESS_H

#include <sys/types.h>

#include <string>
#include <vector>

namespace stepchoir {

class ChildProcess {
 public:
  struct Options {
    bool capture_stdout = false;  // stdout through a pipe (read_line), else /dev/null ...
    bool own_group = false;       // its own process group: a terminal's Ctrl-C does not reach it
    bool inherit_stdout = false;  // ... or, without capture_stdout, this process's stdout
    bool pipe_stdin = false;      // stdin from a pipe (write_stdin), else this process's stdin
  };
  // Called from: the commands and the tests. Starts argv[0] (a path) with this process's
  // environment. Throws std::runtime_error when it cannot start.
  ChildProcess(const std::vector<std::string> &argv, Options options);
  ChildProcess(const std::vector<std::string> &argv, bool capture_stdout) : ChildProcess(argv, Options{capture_stdout, false}) {}
  // Kills it (SIGKILL) if it still runs, and waits.
  ~ChildProcess();
  ChildProcess(const ChildProcess &) = delete;
  ChildProcess &operator=(const ChildProcess &) = delete;

  // The next stdout line (without its newline) into *line, waiting up to timeout_ms; false on
  // timeout or when the child closed stdout.
  bool read_line(std::string *line, int timeout_ms);
  // Every stdout line until the child closes stdout or timeout_ms passes between two lines.
  std::string read_rest(int timeout_ms);

  // Writes text to the child's stdin (Options::pipe_stdin); false when it cannot (no pipe, the
  // child closed it).
  bool write_stdin(const std::string &text);

  // Sends sig and waits for the exit: the exit status, or -1 when a signal ended it (again on
  // later calls).
  int signal_and_wait(int sig);
  // Waits for the exit (status as above).
  int wait();
  // True while it runs (reaps it when it has exited).
  bool running();
  // The process id while it runs, else -1.
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  int out_ = -1;
  int in_ = -1;
  std::string buffer_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_BOARD_CHILD_PROCESS_H
