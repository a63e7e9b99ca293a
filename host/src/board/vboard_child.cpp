// vboard_child.cpp: starts and stops the virtual board child process.
#include "board/vboard_child.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <stdexcept>
#include <thread>

extern char **environ;

namespace stepchoir {

VirtualBoard::VirtualBoard(const std::string &board, const std::string &link_path, const std::string &trace_path,
                           const std::vector<std::string> &extra_args) {
  char self[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) throw std::runtime_error("cannot find this program's directory");
  self[n] = 0;
  std::string dir(self);
  path_ = dir.substr(0, dir.rfind('/')) + "/stepchoir-vboard";
  std::vector<std::string> args{path_, "--board", board, "--link", link_path, "--quiet", "--exit-with-parent"};
  if (!trace_path.empty()) args.insert(args.end(), {"--trace", trace_path});
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  std::vector<char *> argv;
  for (auto &a : args) argv.push_back(const_cast<char *>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  // Its own process group: Ctrl-C reaches this program only, which silences the motors
  // first and then stops the board.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  const int rc = posix_spawn(&pid_, path_.c_str(), &fa, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw std::runtime_error("cannot start the virtual board " + path_);
  // A little ahead of other work, where allowed (root): the simulation keeps real time only
  // with most of a core, and a board that falls behind plays late. Without the right, it runs
  // at normal priority.
  setpriority(PRIO_PROCESS, static_cast<id_t>(pid_), kPriority);
  struct stat st;
  for (int i = 0; i < 200 && ::lstat(link_path.c_str(), &st) != 0; ++i) {
    int status;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("the virtual board " + path_ + " exited at start");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
}

VirtualBoard::~VirtualBoard() { stop(); }

void VirtualBoard::stop() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGTERM);
  int status;
  waitpid(pid_, &status, 0);
  pid_ = -1;
}

}  // namespace stepchoir
