// allocator.h: the pure note-to-motor allocation engine: MIDI channel messages in, motor periods out.
//
// The Allocator owns no I/O, no threads and no heap: every table is a fixed array inside the
// object, so after construction nothing it does allocates, blocks, logs or throws. It is meant
// to live on the real-time engine thread, which feeds it one MidiEvent at a time and sends the
// period entries it returns to the boards.
//
// Motors are numbered 0 .. motor_count-1 across the whole setup; mapping an index to a board
// and the board's own motor number is the caller's business (sc::PeriodEntry::motor carries
// the allocator's index).
//
// Policies (AllocatorConfig::policy):
//   kPoly     every channel shares every motor. A note takes a free motor that can play it;
//             when none is free it takes a doubler (below), else steals one (Priority: the
//             oldest note, or keeps the lowest notes, or keeps the highest notes). A stolen or
//             refused note is forgotten: it does not come back when a motor frees up.
//   kChannel  MIDI channel n plays on motor n alone (channels >= motor_count are ignored),
//             monophonic with last-note priority and note memory, as kMono.
//   kMono     each channel owns a group of motors (AllocatorConfig::mono_channel). The channel
//             plays one note at a time, in unison on every motor of its group; the last key
//             pressed sounds, and releasing it returns to the most recent key still held.
//
// Velocity -> loudness (AllocatorConfig::velocity, live/velocity.h), kPoly only: a stepper has one
// volume, but motors in unison are louder. A note-on at velocity >= double_at takes one free motor
// more, >= triple_at two (by default 100 and 120; 0 or above 127: that level off). These doublers
// are free motors only (doubling never stops a sounding note) whose own transpose, folding and
// mutes give the very note the note's motor plays, the fewest octaves of folding first; they play
// it with its channel's bend, vibrato (same phase) and glide, and their own tuning. A note-off, the
// pedal's lift, all-notes-off, all-sound-off and panic end them with the note. The same key struck
// again keeps its motor and gets the doublers its new velocity asks for (fewer: the highest motors
// go). When a new note finds no motor free it takes a motor that sounds in unison with another
// before it steals: the biggest unison first, a doubler before the note's own motor (then a doubler
// becomes the note's own and the note sounds on), so a doubled note is never stolen while it has a
// doubler. kMono groups are unison already and kChannel has one motor a channel: there velocity
// changes nothing. Cost: a note-on that finds no motor free compares every pair of motors once (32
// motors: 1,024 pairs).
// On the supported rigs (Uno + CNC Shield V3, Mega + RAMPS 1.4) the drivers' microstep selects
// M0-M2 are jumpers, not pins, so velocity cannot pick full step or microsteps: doubling only.
//
// Per motor: a playable range, octave folding into it, transpose, tuning offset and a set of
// muted notes (resonances). Range and muted notes apply to the note the motor plays, that is
// after transpose and before bend and tuning. A note outside the range moves by whole octaves
// to the nearest octave inside it; a muted note moves to the nearest unmuted octave inside the
// range; in kPoly a motor that plays the note unfolded is preferred to one that must fold it.
// A motor that cannot play a note at all (every octave of it muted) does not take it.
//
// Zones (AllocatorConfig::zones, kPoly only): a zone maps a key range and a MIDI channel (or any)
// to a set of motors. With zones, a note plays only on the motors of the zones its key and
// channel fall in: once in each such zone (a layer: a voice per zone, each free, stolen or doubled
// among its zone's motors alone); a note no zone covers is not played. Without zones every motor
// takes any note. Zones match the key as received, before any transpose.
//
// A preset (AllocatorConfig as live/presets.h switches them) may also set a transpose for every
// motor (added to each motor's own), mute whole motors (they play nothing in any policy), the bend
// range every channel starts with, and the glide every channel starts with (live/glide.h
// GlideConfig); configure() applies a new one between notes.
//
// Percussion: General MIDI channel 10, and any channel whose bank select (CC0 120 or 127, then a
// program change) chose a drum kit, plays drum hits, not pitches. Their notes are ignored
// unless AllocatorConfig::sing_percussion is set (CC0 121 and a program change make a channel
// melodic again).
//
// MIDI handled, per channel: note on/off (velocity 0 = off; a loud one doubles, above), sustain
// pedal (CC64), pitch bend with a per-channel range (RPN 0 through CC101/100 + CC6/38), vibrato on
// the mod wheel (CC1) and, when configured, channel aftertouch (live/vibrato.h), glide (CC65 on,
// CC5 its time: live/glide.h; tick() moves both on between events), all-sound-off (CC120),
// reset-all-controllers (CC121), all-notes-off (CC123; CC124-127 imply it, as MIDI says).
// Channel mode messages act on the channel they arrive on, as MIDI defines; panic() acts on
// everything. Every other message is ignored.
#ifndef STEPCHOIR_HOST_ALLOCATOR_H
#define STEPCHOIR_HOST_ALLOCATOR_H

#include <array>
#include <bitset>
#include <cstddef>
#include <cstdint>

#include "core/midi_event.h"
#include "core/pitch.h"
#include "live/glide.h"
#include "live/velocity.h"
#include "live/vibrato.h"
#include "stepchoir_protocol.h"

namespace stepchoir {

enum class Policy : uint8_t { kPoly, kChannel, kMono };

// kPoly only: which sounding note loses its motor when a new note finds none free.
enum class Priority : uint8_t {
  kOldest,   // steal the motor whose note started longest ago
  kLowest,   // lowest-note priority: steal the highest note, unless the new note is higher still
  kHighest,  // highest-note priority: steal the lowest note, unless the new note is lower still
};

// One motor's musical settings.
struct MotorConfig {
  uint32_t f_cpu_hz = 16000000;  // clock of the board driving this motor (Caps::f_cpu_hz, or
                                 // as its crystal runs: config/board_memory.h crystal_hz)
  uint8_t lowest_note = 21;      // playable range, MIDI notes, inclusive (default: piano, A0..C8,
  uint8_t highest_note = 108;    //   which stays within the firmware's period limits at 16 MHz)
  int8_t transpose = 0;          // semitones added to every note before folding
  double tuning_cents = 0.0;     // added to every note's pitch
  std::bitset<128> muted;        // MIDI notes this motor must not play (after transpose)
};

// The note motor config mc plays for a key (transpose, octave folding into its range, mutes)
// and how many octaves it had to move; false when every octave of it inside the range is
// muted. transpose: semitones added besides the motor's own (a preset's). Called from: the
// Allocator (live) and the song planner. Pure.
bool resolve_note(const MotorConfig &mc, uint8_t note, uint8_t *played, int *octaves, int transpose = 0) noexcept;

// The bend range every channel starts with unless a configuration says otherwise, semitones each way.
constexpr uint8_t kDefaultBendSemitones = 2;

// kPoly: a split or layer zone: the keys (as received) and channel whose notes the motors play.
struct Zone {
  uint8_t lowest = 0, highest = 127;  // keys, MIDI notes, inclusive
  int8_t channel = -1;                // MIDI channel 0-15, or -1: any
  uint32_t motors = 0;                // bit m: motor m may play the zone's notes

  constexpr bool covers(uint8_t ch, uint8_t key) const noexcept {
    return key >= lowest && key <= highest && (channel < 0 || channel == ch);
  }
};

struct AllocatorConfig {
  static constexpr size_t kMaxMotors = 32;  // motors one Allocator can drive (a bit each in a uint32_t)
  static constexpr size_t kMaxZones = 16;   // zones one configuration can hold

  uint8_t motor_count = 1;  // 1 .. kMaxMotors
  Policy policy = Policy::kPoly;
  Priority priority = Priority::kOldest;
  bool sing_percussion = false;  // true: percussion channels' notes take motors as pitches
  double a4_hz = kA4Hz;     // tuning reference for every motor
  VibratoConfig vibrato;    // the mod wheel's (and aftertouch's) vibrato
  VelocityConfig velocity;  // kPoly: the velocities from which a note takes a second and third motor
  std::array<MotorConfig, kMaxMotors> motors{};
  // kMono only: the channel (0-15) whose group motor m belongs to, or -1 for none.
  std::array<int8_t, kMaxMotors> mono_channel = filled(-1);
  // What a preset sets besides the above (live/presets.h):
  int8_t transpose = 0;                        // semitones added to every key besides each motor's own, -48..48
  uint8_t bend_range = kDefaultBendSemitones;  // semitones each way every channel starts with (RPN 0 changes it)
  GlideConfig glide;                           // the glide every channel starts with
  uint32_t muted_motors = 0;                   // bit m: motor m plays nothing
  uint8_t zone_count = 0;                      // kPoly: zones[0 .. zone_count-1] apply; 0: any motor, any note
  std::array<Zone, kMaxZones> zones{};

 private:
  static constexpr std::array<int8_t, kMaxMotors> filled(int8_t v) {
    std::array<int8_t, kMaxMotors> a{};
    for (auto &x : a) x = v;
    return a;
  }
};

// What one motor plays, for displays and tests.
struct MotorState {
  bool sounding = false;    // the motor plays a note (its period may still be 0 if the
                            //   pitch is below what the period field can hold)
  uint8_t channel = 0;      // MIDI channel of the note, 0-15
  uint8_t note = 0;         // the MIDI key, as received
  uint8_t played_note = 0;  // the note the motor plays: key + transpose, folded
  bool held = false;        // the key is down
  bool sustained = false;   // the key is up and the sustain pedal holds the note
  bool doubling = false;    // an extra motor of a loud note, in unison with the note's own
  uint32_t period_q8 = sc::kPeriodSilent;  // current period, ticks q8, 0 = silent
};

class Allocator {
 public:
  static constexpr size_t kMaxMotors = AllocatorConfig::kMaxMotors;
  static constexpr uint8_t kDefaultBendRange = kDefaultBendSemitones;

  // Why a configuration is unusable, or nullptr when it is fine.
  // Called from: any thread. Does not allocate or block.
  static const char *validate(const AllocatorConfig &config) noexcept;

  // Starts with every motor silent, pedals up, bends centred, bend ranges at config.bend_range.
  // Throws std::invalid_argument (with validate()'s reason) for an unusable configuration.
  // Called from: setup code, before the engine thread runs. Does not allocate.
  explicit Allocator(const AllocatorConfig &config);

  // Replaces the configuration (a preset switch): forgets every note, held or sustained, and
  // resets every channel as construction does; the next flush() (or handle()) writes a silent
  // entry for every motor that was sounding, so nothing is left stuck. Returns false and changes
  // nothing when validate() rejects the configuration.
  // Called from: the engine thread (LiveSession, at a program change), setup code. Does not
  // allocate or block; copies the configuration (about 2 KB).
  bool configure(const AllocatorConfig &config) noexcept;

  // Applies one MIDI event and writes the motors whose period changed because of it (and any
  // left over from an earlier call) to out, lowest motor first, at most max_out entries.
  // Returns the count written. With max_out >= motor_count nothing is ever left over; with
  // less, flush() returns the rest.
  // Called from: the engine thread. Does not allocate, block or throw.
  size_t handle(const MidiEvent &event, sc::PeriodEntry *out, size_t max_out) noexcept;

  // Moves vibrato on to now_us (monotonic_us): retunes every motor whose channel's mod wheel
  // (or aftertouch) is up and writes those whose period changed, as handle() does.
  // Called from: the engine thread, every kVibratoTickUs while vibrating(). Does not allocate.
  size_t tick(uint64_t now_us, sc::PeriodEntry *out, size_t max_out) noexcept;
  // True while a sounding motor's channel has its mod wheel (or aftertouch) up, or a motor
  // glides: tick() has work.
  bool vibrating() const noexcept;

  // Writes the motors whose period changed since it was last reported, at most max_out.
  // Called from: the engine thread. Does not allocate or block.
  size_t flush(sc::PeriodEntry *out, size_t max_out) noexcept;

  // Silences everything: forgets every held and sustained note and lifts every sustain
  // pedal (bends and bend ranges stay). Writes a silent entry for every motor, whatever was
  // reported before, at most max_out (flush() returns the rest).
  // Called from: the engine thread. Does not allocate or block.
  size_t panic(sc::PeriodEntry *out, size_t max_out) noexcept;

  // Changes the tuning reference; sounding motors are retuned (flush() reports them).
  // Ignored unless a4_hz is finite and positive.
  // Called from: the engine thread. Does not allocate or block.
  void set_a4_hz(double a4_hz) noexcept;

  // The performer's stage controls (live/stage.h). They outlast configure(): a preset switch
  // keeps the stage transpose and mutes. Called from: the engine thread (LiveSession), setup
  // code, tests. Do not allocate or block.
  // Semitones (clamped to -48..48) added to every key besides the preset's and each motor's
  // transpose, for notes that start from now: a held note keeps its pitch, and its note-off
  // still finds it by key.
  void set_stage_transpose(int semitones) noexcept;
  int stage_transpose() const noexcept { return stage_transpose_; }
  // Bit m: motor m plays nothing. A newly muted motor falls silent now (in kPoly its note
  // moves to one of its doublers, if any); an unmuted one in kMono/kChannel rejoins its
  // channel's note at once, in kPoly it takes the next note.
  void set_stage_mutes(uint32_t mask) noexcept;
  uint32_t stage_mutes() const noexcept { return stage_mutes_; }
  // A control change on every channel (a knob that sets every channel's vibrato depth or glide).
  void control_all(uint8_t cc, uint8_t value) noexcept;
  // The vibrato's rate (0 < hz <= 20; else ignored), phase-continuous: every sounding note's
  // sine carries on from where it is. Until the next configure().
  void set_vibrato_rate(double hz) noexcept;

  // Queries. Called from: the engine thread (or any thread while the engine is stopped).
  // Do not allocate or block.
  MotorState motor(size_t m) const noexcept;          // a default MotorState for m out of range
  size_t motor_count() const noexcept { return config_.motor_count; }
  const AllocatorConfig &config() const noexcept { return config_; }
  double bend_semitones(uint8_t channel) const noexcept;  // current bend of a channel
  double bend_range_semitones(uint8_t channel) const noexcept;
  bool sustain(uint8_t channel) const noexcept;           // the channel's pedal is down

 private:
  static constexpr uint8_t kNone = 0xFF;
  static constexpr uint32_t kUnreported = 0xFFFFFFFFu;  // never a valid period
  static constexpr uint16_t kBendCentre = 8192;

  // What a motor is doing. In kMono/kChannel the fields mirror the channel's current note.
  struct Voice {
    bool active = false;
    uint8_t channel = 0, note = 0, played = 0;
    bool held = false, sustained = false;
    uint64_t started = 0;  // note-on sequence number (kPoly stealing)
    uint64_t onset_us = 0;  // when the motor began this note (its vibrato's phase)
    bool doubler = false;   // kPoly: an extra motor of a loud note, in unison with its own motor
    uint8_t layer = kNone;  // kPoly with zones: the zone the voice plays the key for, else kNone
  };

  struct Channel {
    bool pedal = false;
    uint16_t bend = kBendCentre;
    uint8_t range_semitones = kDefaultBendRange, range_cents = 0;
    uint8_t rpn_msb = 127, rpn_lsb = 127;  // selected RPN; 127/127 = none
    uint8_t bank = 0;                      // bank select MSB, taken at the next program change
    bool percussion = false;               // a drum kit: its notes are hits, not pitches
    uint8_t mod = 0, pressure = 0;         // mod wheel (CC1) and channel aftertouch
    bool glide = false;                    // portamento on (CC65)
    uint32_t glide_us = 0;                 // glide time (CC5: kGlideUsPerStep a step)
    // kMono/kChannel note memory: keys in press order, most recent last, no duplicates;
    // key_up marks keys released while the pedal was down (they still count).
    std::array<uint8_t, 128> keys{};
    uint8_t depth = 0;
    std::bitset<128> key_up;
  };

  bool is_poly() const noexcept { return config_.policy == Policy::kPoly; }
  void reset_state() noexcept;
  void note_on(uint8_t ch, uint8_t note, uint8_t velocity) noexcept;
  void note_off(uint8_t ch, uint8_t note) noexcept;
  void control_change(uint8_t ch, uint8_t cc, uint8_t value) noexcept;
  void set_pedal(uint8_t ch, bool down) noexcept;
  void all_notes_off(uint8_t ch) noexcept;
  void all_sound_off(uint8_t ch) noexcept;
  void poly_note_on(uint8_t ch, uint8_t note, uint8_t extra) noexcept;  // extra: doublers wanted
  // One voice of a kPoly note: for zone `layer` (kNone: no zones) on the motors in `allowed`.
  void poly_place(uint8_t ch, uint8_t note, uint8_t extra, uint8_t layer, uint32_t allowed) noexcept;
  size_t poly_victim(uint8_t note, uint32_t allowed) const noexcept;  // kNone when the new note must yield
  // kPoly velocity doubling. Motors m and p sound the same key of the same channel.
  bool same_key(size_t m, size_t p) const noexcept;
  size_t key_motors(size_t p) const noexcept;  // motors sounding p's key, p among them
  // Gives the note on motor p (its own motor) `want` doublers: releases surplus ones, takes
  // free motors in unison for missing ones while there are any.
  void set_doublers(size_t p, uint8_t want, uint32_t allowed) noexcept;
  // No motor free: a motor in `allowed` in unison with another that can play `note`, kNone when none.
  size_t spare_motor(uint8_t note, uint32_t allowed) const noexcept;
  void hand_over(size_t m) noexcept;  // motor m is taken: a doubler of its note becomes its own
  void mono_push(uint8_t ch, uint8_t note) noexcept;
  void mono_remove(uint8_t ch, uint8_t note) noexcept;
  void mono_update(uint8_t ch) noexcept;  // points the channel's group at its current note
  // The note motor m plays for a key (transpose, folding, mutes) and how many octaves it had
  // to move; false when every octave of it inside the range is muted.
  bool resolve(size_t m, uint8_t note, uint8_t *played, int *octaves) const noexcept;
  void release(size_t m) noexcept;
  void retune(size_t m) noexcept;              // recomputes period_[m] from voices_[m]
  void retune_channel(uint8_t ch) noexcept;

  uint32_t muted_mask() const noexcept { return config_.muted_motors | stage_mutes_; }

  AllocatorConfig config_;
  int stage_transpose_ = 0;
  uint32_t stage_mutes_ = 0;
  std::array<Voice, kMaxMotors> voices_{};
  std::array<uint32_t, kMaxMotors> period_{};    // what each motor should play now
  std::array<uint32_t, kMaxMotors> reported_{};  // what flush() last reported
  std::array<uint8_t, kMaxMotors> owner_{};      // kMono/kChannel: channel of the group, kNone
  std::array<Channel, 16> channels_{};
  uint64_t sequence_ = 0;
  uint64_t now_us_ = 0;  // the time of the event or tick being applied (vibrato's clock)
  std::array<Glide, kMaxMotors> glide_{};          // each motor's slide into its note
  std::array<double, kMaxMotors> last_pitch_{};    // the note (semitones) each motor played last
  std::array<uint64_t, kMaxMotors> silent_us_{};   // when it fell silent (0: it sounds or never did)
  void start_glide(size_t m, uint8_t ch, bool always) noexcept;  // from last_pitch_[m], if the channel glides
  uint8_t vibrato_amount(uint8_t ch) const noexcept;  // the controller that sets its depth
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_ALLOCATOR_H
