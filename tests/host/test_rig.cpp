// test_rig.cpp: the rig file every command reads: where it is looked for, which [[boards]]
// entry a port gets, and the motors' musical settings a song is planned with; the host's
// memory of the boards it has met.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "board/vboard_child.h"
#include "config/board_memory.h"
#include "config/rig.h"
#include "live/realtime_setup.h"

using namespace stepchoir;

namespace {

// Sets an environment variable for one scope and puts the old value back.
class ScopedEnv {
 public:
  ScopedEnv(const char *name, const char *value) : name_(name) {
    const char *old = std::getenv(name);
    had_ = old != nullptr;
    if (had_) old_ = old;
    if (value)
      ::setenv(name, value, 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (had_)
      ::setenv(name_, old_.c_str(), 1);
    else
      ::unsetenv(name_);
  }

 private:
  const char *name_;
  bool had_ = false;
  std::string old_;
};

// A fresh directory under /tmp for this test run.
std::string scratch_dir(const char *what) {
  const std::string d = "/tmp/stepchoir-test-rig-" + std::string(what) + "-" + std::to_string(::getpid());
  ::mkdir(d.c_str(), 0700);
  return d;
}

}  // namespace

TEST_CASE("rig: the default location follows XDG_CONFIG_HOME, else HOME", "[config]") {
  {
    ScopedEnv xdg("XDG_CONFIG_HOME", "/x/conf");
    CHECK(default_config_path() == "/x/conf/stepchoir/stepchoir.toml");
  }
  {
    ScopedEnv xdg("XDG_CONFIG_HOME", "");
    ScopedEnv home("HOME", "/home/player");
    CHECK(default_config_path() == "/home/player/.config/stepchoir/stepchoir.toml");
  }
  {
    ScopedEnv xdg("XDG_CONFIG_HOME", nullptr);
    ScopedEnv home("HOME", nullptr);
    CHECK(default_config_path().empty());
    CHECK(rig_path("").empty());
  }
}

TEST_CASE("rig: --config wins, else the default file if it is there, else no file", "[config]") {
  const std::string dir = scratch_dir("where");
  ScopedEnv xdg("XDG_CONFIG_HOME", dir.c_str());
  CHECK(rig_path("").empty());  // nothing there yet
  CHECK(load_rig("").path.empty());
  CHECK(load_rig("").config.boards.empty());
  ::mkdir((dir + "/stepchoir").c_str(), 0700);
  const std::string file = dir + "/stepchoir/stepchoir.toml";
  std::ofstream(file) << "a4_hz = 432.0\n[[boards]]\nport = \"/dev/ttyACM7\"\n";
  CHECK(rig_path("") == file);
  const Rig rig = load_rig("");
  CHECK(rig.path == file);
  CHECK(rig.config.a4_hz == 432.0);
  CHECK(rig_port(rig, "") == "/dev/ttyACM7");
  CHECK(rig_port(rig, "/dev/ttyUSB0") == "/dev/ttyUSB0");  // the command line wins
  CHECK(rig_path("/elsewhere.toml") == "/elsewhere.toml");
  // a bad default file is reported, not ignored
  std::ofstream(file) << "a4_hz = \"high\"\n";
  CHECK_THROWS_WITH(load_rig(""), Catch::Contains(file + ":1:"));
  ::unlink(file.c_str());
  ::rmdir((dir + "/stepchoir").c_str());
  ::rmdir(dir.c_str());
}

TEST_CASE("rig: a port gets its own [[boards]] entry, else the entry in its place", "[config]") {
  Rig rig;
  rig.config = parse_config("[[boards]]\nport = \"/dev/A\"\n[[boards.motors]]\ntranspose = 1\n"
                            "[[boards]]\nport = \"/dev/B\"\n[[boards.motors]]\ntranspose = 2\n",
                            "two.toml");
  REQUIRE(board_settings(rig, "/dev/B", 0) == &rig.config.boards[1]);  // by port, whatever the order
  CHECK(board_settings(rig, "/dev/A", 1) == &rig.config.boards[0]);
  CHECK(board_settings(rig, "/dev/C", 1) == &rig.config.boards[1]);  // by place
  CHECK(board_settings(rig, "/dev/C", 2) == nullptr);
  // An entry whose port is there belongs to the board on it: another port does not take it.
  Rig there;
  there.config = parse_config("[[boards]]\nport = \"/dev/null\"\n[[boards.motors]]\ntranspose = 1\n", "there.toml");
  CHECK(board_settings(there, "/dev/C", 0) == nullptr);
  CHECK(board_settings(there, "/dev/null", 0) == &there.config.boards[0]);
  const std::string link = "/tmp/stepchoir-test-rig-null";  // another name for the same file
  ::unlink(link.c_str());
  REQUIRE(::symlink("/dev/null", link.c_str()) == 0);
  CHECK(board_settings(there, link, 0) == &there.config.boards[0]);
  ::unlink(link.c_str());
  CHECK(rig_port(rig, "") == "/dev/A");
  CHECK(board_settings(Rig{}, "/dev/A", 0) == nullptr);
}

TEST_CASE("rig: without a port the virtual boards are --vboard's, else the file's boards', else one Uno",
          "[config]") {
  Rig rig;
  rig.config = parse_config("[[boards]]\nboard = \"mega\"\n[[boards]]\n", "two.toml");
  CHECK(rig_vboards(rig, {}) == std::vector<std::string>{"mega", "uno"});  // the second's default
  CHECK(rig_vboards(rig, {"uno"}) == std::vector<std::string>{"uno"});     // the command line wins
  CHECK(rig_vboards(Rig{}, {}) == std::vector<std::string>{"uno"});
  CHECK(rig_port(rig, "").empty());  // no port in the file: the commands start its virtual boards
}

TEST_CASE("rig: several virtual boards, each on its own link and trace beside the first's", "[config]") {
  CHECK(vboard_trace_path("/tmp/t.csv", 0) == "/tmp/t.csv");
  CHECK(vboard_trace_path("/tmp/t.csv", 1) == "/tmp/t-2.csv");
  CHECK(vboard_trace_path("/tmp/t", 2) == "/tmp/t-3.csv");
  CHECK(vboard_trace_path("", 1).empty());  // no trace asked: none for any
  const std::string first = vboard_link_path("live", 0), second = vboard_link_path("live", 1);
  CHECK(first.rfind("/tmp/stepchoir-live-", 0) == 0);
  CHECK(second == first.substr(0, first.size() - 4) + "-2.pty");
}

TEST_CASE("rig: a song command plays on --port, else the file's ports, unless a virtual board was asked for",
          "[config]") {
  Rig rig;
  rig.config = parse_config("[[boards]]\nport = \"/dev/A\"\n[[boards]]\nboard = \"mega\"\n[[boards]]\nport = \"/dev/B\"\n",
                            "three.toml");
  CHECK(rig_ports(rig, {}, false) == std::vector<std::string>{"/dev/A", "/dev/B"});
  CHECK(rig_ports(rig, {"/dev/C"}, false) == std::vector<std::string>{"/dev/C"});
  CHECK(rig_ports(rig, {}, true).empty());  // --vboard and the like win over the file's ports
  CHECK(rig_ports(Rig{}, {}, false).empty());
}

TEST_CASE("rig: the song's motors take their range, transpose, tuning and mutes from the file", "[config]") {
  const LiveConfig c = parse_config("[[boards]]\n"
                                    "[[boards.motors]]\nlowest_note = 40\nhighest_note = 80\n"
                                    "[[boards.motors]]\ntranspose = -12\ntuning_cents = 3.5\nmuted = [60]\n",
                                    "m.toml");
  const std::vector<MotorConfig> music = motor_music(&c.boards[0], 16001000, {1, 0, 3});
  REQUIRE(music.size() == 3);
  CHECK(music[0].transpose == -12);
  CHECK(music[0].tuning_cents == 3.5);
  CHECK(music[0].muted.test(60));
  CHECK(music[1].lowest_note == 40);
  CHECK(music[1].highest_note == 80);
  CHECK(music[2].transpose == 0);  // not in the file: the defaults
  CHECK(music[2].lowest_note == MotorConfig{}.lowest_note);
  for (const MotorConfig &m : music) CHECK(m.f_cpu_hz == 16001000);
  CHECK(motor_music(nullptr, 16000000, {0}).at(0).transpose == 0);
}

TEST_CASE("board memory: in XDG_CACHE_HOME, else ~/.cache - a record kept, replaced and read back", "[config]") {
  {
    ScopedEnv xdg("XDG_CACHE_HOME", "/x/cache");
    CHECK(board_memory_path() == "/x/cache/stepchoir/boards.toml");
  }
  {
    ScopedEnv xdg("XDG_CACHE_HOME", nullptr);
    ScopedEnv home("HOME", "/home/player");
    CHECK(board_memory_path() == "/home/player/.cache/stepchoir/boards.toml");
  }
  const std::string path = scratch_dir("memory") + "/deeper/stepchoir/boards.toml";
  std::remove(path.c_str());
  CHECK_FALSE(recall_board(0x0123456789abcdefull, path));  // no file: met for the first time
  remember_board(0x0123456789abcdefull, {"uno_cnc_shield_v3", 2493.7, 6.1}, path);
  remember_board(0xfedcba9876543210ull, {"mega_ramps_14", -1500.25, 4}, path);
  remember_board(0x0123456789abcdefull, {"uno_cnc_shield_v3", 2494.5, 5.5}, path);  // replaced
  const auto uno = recall_board(0x0123456789abcdefull, path);
  REQUIRE(uno);
  CHECK(uno->name == "uno_cnc_shield_v3");
  CHECK(uno->clock_ppm == 2494.5);
  CHECK(uno->sigma_ppm == 5.5);
  const auto mega = recall_board(0xfedcba9876543210ull, path);
  REQUIRE(mega);
  CHECK(mega->clock_ppm == -1500.25);
  CHECK_FALSE(recall_board(1, path));
  CHECK(board_id_hex(0xabcull) == "0000000000000abc");
}

TEST_CASE("board memory: the keyboard's clock is F_CPU, or as the board's remembered crystal runs", "[config]") {
  CHECK(crystal_hz(16000000, std::nullopt) == 16000000u);  // a board met for the first time
  CHECK(crystal_hz(16000000, BoardRecord{"uno", 5000.0, 5.0}) == 16080000u);
  CHECK(crystal_hz(16000000, BoardRecord{"uno", -1500.25, 5.0}) == 15975996u);  // to the hertz
  CHECK(crystal_hz(16000000, BoardRecord{"uno", 1e7, 5.0}) == 16000000u);        // not a crystal's: left aside
  CHECK(crystal_hz(16000000, BoardRecord{"uno", std::nan(""), 5.0}) == 16000000u);
}

TEST_CASE("board memory: a broken file names its line and column", "[config]") {
  const std::string path = scratch_dir("memory-bad") + "/boards.toml";
  std::ofstream(path) << "[boards.0000000000000001]\nclock_ppm = 'fast'\nsigma_ppm = 3\n";
  CHECK_THROWS_WITH(recall_board(1, path), path + ":1:1: board 0000000000000001: expected clock_ppm and sigma_ppm "
                                                  "(numbers, sigma_ppm >= 0)");
  std::ofstream(path) << "[boards\n";
  CHECK_THROWS_WITH(recall_board(1, path), Catch::StartsWith(path + ":1:"));
}

TEST_CASE("rig: real-time limits allow SCHED_FIFO and memory locking as the limits say", "[config]") {
  RealtimeLimits l;
  l.rtprio = 0;
  l.memlock_bytes = 8u << 20;
  CHECK_FALSE(priority_allowed(l, 60));
  CHECK_FALSE(memory_lock_allowed(l));  // a finite limit: locking the future could fail an allocation
  l.rtprio = 95;
  l.memlock_bytes = UINT64_MAX;
  CHECK(priority_allowed(l, 60));
  CHECK(memory_lock_allowed(l));
  l.rtprio = 59;
  CHECK_FALSE(priority_allowed(l, 60));
  l = RealtimeLimits{};
  l.privileged = true;  // root: no limit applies
  CHECK(priority_allowed(l, 99));
  CHECK(memory_lock_allowed(l));
  // This process's own limits are read (whatever they are here).
  const RealtimeLimits mine = realtime_limits();
  CHECK(mine.privileged == (::geteuid() == 0));
}
