// child_process.h: a program run by an end-to-end test (jackd, `stepchoir live`), with its
// stdout readable line by line; ended with a signal when the test is done with it.
#ifndef STEPCHOIR_TESTS_CHILD_PROCESS_H
#define STEPCHOIR_TESTS_CHILD_PROCESS_H

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

extern char **environ;

// Waits for child pid to exit: its exit status, or -1 when a signal ended it.
// Called from: ChildProcess and VboardProcess.
inline int wait_exit_status(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class ChildProcess {
 public:
  // Starts argv[0] (a path) with the test's environment; stdout comes through a pipe when
  // capture_stdout, else goes to /dev/null. Throws std::runtime_error when it cannot start.
  ChildProcess(const std::vector<std::string> &argv, bool capture_stdout) {
    int out[2] = {-1, -1};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (capture_stdout) {
      if (pipe(out) != 0) throw std::runtime_error("pipe failed");
      posix_spawn_file_actions_adddup2(&fa, out[1], 1);
      posix_spawn_file_actions_addclose(&fa, out[0]);
    } else {
      posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    }
    std::vector<char *> args;
    for (const auto &a : argv) args.push_back(const_cast<char *>(a.c_str()));
    args.push_back(nullptr);
    const int rc = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (capture_stdout) {
      close(out[1]);
      out_ = out[0];
    }
    if (rc != 0) throw std::runtime_error("cannot start " + argv[0]);
  }
  ChildProcess(const ChildProcess &) = delete;
  ChildProcess &operator=(const ChildProcess &) = delete;
  ~ChildProcess() {
    if (pid_ > 0) signal_and_wait(SIGKILL);
    if (out_ >= 0) close(out_);
  }

  // The next stdout line (without its newline) into *line, waiting up to timeout_ms; false on
  // timeout or when the child closed stdout.
  bool read_line(std::string *line, int timeout_ms) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    for (;;) {
      const size_t nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        *line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return true;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      if (out_ < 0 || left.count() <= 0) return false;
      pollfd p{out_, POLLIN, 0};
      if (poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char buf[512];
      const ssize_t n = read(out_, buf, sizeof buf);
      if (n <= 0) return false;
      buffer_.append(buf, static_cast<size_t>(n));
    }
  }

  // Every stdout line until the child closes stdout or timeout_ms passes between two lines.
  std::string read_rest(int timeout_ms) {
    std::string all, line;
    while (read_line(&line, timeout_ms)) all += line + "\n";
    return all + buffer_;
  }

  // Sends sig, waits for the exit: the exit status, or -1 when a signal ended it.
  int signal_and_wait(int sig) {
    if (pid_ <= 0) return status_;
    kill(pid_, sig);
    return wait();
  }

  // The process id while it runs (for signals a test sends itself), else -1.
  pid_t pid() const { return pid_; }

  // Waits for the exit (status as above).
  int wait() {
    if (pid_ <= 0) return status_;
    status_ = wait_exit_status(pid_);
    pid_ = -1;
    return status_;
  }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  int out_ = -1;
  std::string buffer_;
};

#endif  // STEPCHOIR_TESTS_CHILD_PROCESS_H
