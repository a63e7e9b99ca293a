// rig.h: the one rig file every command reads: where it is, which board entry a port gets,
// and what a command takes from it (the port, the motors' settings on the board and in the
// planner).
//
// A command uses --config FILE if given, else the default location if a file is there, else
// none (every setting at its default). Command-line options win over the file.
#ifndef STEPCHOIR_HOST_CONFIG_RIG_H
#define STEPCHOIR_HOST_CONFIG_RIG_H

#include <functional>
#include <string>
#include <vector>

#include "board/board.h"
#include "config/config.h"

namespace stepchoir {

// $xdg_variable/stepchoir/name, or ~/home_dir/stepchoir/name when the variable is unset or
// empty ("" when HOME is unset too), as the XDG base directory spec says. Called from:
// default_config_path, board_memory_path.
std::string xdg_file(const char *xdg_variable, const char *home_dir, const std::string &name);

// $XDG_CONFIG_HOME/stepchoir/stepchoir.toml, or ~/.config/stepchoir/stepchoir.toml when
// XDG_CONFIG_HOME is unset or empty ("" when HOME is unset too). Called from: rig_path,
// `stepchoir config --where`.
std::string default_config_path();

// The file a command reads: `given` if not empty, else the default location if a file is
// there, else "" (none). Called from: every command that takes --config.
std::string rig_path(const std::string &given);

// A loaded rig: the file's settings (defaults when there is no file) and where they came from.
struct Rig {
  std::string path;  // "" = no file
  LiveConfig config;
};

// Loads rig_path(given). Throws std::runtime_error "PATH:LINE:COLUMN: ..." for a bad file.
Rig load_rig(const std::string &given);

// The [[boards]] entry for the board at `port`, the `index`-th of the command's boards: the
// entry whose port is that port (the same file: a by-id link names its ttyACM node), else the index-th entry if it names no port or one that is
// not there (the board plugged in elsewhere), else none. Called from: the commands, after they
// opened the board.
const BoardSettings *board_settings(const Rig &rig, const std::string &port, size_t index);

// The board a one-board command talks to: --port if given, else the file's first board's port,
// else "". Called from: main.
std::string rig_port(const Rig &rig, const std::string &port);

// The boards a song command (live, play, jam) plays on: `ports` (--port) if given, else the
// file's ports unless `virtual_asked` (a virtual board's option was given: the command line
// wins), else none (the command starts virtual boards: rig_vboards).
std::vector<std::string> rig_ports(const Rig &rig, const std::vector<std::string> &ports, bool virtual_asked);

// The boards the virtual boards simulate when a command has no port at all: `given` (--vboard)
// if not empty, else each [[boards]] entry's board, else one Uno. Called from: play, render, jam,
// live.
std::vector<std::string> rig_vboards(const Rig &rig, const std::vector<std::string> &given);

// Sends the configuration and the driver settings of every motor `settings` lists (up to the
// board's motor count); throws naming the port, the motor and the board's error when it refuses
// one. Called from: every command that plays notes, after hello, before the first note.
void configure_motors(Board &board, const Caps &caps, const BoardSettings &settings, const std::string &port);

// Homes every motor of the board that has an end switch, all at once (board/motion.h
// home_motors), with the file's travel and motion settings where `settings` lists the motor;
// `motors` empty: all of them, else those. A motor without switches is skipped with a line to
// `say` unless asked for by name (then home_motors throws before any motor moves). A motor
// whose switch did not fire leaves the others to finish; then this throws, a line for each such
// motor. Called from: `stepchoir home`, and live, play and jam when the file sets home_on_start,
// after configure_motors.
void home_board(Board &board, const Caps &caps, const BoardSettings *settings, const std::string &port,
                const std::vector<int> &motors, const std::function<void(const std::string &)> &say);

// The file's settings of the keyboard's allocation: priority, drum channels, tuning, vibrato,
// velocity doubling and glide (policy and motors are the caller's). Called from: live, jam.
void apply_allocation(const LiveConfig &cfg, AllocatorConfig *alloc);

// Prints a line and flushes stdout: home_board's `say` for the commands.
void say_line(const std::string &line);

// One motor's travel (steps) and motion settings: the file's, else the defaults.
uint32_t motor_travel(const BoardSettings *settings, uint8_t motor);
MotionSettings motor_motion(const BoardSettings *settings, uint8_t motor);
// One motor's channel under policy mono (0-15): the file's, else 0 (channel 1, in unison with
// every motor the file leaves out). Called from: live, jam.
int8_t motor_mono_channel(const BoardSettings *settings, uint8_t motor);

// The planner's and allocator's view of the board's motors `ids`: each one's musical settings
// from the file (range, transpose, tuning, mutes) and the board's clock (Hz). Motors the file
// does not list keep the defaults. Called from: play, render, jam.
std::vector<MotorConfig> motor_music(const BoardSettings *settings, uint32_t f_cpu_hz, const std::vector<uint8_t> &ids);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CONFIG_RIG_H
