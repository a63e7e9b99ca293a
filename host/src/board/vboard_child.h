// vboard_child.h: the virtual board (stepchoir-vboard, beside this program) as a child
// process, for commands run without a --port.
#ifndef STEPCHOIR_HOST_VBOARD_CHILD_H
#define STEPCHOIR_HOST_VBOARD_CHILD_H

#include <string>
#include <vector>

#include "board/child_process.h"

namespace stepchoir {

// The boards and USB bridge models the virtual board simulates (its --board and --link-model;
// docs/usb-bridges.md).
inline const std::vector<std::string> kBoardKinds{"uno", "mega"};
inline const std::vector<std::string> kLinkModels{"ideal", "16u2", "ftdi", "ch340"};

// How many motors a board of kind `kind` (one of kBoardKinds) drives: its firmware board table's
// count (uno 4, mega 5); 0 for another name.
size_t board_kind_motors(const std::string &kind);

// The words of a list as a sentence says them: "uno or mega", "ideal, 16u2, ftdi or ch340".
inline std::string one_of(const std::vector<std::string> &words) {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i)
    out += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i];
  return out;
}

// The virtual board as a child process, for `live`, `play` and `jam` without --port, and
// `render`. Stopped (SIGTERM) when destroyed.
class VirtualBoard {
 public:
  // Called from: the commands. Starts <dir of this program>/stepchoir-vboard on link_path (with
  // a trace when trace_path is not empty, and extra_args) and waits until the link exists; throws
  // std::runtime_error when it cannot.
  VirtualBoard(const std::string &board, const std::string &link_path, const std::string &trace_path,
               const std::vector<std::string> &extra_args);
  // Called from: the command's end. Stops it (SIGTERM: it writes its trace out) and waits.
  ~VirtualBoard();
  // Stops it now and waits for it to exit; its trace is complete afterwards. Idempotent.
  void stop();
  VirtualBoard(const VirtualBoard &) = delete;
  VirtualBoard &operator=(const VirtualBoard &) = delete;
  const std::string &path() const { return path_; }

 private:
  static constexpr int kPriority = -5;  // nice value asked for the simulation
  std::string path_;
  ChildProcess child_;
};

// Where the k-th (from 0) of a command's virtual boards is reached: /tmp/stepchoir-CMD-PID.pty,
// the others -2, -3, ... And its trace: `trace` for the first, the others beside it (T.csv ->
// T-2.csv, ...); "" (no trace) stays "". Called from: play, render, jam, live.
std::string vboard_link_path(const std::string &cmd, size_t k);
std::string vboard_trace_path(const std::string &trace, size_t k);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_VBOARD_CHILD_H
