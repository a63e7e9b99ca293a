// config.h: the rig configuration file (TOML): boards, motors, allocation, MIDI (config/rig.h:
// where it is and what each command takes from it).
//
// Every key is optional; what is missing keeps its default. `stepchoir config --print-default`
// prints default_config_text(), a commented file that loads to exactly the defaults.
#ifndef STEPCHOIR_HOST_CONFIG_H
#define STEPCHOIR_HOST_CONFIG_H

#include <bitset>
#include <optional>
#include <string>
#include <vector>

#include "board/motion.h"
#include "live/allocator.h"
#include "live/presets.h"
#include "live/stage.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

// A motor's musical keys as one table of the file sets them ([[boards.motors]], [[presets.motors]]):
// each key left out is empty.
struct MusicSettings {
  std::optional<uint8_t> lowest_note, highest_note;  // playable range, MIDI notes, inclusive
  std::optional<int8_t> transpose;                   // semitones added to every note, -48..48
  std::optional<double> tuning_cents;                // added to every note's pitch, -1200..1200
  std::optional<std::bitset<128>> muted;             // MIDI notes the motor must not play (the whole set)

  // `base` with what this sets in its place. Called from: the config loader, preset_config.
  MotorConfig over(MotorConfig base) const;
};

// One motor as the file describes it: the board's driver settings (sent as a config frame)
// and its musical settings (for the allocator; f_cpu_hz comes from the board's hello).
struct MotorSettings {
  sc::ConfigBody hardware{};  // .motor is filled in by position
  sc::DriverBody power{};     // SLEEP and RESET pins, idle power-down, wake time (kMsgDriver)
  MotorConfig music;
  int8_t mono_channel = 0;    // policy mono: the MIDI channel (0-15) whose group the motor is in
  MotionSettings motion;      // moves: home, jog, center
};

struct BoardSettings {
  std::string port;                   // serial port or link; "" = none given
  std::string board = "uno";          // uno or mega: what the virtual board simulates for this
                                      // entry (render; live, play and jam with no port at all)
  std::vector<MotorSettings> motors;  // in motor order; motors not listed keep their board's defaults
};

// One [[presets.zones]] entry: the keys and channel whose notes the listed motors play.
struct ZoneSettings {
  uint8_t lowest = 0, highest = 127;  // keys, MIDI notes, inclusive
  int8_t channel = -1;                // 0-15 (the file says 1-16), -1: any
  std::vector<uint8_t> motors;        // pool motor indexes
  std::string where;                  // "FILE:LINE:COLUMN" of its motors, for a motor the pool lacks
};

// One [[presets.motors]] entry: a pool motor's musical settings while its preset is active.
struct PresetMotorSettings {
  uint8_t motor = 0;    // pool index (0: the first board's first motor)
  MusicSettings music;  // what it leaves out keeps the motor's own (its [[boards.motors]] entry's)
  std::string where;    // "FILE:LINE:COLUMN" of its motor key, for a motor the pool lacks or a bad range
};

// One [[presets]] table. What it does not set keeps the file's top-level value.
struct PresetSettings {
  uint8_t program = 1;            // 1-128, as keyboards show it (the wire's 0-127 plus 1)
  int32_t bank = -1;              // 0-16383 (CC0 * 128 + CC32), -1: any bank
  std::string name;
  std::string where;              // "FILE:LINE:COLUMN" of its table
  std::optional<Policy> policy;   // absent: the top level's (or --policy's)
  Priority priority = Priority::kOldest;
  int8_t transpose = 0;           // semitones for every motor, -48..48
  uint8_t bend_range = kDefaultBendSemitones;  // semitones, the initial RPN 0 range
  VibratoConfig vibrato;
  VelocityConfig velocity;
  GlideConfig glide;
  std::vector<uint8_t> mute_motors;  // pool motor indexes silent in this preset
  std::string mute_where;            // "FILE:LINE:COLUMN" of mute_motors
  std::vector<ZoneSettings> zones;
  std::vector<PresetMotorSettings> motors;  // [[presets.motors]], at most one a motor
};

// One [[controls]] table: a learned controller (`stepchoir live --learn` writes them).
struct ControlSettings {
  Binding binding;
  std::string where;  // "FILE:LINE:COLUMN" of its table, for a motor the pool lacks
};

// One item of the [setlist]: a preset, a song played jam style on some motors while the
// keyboard plays the others, or both.
struct SetlistItem {
  std::string name;                  // for displays: its own, else the preset's, else the song file's
  int preset = -1;                   // index into LiveConfig::presets; -1: the preset stays as it is
  std::string song;                  // the song file ("" none); relative: from the rig file's directory
  std::vector<uint8_t> song_motors;  // pool motors the song plays: its own, else its preset's mute_motors
  double tempo = 1.0;                // tempo scale of the song
  int transpose = 0;                 // semitones for the song
  std::string where;                 // "FILE:LINE:COLUMN" of the item
};

struct LiveConfig {
  std::string midi_input = "virtual";
  std::string midi_api = "alsa";
  Policy policy = Policy::kPoly;
  Priority priority = Priority::kOldest;
  bool sing_percussion = false;  // [allocation] sing_percussion: drum channels' notes as pitches
  double a4_hz = kA4Hz;
  bool home_on_start = false;     // live, play and jam home the motors with switches first
  VibratoConfig vibrato;          // [vibrato]: the mod wheel's
  VelocityConfig velocity;        // [velocity]: from which velocity a poly note takes a second and third motor
  GlideConfig glide;              // [glide]: the glide every channel starts with
  std::vector<BoardSettings> boards;
  std::vector<PresetSettings> presets;  // [[presets]], in file order: the first is active at start
  std::vector<ControlSettings> controls;  // [[controls]], in file order
  std::vector<SetlistItem> setlist;       // [setlist] items, in order
};

// Hardware defaults for one motor: A4988 at 16 microsteps, switches active low, 3200 steps of
// travel, the whole period range, no onset ramp, 2 us pulses.
// Called from: the config loader, tests.
sc::ConfigBody default_motor_hardware(uint8_t motor);

// Driver power defaults for one motor: no SLEEP or RESET pin, idle none after 1000 ms, and the
// driver's wake-up time (us): A4988 1000, DRV8825 1700, TB6600 5 (its ENABLE).
// Called from: the config loader, tests.
sc::DriverBody default_motor_power(uint8_t motor, uint8_t driver);

// Reads and checks a configuration file. Throws std::runtime_error "PATH:LINE:COLUMN: what is
// wrong" for a syntax error, an unknown key, a value of the wrong type or out of range.
// Called from: load_rig, `stepchoir config --check`.
LiveConfig load_config(const std::string &path);
// The same from text; source names it in messages.
LiveConfig parse_config(const std::string &text, const std::string &source);

// The commented default configuration. Called from: `stepchoir config --print-default`.
const char *default_config_text();

// The allocator configuration of preset p over `base` (the top level's, with the pool's motors):
// what p sets replaces base's; a [[presets.motors]] entry replaces only the keys it sets of that
// motor's own. Throws std::runtime_error "FILE:LINE:COLUMN: ..." for a motor index the pool lacks,
// a motor's lowest_note above its highest_note, or zones under a policy other than poly.
// Called from: live_presets; tests.
AllocatorConfig preset_config(const AllocatorConfig &base, const PresetSettings &p);

// Every preset of the file as the engine holds them (LiveSession::set_presets), in file order.
// Called from: `stepchoir live`, before the session starts. Throws as preset_config.
std::vector<LivePreset> live_presets(const LiveConfig &config, const AllocatorConfig &base);

// The learned controllers of the file, checked against a pool of motor_count motors. Throws
// std::runtime_error "FILE:LINE:COLUMN: ..." for a mute_motor whose motor the pool lacks.
// Called from: `stepchoir live`, before the session starts.
std::vector<Binding> live_controls(const LiveConfig &config, size_t motor_count);

// The file's presets and controls for a keyboard that plays only some of the pool's motors (jam:
// a song plays the others). keyboard: the keyboard's motors as pool indexes, in order (jam's
// console shows them so); each pool index the presets and controls name becomes its index among
// them (keyboard_motor). A motor the keyboard lacks
// is left out of mute_motors, zones (a zone left with none goes; a preset whose zones all go
// mutes every keyboard motor) and [[presets.motors]], and a control muting it goes; each is told
// in left_out ("FILE:LINE:COLUMN: motor N plays the song: left out of ...").
// Called from: `stepchoir jam`, before its session starts.
LiveConfig keyboard_view(const LiveConfig &config, const std::vector<size_t> &keyboard,
                         std::vector<std::string> *left_out);
// Pool motor `motor`'s index among the keyboard's motors (pool indexes, in order); nullopt when
// the keyboard lacks it. Called from: keyboard_view, the console (a typed mute_motor).
std::optional<uint8_t> keyboard_motor(const std::vector<size_t> &keyboard, size_t motor);

// The [[controls]] table of a binding, as save_control writes it.
std::string control_text(const Binding &b);

// Saves a learned controller to the rig file at path (created, with its directory, when
// missing): removes every [[controls]] table on the same controller and channel or with the
// same action (and motor), then appends b's. The rest of the file is kept as written. The file
// is replaced in one rename. Throws std::runtime_error naming the path when it cannot write,
// or "PATH:LINE:COLUMN: ..." when the result would not load.
// Called from: `stepchoir live --learn`, on the main thread.
void save_control(const std::string &path, const Binding &b);

// "poly" / "channel" / "mono"; throws std::invalid_argument naming the value otherwise.
Policy parse_policy(const std::string &name);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CONFIG_H
