// vboard_child.cpp: starts and stops the virtual board child process.
#include "board/vboard_child.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <csignal>
#include <stdexcept>
#include <string>
#include <thread>

#include "mega_ramps_14.h"
#include "uno_cnc_shield_v3.h"

namespace stepchoir {

size_t board_kind_motors(const std::string &kind) {
  return kind == "uno" ? board::uno_cnc_shield_v3::kMotorCount : kind == "mega" ? board::mega_ramps_14::kMotorCount : 0;
}

namespace {

// <dir of this program>/stepchoir-vboard.
std::string vboard_path() {
  char self[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) throw std::runtime_error("cannot find this program's directory");
  self[n] = 0;
  const std::string dir(self);
  return dir.substr(0, dir.rfind('/')) + "/stepchoir-vboard";
}

std::vector<std::string> vboard_args(const std::string &path, const std::string &board, const std::string &link_path,
                                     const std::string &trace_path, const std::vector<std::string> &extra_args) {
  // The host's own board: opened once by the program that started it, it neither resets on
  // the open nor has a bootloader to wait out (hello at once).
  std::vector<std::string> args{path, "--board", board, "--link", link_path, "--quiet", "--exit-with-parent",
                                "--no-auto-reset", "--no-bootloader"};
  if (!trace_path.empty()) args.insert(args.end(), {"--trace", trace_path});
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  return args;
}

}  // namespace

VirtualBoard::VirtualBoard(const std::string &board, const std::string &link_path, const std::string &trace_path,
                           const std::vector<std::string> &extra_args)
    : path_(vboard_path()),
      // Its own process group: Ctrl-C reaches this program only, which silences the motors
      // first and then stops the board.
      child_(vboard_args(path_, board, link_path, trace_path, extra_args), ChildProcess::Options{false, true}) {
  // A little ahead of other work, where allowed (root): the simulation keeps real time only
  // with most of a core, and a board that falls behind plays late. Without the right, it runs
  // at normal priority.
  setpriority(PRIO_PROCESS, static_cast<id_t>(child_.pid()), kPriority);
  struct stat st;
  for (int i = 0; i < 200 && ::lstat(link_path.c_str(), &st) != 0; ++i) {
    if (!child_.running()) throw std::runtime_error("the virtual board " + path_ + " exited at start");
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
}

VirtualBoard::~VirtualBoard() { stop(); }

void VirtualBoard::stop() { child_.signal_and_wait(SIGTERM); }

std::string vboard_link_path(const std::string &cmd, size_t k) {
  return "/tmp/stepchoir-" + cmd + "-" + std::to_string(::getpid()) + (k ? "-" + std::to_string(k + 1) : "") + ".pty";
}

std::string vboard_trace_path(const std::string &trace, size_t k) {
  if (!k || trace.empty()) return trace;
  const bool csv = trace.size() > 4 && trace.compare(trace.size() - 4, 4, ".csv") == 0;
  return (csv ? trace.substr(0, trace.size() - 4) : trace) + "-" + std::to_string(k + 1) + ".csv";
}

}  // namespace stepchoir
