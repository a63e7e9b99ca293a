// doctor.cpp: see doctor.h.
#include "cli/doctor.h"

#include <fcntl.h>
#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <stdexcept>

#include "board/board.h"
#include "board/link.h"
#include "config/rig.h"
#include "live/board_link.h"
#include "live/midi_in.h"
#include "live/realtime_setup.h"
#include "live/session.h"

namespace stepchoir {
namespace {

// Where the repository's system files are installed from (the doctor's fixes name them).
const char *const kUdevRule = "tools/system/99-stepchoir.rules";
const char *const kLimitsFile = "tools/system/99-stepchoir-realtime.conf";
// A round trip slower than this delays every clock sync and reply (ms): a bridge that batches
// for 16 ms (an FTDI's default latency timer) is, the 16U2's 4 ms is not.
const double kSlowRoundTripMs = 10.0;

struct Report {
  int problems = 0;
  void ok(const std::string &what) { std::printf("ok   %s\n", what.c_str()); }
  void info(const std::string &what) { std::printf("--   %s\n", what.c_str()); }
  void fix(const std::string &what, const std::string &how) {
    ++problems;
    std::printf("FIX  %s\n     %s\n", what.c_str(), how.c_str());
  }
};

// True when this process is in group gid (its primary group or a supplementary one).
bool in_group(gid_t gid) {
  if (::getegid() == gid) return true;
  std::vector<gid_t> groups(static_cast<size_t>(std::max(::getgroups(0, nullptr), 0)));
  const int n = ::getgroups(static_cast<int>(groups.size()), groups.data());
  return std::find(groups.begin(), groups.begin() + std::max(n, 0), gid) != groups.begin() + std::max(n, 0);
}

std::string group_name(gid_t gid) {
  const group *g = ::getgrgid(gid);
  return g ? g->gr_name : std::to_string(gid);
}

void check_config(Report &r, const std::string &given, Rig *rig) {
  try {
    *rig = load_rig(given);
    if (rig->path.empty()) r.info("configuration: none (every setting at its default; `stepchoir config --print-default` writes one)");
    else r.ok("configuration: " + rig->path + " (" + std::to_string(rig->config.boards.size()) + " boards)");
  } catch (const std::exception &e) {
    r.fix(std::string("configuration: ") + e.what(), "edit that line, then `stepchoir config --check FILE` again");
  }
}

// A port's device: read and write access (true), else why not and the fix.
bool check_port_access(Report &r, const std::string &port) {
  struct stat st{};
  if (::stat(port.c_str(), &st) != 0) {
    r.fix(port + ": not there", "plug the board in (`stepchoir ports` lists the ports), or correct the port");
    return false;
  }
  if (::access(port.c_str(), R_OK | W_OK) == 0) {
    r.ok(port + ": readable and writable");
    return true;
  }
  const std::string group = group_name(st.st_gid);
  if (!in_group(st.st_gid))
    r.fix(port + ": no permission (it belongs to group " + group + ", which you are not in)",
          "sudo usermod -aG " + group + " \"$USER\", then log out and in again");
  else
    r.fix(port + ": no permission for group " + group,
          std::string("install the udev rule: sudo cp ") + kUdevRule +
              " /etc/udev/rules.d/ && sudo udevadm control --reload && sudo udevadm trigger");
  return false;
}

void check_realtime(Report &r) {
  const RealtimeLimits l = realtime_limits();
  const bool prio = priority_allowed(l, LiveSession::kEnginePriority), lock = memory_lock_allowed(l);
  const std::string how = std::string("sudo cp ") + kLimitsFile +
                          " /etc/security/limits.d/ && sudo usermod -aG audio \"$USER\", then log out and in again";
  if (prio) r.ok("real time: SCHED_FIFO priority " + std::to_string(LiveSession::kEnginePriority) + " allowed");
  else r.fix("real time: SCHED_FIFO not allowed (rtprio limit " + std::to_string(l.rtprio) + ")", how);
  if (lock) r.ok("real time: memory locking allowed");
  else r.fix("real time: memory locking limited to " + std::to_string(l.memlock_bytes / 1024) + " KiB", how);
}

// Runs f with stderr on /dev/null: the MIDI libraries print their own diagnostics there when
// a server or the sequencer is missing, which the report says in its own words.
template <typename F> void quietly(F f) {
  std::fflush(stderr);
  const int saved = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY);
  if (null >= 0) ::dup2(null, 2);
  try {
    f();
  } catch (...) {
    if (saved >= 0) ::dup2(saved, 2), ::close(saved);
    if (null >= 0) ::close(null);
    throw;
  }
  if (saved >= 0) ::dup2(saved, 2), ::close(saved);
  if (null >= 0) ::close(null);
}

void check_midi(Report &r) {
  for (const std::string api : {"alsa", "jack"}) {
    std::vector<std::string> inputs;
    std::string error;
    quietly([&] {
      try {
        inputs = list_midi_inputs(parse_midi_api(api));
      } catch (const std::exception &e) {
        error = e.what();
      }
    });
    std::string names;
    for (const auto &n : inputs) names += (names.empty() ? "" : ", ") + n;
    if (!error.empty() && api == "alsa") r.fix(error, "sudo modprobe snd-seq (the ALSA sequencer)");
    else if (!error.empty() || (api == "jack" && inputs.empty()))
      r.info("MIDI (jack): no inputs (`live --midi-api jack` needs a JACK server running: jackd, or pipewire-jack)");
    else
      r.ok("MIDI (" + api + "): " + std::to_string(inputs.size()) + " inputs" +
           (inputs.empty() ? " (plug a keyboard in, or use --midi virtual)" : ": " + names));
  }
}

// Greets the board at port, checks its firmware and times clock round trips.
void check_board(Report &r, const std::string &port, int trips) {
  try {
    Board board(open_link(port));
    const Caps caps = board.greet();
    const std::string what = port + ": " + caps.board_name + ", " + std::to_string(caps.motor_count) + " motors, protocol " +
                             std::to_string(caps.protocol_version);
    if (caps.protocol_version != sc::kProtocolVersion) {
      r.fix(what + " (this program speaks " + std::to_string(sc::kProtocolVersion) + ")",
            "flash this version's firmware (README, Flashing)");
      return;
    }
    board.send({sc::kMsgIdReq});
    if (!board.wait_reply(sc::kMsgId, 500)) {
      r.fix(what + ": its firmware is older than this program (no board id)", "flash this version's firmware (README, Flashing)");
      return;
    }
    r.ok(what);
    std::vector<double> ms;
    for (int i = 0; i < trips; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      board.send({sc::kMsgClockReq, static_cast<uint8_t>(i)});
      if (!board.wait_reply(sc::kMsgClock, 1000)) continue;
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    if (ms.size() < size_t(trips)) {
      r.fix(port + ": " + std::to_string(trips - int(ms.size())) + " of " + std::to_string(trips) + " round trips lost",
            "check the cable and the USB hub; `stepchoir status` counts the board's bad frames");
      if (ms.empty()) return;
    }
    std::sort(ms.begin(), ms.end());
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s: round trip p50 %.2f ms, max %.2f ms (%zu trips)", port.c_str(), ms[ms.size() / 2],
                  ms.back(), ms.size());
    if (ms[ms.size() / 2] > kSlowRoundTripMs)
      r.fix(buf, "an FTDI bridge batches for 16 ms: echo 1 | sudo tee /sys/bus/usb-serial/devices/$(basename " + port +
                     ")/latency_timer");
    else r.ok(buf);
  } catch (const std::exception &e) {
    r.fix(port + ": " + e.what(), "check the port, the cable and that the board runs stepchoir's firmware");
  }
}

}  // namespace

int run_doctor(const DoctorOptions &o) {
  Report r;
  Rig rig;
  check_config(r, o.config, &rig);
  std::vector<std::string> ports = o.ports;
  if (ports.empty())
    for (const BoardSettings &b : rig.config.boards)
      if (!b.port.empty()) ports.push_back(b.port);
  if (ports.empty()) {
    const auto found = list_serial_ports();
    if (found.empty()) r.info("serial ports: none found (plug a board in, or give --port)");
    for (const std::string &p : found) ports.push_back(p.substr(0, p.find("  ")));
  }
  std::vector<std::string> open;
  for (const std::string &p : ports)
    if (check_port_access(r, p)) open.push_back(p);
  check_realtime(r);
  check_midi(r);
  for (const std::string &p : open) check_board(r, p, o.round_trips);
  std::printf(r.problems ? "%d to fix\n" : "nothing to fix\n", r.problems);
  return r.problems ? 1 : 0;
}

}  // namespace stepchoir
