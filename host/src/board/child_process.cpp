// child_process.cpp: ChildProcess on posix_spawn.
#include "board/child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <stdexcept>

extern char **environ;

namespace stepchoir {
namespace {

// The exit status of a waitpid() status word, or -1 when a signal ended the child.
int exit_status(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; }

}  // namespace

ChildProcess::ChildProcess(const std::vector<std::string> &argv, Options options) {
  if (argv.empty()) throw std::runtime_error("no program to start");
  // Close-on-exec: neither end reaches this child (but as its stdout) or any later one.
  int out[2] = {-1, -1};
  int in[2] = {-1, -1};
  if (options.capture_stdout && pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  if (options.pipe_stdin && pipe2(in, O_CLOEXEC) != 0) {
    if (options.capture_stdout) {
      close(out[0]);
      close(out[1]);
    }
    throw std::runtime_error("pipe failed");
  }
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  if (options.pipe_stdin) posix_spawn_file_actions_adddup2(&fa, in[0], 0);
  if (options.capture_stdout) {
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
  } else if (!options.inherit_stdout) {
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  }
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  if (options.own_group) {
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
  }
  std::vector<char *> args;
  for (const auto &a : argv) args.push_back(const_cast<char *>(a.c_str()));
  args.push_back(nullptr);
  const int rc = posix_spawn(&pid_, args[0], &fa, &attr, args.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  if (options.capture_stdout) close(out[1]);
  if (options.pipe_stdin) close(in[0]);
  if (rc != 0) {
    if (options.capture_stdout) close(out[0]);
    if (options.pipe_stdin) close(in[1]);
    pid_ = -1;
    throw std::runtime_error("cannot start " + argv[0]);
  }
  out_ = out[0];
  in_ = in[1];
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0) signal_and_wait(SIGKILL);
  if (out_ >= 0) close(out_);
  if (in_ >= 0) close(in_);
}

bool ChildProcess::write_stdin(const std::string &text) {
  size_t done = 0;
  while (in_ >= 0 && done < text.size()) {
    const ssize_t n = write(in_, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return in_ >= 0;
}

bool ChildProcess::read_line(std::string *line, int timeout_ms) {
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

std::string ChildProcess::read_rest(int timeout_ms) {
  std::string all, line;
  while (read_line(&line, timeout_ms)) all += line + "\n";
  return all + buffer_;
}

int ChildProcess::signal_and_wait(int sig) {
  if (pid_ <= 0) return status_;
  kill(pid_, sig);
  return wait();
}

int ChildProcess::wait() {
  if (pid_ <= 0) return status_;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  status_ = exit_status(status);
  pid_ = -1;
  return status_;
}

bool ChildProcess::running() {
  if (pid_ <= 0) return false;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) == pid_) {
    pid_ = -1;
    status_ = exit_status(status);
    return false;
  }
  return true;
}

}  // namespace stepchoir
