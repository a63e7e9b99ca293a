// vboard_process.h: runs build/bin/stepchoir-vboard (the real firmware in simavr) as a child
// process for end-to-end tests, and hands out its pty path.
#ifndef STEPCHOIR_TESTS_VBOARD_PROCESS_H
#define STEPCHOIR_TESTS_VBOARD_PROCESS_H

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "child_process.h"

extern char **environ;

class VboardProcess {
 public:
  // Starts the virtual board with `args` after the binary name; waits for its pty line.
  explicit VboardProcess(const std::vector<std::string> &args) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe failed");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    posix_spawn_file_actions_addclose(&fa, out[0]);
    std::vector<std::string> all{STEPCHOIR_VBOARD};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char *> argv;
    for (auto &a : all) argv.push_back(const_cast<char *>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) != 0)
      throw std::runtime_error(std::string("cannot start ") + STEPCHOIR_VBOARD);
    posix_spawn_file_actions_destroy(&fa);
    close(out[1]);
    out_ = fdopen(out[0], "r");
    char line[256];
    if (!fgets(line, sizeof line, out_)) throw std::runtime_error("virtual board printed no pty line");
    std::string s(line);
    if (s.rfind("pty: ", 0) != 0) throw std::runtime_error("virtual board said: " + s);
    pty_ = s.substr(5, s.find_last_not_of("\r\n") - 4);
  }

  VboardProcess(const VboardProcess &) = delete;
  VboardProcess &operator=(const VboardProcess &) = delete;

  // Stops the board if it still runs.
  ~VboardProcess() {
    if (pid_ > 0) stop();
    if (out_) fclose(out_);
  }

  // Ends the board with SIGTERM (it then finishes its trace) and waits: its exit status, -1 if
  // a signal killed it (the vboard exits 0 on SIGTERM, 2 when the AVR crashed).
  int stop() {
    if (pid_ > 0) kill(pid_, SIGTERM);
    return wait();
  }

  const std::string &pty() const { return pty_; }

  // Waits for the board to exit (e.g. after --seconds); returns its exit status (again on
  // later calls), -1 if a signal killed it.
  int wait() {
    if (pid_ <= 0) return status_;
    status_ = wait_exit_status(pid_);
    pid_ = -1;
    return status_;
  }

  // True while the process runs.
  bool running() {
    if (pid_ <= 0) return false;
    int status;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      return false;
    }
    return true;
  }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  FILE *out_ = nullptr;
  std::string pty_;
};

#endif  // STEPCHOIR_TESTS_VBOARD_PROCESS_H
