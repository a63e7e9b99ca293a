// config.cpp: TOML configuration for `stepchoir live` (toml++), checked key by key.
#include "config/config.h"

#include <toml++/toml.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "board/vboard_child.h"
#include "config/toml_read.h"

namespace stepchoir {
namespace {

using namespace toml_read;

// Called from: read_motor. The driver power keys of one [[boards.motors]] entry (the board
// checks the pins against its own: a pin it lacks or uses is refused when live configures it).
sc::DriverBody read_power(const std::string &source, const toml::table &t, uint8_t index, uint8_t driver) {
  sc::DriverBody p = default_motor_power(index, driver);
  for (const char *key : {"sleep_pin", "reset_pin"}) {
    const int64_t pin = get_int(source, t, key, sc::kPinNone, 127, sc::kPinNone);
    if (pin == 0 || pin == 1) fail(source, *t.get(key), std::string(key) + " = " + std::to_string(pin) +
                                                            ": pins 0 and 1 are the board's serial link");
    (std::string(key) == "sleep_pin" ? p.sleep_pin : p.reset_pin) = static_cast<int8_t>(pin);
  }
  if (p.sleep_pin != sc::kPinNone && p.sleep_pin == p.reset_pin)
    fail(source, *t.get("reset_pin"), "reset_pin: the same pin as sleep_pin");
  const std::string idle = get_string(source, t, "idle", "none");
  if (idle == "none") p.idle = sc::kIdleNone;
  else if (idle == "sleep") p.idle = sc::kIdleSleep;
  else if (idle == "disable") p.idle = sc::kIdleDisable;
  else fail(source, *t.get("idle"), "idle '" + idle + "': expected none, sleep or disable");
  if (p.idle == sc::kIdleSleep && p.sleep_pin == sc::kPinNone)
    fail(source, *t.get("idle"), "idle = \"sleep\" needs sleep_pin, the Arduino pin wired to the driver's SLEEP");
  p.idle_ms = static_cast<uint16_t>(get_int(source, t, "idle_ms", 0, 65535, p.idle_ms));
  p.wake_us = static_cast<uint16_t>(get_int(source, t, "wake_us", 0, sc::kWakeUsMax, p.wake_us));
  return p;
}

// Called from: read_motor. The motion keys of one [[boards.motors]] entry: a turn is 200 full
// steps unless steps_per_turn says otherwise, and 40 mm (a GT2 belt on a 20-tooth pulley)
// unless steps_per_mm does.
MotionSettings read_motion(const std::string &source, const toml::table &t, uint8_t microsteps) {
  MotionSettings ms;
  ms.steps_per_turn = get_number(source, t, "steps_per_turn", 1, 1e6, 200.0 * microsteps);
  ms.steps_per_mm = get_number(source, t, "steps_per_mm", 0.01, 1e5, ms.steps_per_turn / 40.0);
  ms.acceleration = get_number(source, t, "acceleration", 1, 1e5, ms.acceleration);
  ms.min_speed = get_number(source, t, "min_speed", 0.01, 1e4, ms.min_speed);
  ms.max_speed = get_number(source, t, "max_speed", 0.01, 1e4, ms.max_speed);
  ms.home_speed = get_number(source, t, "home_speed", 0.01, 1e4, ms.home_speed);
  ms.backoff_mm = get_number(source, t, "backoff_mm", 0, 100, ms.backoff_mm);
  if (ms.min_speed > ms.max_speed) fail(source, *t.get("min_speed"), "min_speed must not be above max_speed");
  return ms;
}

// Called from: parse_config for each [[boards.motors]] entry.
MotorSettings read_motor(const std::string &source, const toml::table &t, uint8_t index) {
  known_keys(source, t,
             {"driver", "microsteps", "endstop_active_high", "travel_steps", "pulse_us", "lowest_note", "highest_note",
              "transpose", "tuning_cents", "muted", "mono_channel", "sleep_pin", "reset_pin", "idle", "idle_ms",
              "wake_us", "steps_per_mm", "steps_per_turn", "acceleration", "min_speed", "max_speed", "home_speed",
              "backoff_mm"},
             "[[boards.motors]]");
  MotorSettings m;
  m.hardware = default_motor_hardware(index);
  const std::string driver = get_string(source, t, "driver", "a4988");
  if (driver == "a4988") m.hardware.driver = sc::kDriverA4988;
  else if (driver == "drv8825") m.hardware.driver = sc::kDriverDrv8825;
  else if (driver == "tb6600") m.hardware.driver = sc::kDriverTb6600;
  else fail(source, *t.get("driver"), "driver '" + driver + "': expected a4988, drv8825 or tb6600");
  const int64_t micro = get_int(source, t, "microsteps", 1, 32, m.hardware.microsteps);
  if (micro & (micro - 1)) fail(source, *t.get("microsteps"), "microsteps must be 1, 2, 4, 8, 16 or 32");
  m.hardware.microsteps = static_cast<uint8_t>(micro);
  m.hardware.endstop_active_high = get_bool(source, t, "endstop_active_high", false) ? 1 : 0;
  m.hardware.travel_steps = static_cast<uint32_t>(get_int(source, t, "travel_steps", 0, sc::kMaxTravelSteps,
                                                          m.hardware.travel_steps));
  m.hardware.pulse_us = static_cast<uint8_t>(get_int(source, t, "pulse_us", 2, 10, m.hardware.pulse_us));
  m.power = read_power(source, t, index, m.hardware.driver);
  m.motion = read_motion(source, t, m.hardware.microsteps);
  m.music = read_music(source, t).over(MotorConfig{});
  if (m.music.lowest_note > m.music.highest_note)  // one key set, against the other's default
    fail(source, t, "lowest_note must not be above highest_note");
  m.mono_channel = static_cast<int8_t>(get_int(source, t, "mono_channel", 1, 16, 1) - 1);
  return m;
}

}  // namespace

MotorConfig MusicSettings::over(MotorConfig base) const {
  if (lowest_note) base.lowest_note = *lowest_note;
  if (highest_note) base.highest_note = *highest_note;
  if (transpose) base.transpose = *transpose;
  if (tuning_cents) base.tuning_cents = *tuning_cents;
  if (muted) base.muted = *muted;
  return base;
}

sc::ConfigBody default_motor_hardware(uint8_t motor) {
  sc::ConfigBody c{};
  c.motor = motor;
  c.driver = sc::kDriverA4988;
  c.microsteps = 16;
  c.endstop_active_high = 0;
  c.travel_steps = 3200;
  c.min_period_q8 = sc::kPeriodQ8Min;
  c.max_period_q8 = sc::kPeriodQ8Max;
  c.start_period_q8 = 0;
  c.accel_q8 = 0;
  c.pulse_us = 2;
  return c;
}

sc::DriverBody default_motor_power(uint8_t motor, uint8_t driver) {
  sc::DriverBody p{};
  p.motor = motor;
  p.sleep_pin = sc::kPinNone;
  p.reset_pin = sc::kPinNone;
  p.idle = sc::kIdleNone;
  p.idle_ms = 1000;
  p.wake_us = driver == sc::kDriverDrv8825 ? 1700 : driver == sc::kDriverTb6600 ? 5 : 1000;
  return p;
}

Policy parse_policy(const std::string &s) {
  if (s == "poly") return Policy::kPoly;
  if (s == "channel") return Policy::kChannel;
  if (s == "mono") return Policy::kMono;
  throw std::invalid_argument("policy '" + s + "': expected poly, channel or mono");
}

LiveConfig parse_config(const std::string &text, const std::string &source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error &e) {
    throw std::runtime_error(source + ":" + std::to_string(e.source().begin.line) + ":" +
                             std::to_string(e.source().begin.column) + ": " + std::string(e.description()));
  }
  known_keys(source, root,
             {"a4_hz", "home_on_start", "midi", "allocation", "vibrato", "velocity", "glide", "boards", "presets",
              "controls", "setlist"},
             "the top level");
  LiveConfig c;
  c.a4_hz = get_number(source, root, "a4_hz", 200, 1000, kA4Hz);
  c.home_on_start = get_bool(source, root, "home_on_start", false);
  if (const toml::node *n = root.get("midi")) {
    const toml::table *t = n->as_table();
    if (!t) fail(source, *n, "[midi] must be a table");
    known_keys(source, *t, {"input", "api"}, "[midi]");
    c.midi_input = get_string(source, *t, "input", c.midi_input);
    c.midi_api = get_string(source, *t, "api", c.midi_api);
    if (c.midi_api != "alsa" && c.midi_api != "jack") fail(source, *t->get("api"), "api: expected alsa or jack");
  }
  if (const toml::node *n = root.get("allocation")) {
    const toml::table *t = n->as_table();
    if (!t) fail(source, *n, "[allocation] must be a table");
    known_keys(source, *t, {"policy", "priority", "sing_percussion"}, "[allocation]");
    c.policy = get_policy(source, *t, c.policy);
    c.priority = get_priority(source, *t, c.priority);
    c.sing_percussion = get_bool(source, *t, "sing_percussion", c.sing_percussion);
  }
  if (const toml::node *n = root.get("vibrato")) c.vibrato = read_vibrato(source, *n, c.vibrato, "[vibrato]");
  if (const toml::node *n = root.get("velocity")) c.velocity = read_velocity(source, *n, c.velocity, "[velocity]");
  if (const toml::node *n = root.get("glide")) c.glide = read_glide(source, *n, c.glide, "[glide]");
  if (const toml::node *n = root.get("boards")) {
    const toml::array *boards = n->as_array();
    if (!boards) fail(source, *n, "boards: expected [[boards]] tables");
    for (const toml::node &b : *boards) {
      const toml::table *t = b.as_table();
      if (!t) fail(source, b, "boards: expected [[boards]] tables");
      known_keys(source, *t, {"port", "board", "motors"}, "[[boards]]");
      BoardSettings bs;
      bs.port = get_string(source, *t, "port", "");
      bs.board = get_string(source, *t, "board", bs.board);
      if (std::find(kBoardKinds.begin(), kBoardKinds.end(), bs.board) == kBoardKinds.end())
        fail(source, *t->get("board"), "board '" + bs.board + "': expected " + one_of(kBoardKinds));
      // A board named by its kind has that kind's motors; one on a port alone, up to the protocol's.
      const size_t most = t->get("board") ? board_kind_motors(bs.board) : sc::kMaxMotors;
      if (const toml::node *mn = t->get("motors")) {
        const toml::array *motors = mn->as_array();
        if (!motors) fail(source, *mn, "motors: expected [[boards.motors]] tables");
        for (const toml::node &m : *motors) {
          const toml::table *mt = m.as_table();
          if (!mt) fail(source, m, "motors: expected [[boards.motors]] tables");
          if (bs.motors.size() >= most)
            fail(source, m, t->get("board") ? "board '" + bs.board + "' has " + std::to_string(most) + " motors (motor " +
                                                  std::to_string(most - 1) + " is its last)"
                                            : "a board has at most " + std::to_string(most) + " motors");
          bs.motors.push_back(read_motor(source, *mt, static_cast<uint8_t>(bs.motors.size())));
        }
      }
      c.boards.push_back(std::move(bs));
    }
  }
  if (const toml::node *n = root.get("presets")) c.presets = read_presets(source, *n, c);
  if (const toml::node *n = root.get("controls")) c.controls = read_controls(source, *n);
  if (const toml::node *n = root.get("setlist")) c.setlist = read_setlist(source, *n, c);
  return c;
}

LiveConfig load_config(const std::string &path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  return parse_config(text.str(), path);
}

const char *default_config_text() {
  return R"(# stepchoir rig configuration, read by every command that talks to a board (live, play, jam,
# render, tone, driver, home, jog, center, hello, status, panic): --config FILE, else this file at
# $XDG_CONFIG_HOME/stepchoir/stepchoir.toml (~/.config/stepchoir/stepchoir.toml); `stepchoir
# config --where` prints it. Every key is optional: what is left out keeps the value shown.
# Command-line options (--midi, --midi-api, --policy, --port, --vboard ...) override the file.

# Tuning reference: the frequency of A4 (MIDI note 69), Hz.
a4_hz = 440.0
# true: live, play and jam home every motor with end switches first (`stepchoir home`), so each
# carriage starts in the middle of its rail.
home_on_start = false

[midi]
# MIDI input: its index, part of its name, or "virtual" / "virtual:NAME" for a port that other
# programs connect to.
input = "virtual"
# alsa or jack
api = "alsa"

[allocation]
# poly: any free motor plays a note; channel: MIDI channel n on motor n (n from 1); mono: one
# note a channel, last note wins, in unison on the motors whose mono_channel it is (default 1).
policy = "poly"
# poly, when every motor is busy: steal the "oldest" note, or keep the "lowest" / "highest".
priority = "oldest"
# Drum channels (General MIDI channel 10, or a channel whose bank select chose a drum kit) play
# hits, not pitches: their notes are ignored unless this is true.
sing_percussion = false

[vibrato]
# The mod wheel (CC1) adds a sine in pitch: its rate (Hz), its peak depth (cents) with the wheel
# full up (linear below), and how long (ms) it fades in after a note starts.
rate_hz = 5.5
depth_cents = 50.0
fade_ms = 150.0
# true: channel aftertouch sets the depth too (the larger of the wheel and the pressure).
aftertouch = false

[velocity]
# poly: two motors in unison are louder than one. A note struck at velocity double_at or harder
# takes a second free motor playing its pitch, at triple_at a third; never a motor that sounds
# another note. Velocity 1-127; 0 turns a level off. (The CNC shield and RAMPS set microsteps
# with jumpers, so velocity cannot choose full step or microsteps: doubling is what it does.)
double_at = 100
triple_at = 120

[glide]
# Glide (portamento) every channel starts with: its time in ms (0-2032; CC5 sets it in 16 ms steps)
# and on = true to glide without CC65 (CC65 still turns it on and off).
time_ms = 0
on = false

# Presets: one [[presets]] table each, switched by MIDI program change on any channel; the first
# is active at start. program: 1-128 as the keyboard shows it; name: printed when it becomes
# active; bank (0-16383, CC0 * 128 + CC32): only that bank's program change selects it (default:
# any bank). A preset may set policy, priority, transpose (semitones, every motor, -48..48),
# bend_range (semitones, 0-24), mute_motors (motor indexes: silent in this preset), and tables
# [presets.vibrato], [presets.velocity], [presets.glide] as above; what it leaves out keeps the
# value above. Zones (policy poly): [[presets.zones]] with lowest / highest key (MIDI notes),
# channel (1-16, absent: any) and motors (indexes, motor 0 is the first board's first): a note
# plays only on the motors of the zones it falls in, once in each (a layer); with zones, a note
# in none is not played. One motor's music: [[presets.motors]] with motor (its index) and any of
# lowest_note, highest_note, transpose, tuning_cents and muted, as in [[boards.motors]] below
# (muted: the whole list); what it leaves out keeps that motor's own. A program change silences
# every note; held keys sound again only when struck again. For example, a plain preset on
# program 1 and a split on program 2 whose motor 0 plays the bass within E2-E4:
#   [[presets]]
#   program = 1
#   name = "plain"
#
#   [[presets]]
#   program = 2
#   name = "split"
#   transpose = 12
#   [presets.glide]
#   time_ms = 200
#   [[presets.zones]]
#   highest = 59
#   motors = [0, 1]
#   [[presets.zones]]
#   lowest = 60
#   motors = [2, 3]
#   [[presets.motors]]
#   motor = 0
#   lowest_note = 40
#   highest_note = 64

# Stage controls (`stepchoir live --learn` writes them): one [[controls]] table a knob or pedal.
# action: transpose_up, transpose_down, octave_up, octave_down, glide_time, vibrato_depth,
# vibrato_rate, preset_next, preset_previous, setlist_next, setlist_previous, panic or mute_motor
# (with motor = N); cc: its controller number (0-119); channel: 1-16, absent for any. For example,
# a footswitch on CC 67 that steps to the next preset:
# [[controls]]
# action = "preset_next"
# cc = 67

# The setlist `live` steps through (setlist_next, setlist_previous): each item a preset (by name),
# a song file (relative to this file) played jam style on song_motors (default: the motors its
# preset mutes) while the keyboard plays the others, or both; name, tempo and transpose optional.
# [setlist]
# items = [{ preset = "plain" }, { song = "ode.mid", preset = "split", tempo = 0.9 }]


# One [[boards]] table per board, in order: their motors form one pool. A command without --port
# uses the file's ports; with no port in the file either, live, play and jam start a virtual
# board for each [[boards]] table (render always does), each with its motors.
# [[boards]]
# port = "/dev/ttyACM0"
# board = "uno"              # uno or mega: what its virtual board simulates (--vboard wins)
#
# One [[boards.motors]] table per motor of that board, motor 0 first. A listed motor is
# configured on the board (the values below are the defaults); motors not listed keep the
# board's own settings and the default range.
# [[boards.motors]]
# driver = "a4988"           # a4988, drv8825 or tb6600
# microsteps = 16            # 1, 2, 4, 8, 16 or 32, as the driver supports (TB6600: its DIP switches)
# endstop_active_high = false  # true: a pressed switch reads HIGH
# travel_steps = 3200        # length of travel in steps; 0 = no soft limits
# pulse_us = 2               # STEP high time, 2 to 10 us (TB6600: 5)
# lowest_note = 21           # playable range, MIDI notes; notes outside fold by octaves
# highest_note = 108
# transpose = 0              # semitones added to every note
# tuning_cents = 0.0         # added to every note's pitch
# muted = []                 # MIDI notes this motor must not play (resonances)
# mono_channel = 1           # policy mono: the MIDI channel (1-16) this motor follows, in unison
#                            #   with the other motors of that channel
# sleep_pin = -1             # Arduino pin wired to the driver's SLEEP input, -1 = none (the CNC
#                            #   shield and RAMPS tie SLEEP to RESET: wire it to a free pin, A0 = 14)
# reset_pin = -1             # Arduino pin wired to the driver's RESET input, -1 = none
# idle = "none"              # when silent for idle_ms: "none" (stays energized, warm, holding),
#                            #   "sleep" (SLEEP low; needs sleep_pin) or "disable" (ENABLE off; a
#                            #   shared ENABLE goes off once every motor on it is idle)
# idle_ms = 1000             # silence before the idle power-down, 0 to 65535 ms
# wake_us = 1000             # the driver's wake-up time, waited before a woken motor's first
#                            #   step: 0 to 2500 us (default a4988 1000, drv8825 1700, tb6600 5)
# Motion (`stepchoir home`, `jog`, `center`), the seed's StepDriver ramp v^2 = v0^2 + 2as:
# steps_per_turn = 3200      # microsteps a turn (default 200 x microsteps)
# steps_per_mm = 80.0        # microsteps a mm of carriage travel (default steps_per_turn / 40:
#                            #   a GT2 belt on a 20-tooth pulley)
# acceleration = 500.0       # mm/s^2
# min_speed = 5.0            # mm/s: a move's first and last steps
# max_speed = 40.0           # mm/s (the board steps at most 5,000 steps/s)
# home_speed = 20.0          # mm/s toward a switch while homing (the second touch: a quarter)
# backoff_mm = 2.0           # off a switch once it fired
)";
}

}  // namespace stepchoir
