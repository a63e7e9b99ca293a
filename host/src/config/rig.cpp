// rig.cpp: the rig file's location and what each command takes from it.
#include "config/rig.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace stepchoir {

std::string xdg_file(const char *xdg_variable, const char *home_dir, const std::string &name) {
  const char *xdg = std::getenv(xdg_variable);
  if (xdg && *xdg) return std::string(xdg) + "/stepchoir/" + name;
  const char *home = std::getenv("HOME");
  if (home && *home) return std::string(home) + "/" + home_dir + "/stepchoir/" + name;
  return "";
}

std::string default_config_path() { return xdg_file("XDG_CONFIG_HOME", ".config", "stepchoir.toml"); }

std::string rig_path(const std::string &given) {
  if (!given.empty()) return given;
  const std::string fallback = default_config_path();
  struct stat st {};
  return !fallback.empty() && ::stat(fallback.c_str(), &st) == 0 && S_ISREG(st.st_mode) ? fallback : "";
}

Rig load_rig(const std::string &given) {
  Rig rig;
  rig.path = rig_path(given);
  if (!rig.path.empty()) rig.config = load_config(rig.path);
  return rig;
}

namespace {

// True when a and b name the same file, whatever the links between (a by-id name and the
// ttyACM node it points at).
bool same_file(const std::string &a, const std::string &b) {
  if (a == b) return true;
  struct stat sa, sb;
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

}  // namespace

const BoardSettings *board_settings(const Rig &rig, const std::string &port, size_t index) {
  const auto &boards = rig.config.boards;
  for (const BoardSettings &b : boards)
    if (!b.port.empty() && same_file(b.port, port)) return &b;
  // else by position: the same rig on another port name (a board plugged in elsewhere), unless
  // that entry's port is there: it belongs to the board on it, not to this one.
  if (index >= boards.size()) return nullptr;
  const BoardSettings &b = boards[index];
  return b.port.empty() || ::access(b.port.c_str(), F_OK) != 0 ? &b : nullptr;
}

std::string rig_port(const Rig &rig, const std::string &port) {
  if (!port.empty()) return port;
  for (const BoardSettings &b : rig.config.boards)
    if (!b.port.empty()) return b.port;
  return "";
}

std::vector<std::string> rig_ports(const Rig &rig, const std::vector<std::string> &ports, bool virtual_asked) {
  if (!ports.empty() || virtual_asked) return ports;
  std::vector<std::string> out;
  for (const BoardSettings &b : rig.config.boards)
    if (!b.port.empty()) out.push_back(b.port);
  return out;
}

std::vector<std::string> rig_vboards(const Rig &rig, const std::vector<std::string> &given) {
  if (!given.empty()) return given;
  std::vector<std::string> kinds;
  for (const BoardSettings &b : rig.config.boards) kinds.push_back(b.board);
  if (kinds.empty()) kinds.push_back(BoardSettings{}.board);
  return kinds;
}

void configure_motors(Board &board, const Caps &caps, const BoardSettings &settings, const std::string &port) {
  for (size_t m = 0; m < settings.motors.size() && m < caps.motor_count; ++m) {
    board.send(config_payload(settings.motors[m].hardware));
    board.send(driver_payload(settings.motors[m].power));
    const auto err = board.wait_reply(sc::kMsgError, 100);
    if (!err) continue;
    const uint8_t code = (*err)[1];
    const bool driver = (*err)[2] == sc::kMsgDriver;
    throw std::runtime_error(
        port + ": the board refused motor " + std::to_string(m) + "'s " +
        (driver ? "driver settings (sleep_pin, reset_pin, idle, wake_us)" : "configuration") + ": " +
        sc::error_name(code) +
        (code == sc::kErrUnknownType ? " (its firmware is older than this program: flash this version's)"
         : driver && code == sc::kErrConfig ? " (a pin the board lacks or uses already?)"
                                           : ""));
  }
}

void apply_allocation(const LiveConfig &cfg, AllocatorConfig *alloc) {
  alloc->priority = cfg.priority;
  alloc->sing_percussion = cfg.sing_percussion;
  alloc->a4_hz = cfg.a4_hz;
  alloc->vibrato = cfg.vibrato;
  alloc->velocity = cfg.velocity;
  alloc->glide = cfg.glide;
}

void say_line(const std::string &line) {
  std::printf("%s\n", line.c_str());
  std::fflush(stdout);
}

uint32_t motor_travel(const BoardSettings *settings, uint8_t motor) {
  return (settings && motor < settings->motors.size() ? settings->motors[motor].hardware : default_motor_hardware(motor))
      .travel_steps;
}

MotionSettings motor_motion(const BoardSettings *settings, uint8_t motor) {
  return settings && motor < settings->motors.size() ? settings->motors[motor].motion : MotionSettings{};
}

int8_t motor_mono_channel(const BoardSettings *settings, uint8_t motor) {
  return settings && motor < settings->motors.size() ? settings->motors[motor].mono_channel : 0;
}

void home_board(Board &board, const Caps &caps, const BoardSettings *settings, const std::string &port,
                const std::vector<int> &motors, const std::function<void(const std::string &)> &say) {
  std::vector<HomeJob> jobs;
  for (uint8_t m = 0; m < caps.motor_count; ++m) {
    const bool asked = std::find(motors.begin(), motors.end(), int(m)) != motors.end();
    if (!motors.empty() && !asked) continue;
    const bool switches = m < caps.endstops.size() && (caps.endstops[m] & (sc::kEndstopMin | sc::kEndstopMax));
    if (!switches && !asked) {
      say(port + ": motor " + std::to_string(m) + " has no end switch: not homed (jog and center set it by eye)");
      continue;
    }
    jobs.push_back({m, motor_travel(settings, m), motor_motion(settings, m)});
  }
  if (jobs.empty()) return;
  const std::vector<HomeResult> homed = home_motors(board, caps, port, jobs, say);
  std::string failures;
  for (size_t i = 0; i < jobs.size(); ++i) {
    const HomeResult &h = homed[i];
    if (!h.failure.empty()) failures += (failures.empty() ? "" : "\n") + h.failure;
    if (h.measured && std::abs(h.travel_steps - int32_t(jobs[i].travel_steps)) > h.travel_steps / 50)
      say(port + ": motor " + std::to_string(jobs[i].motor) + ": the rail measures " + std::to_string(h.travel_steps) +
          " steps between its switches; the configuration says travel_steps = " +
          std::to_string(jobs[i].travel_steps) + ": set it to " + std::to_string(h.travel_steps));
  }
  if (!failures.empty()) throw std::runtime_error(failures);
}

std::vector<MotorConfig> motor_music(const BoardSettings *settings, uint32_t f_cpu_hz, const std::vector<uint8_t> &ids) {
  std::vector<MotorConfig> out;
  for (uint8_t id : ids) {
    MotorConfig mc = settings && id < settings->motors.size() ? settings->motors[id].music : MotorConfig{};
    mc.f_cpu_hz = f_cpu_hz;
    out.push_back(mc);
  }
  return out;
}

}  // namespace stepchoir
