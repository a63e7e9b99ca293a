// allocator_rig.h: what the allocator's test files share: an Allocator with a mirror of what the
// boards would play, the period formula written out on its own, and the usual configurations.
#ifndef STEPCHOIR_TESTS_ALLOCATOR_RIG_H
#define STEPCHOIR_TESTS_ALLOCATOR_RIG_H

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/midi_event.h"
#include "core/pitch.h"
#include "live/allocator.h"

namespace stepchoir::allocator_test {

// Heap allocations of the test program so far (test_allocator.cpp replaces operator new), so a
// test can show the engine makes none.
extern size_t g_allocations;

constexpr uint32_t kF = 16000000;
// A velocity below the default doubling thresholds (live/velocity.h): one motor a note.
constexpr uint8_t kSoft = 64;

// The period a motor must report for a played note, bend and tuning: the formula of the spec,
// written out independently of the allocator.
inline uint32_t expected_period(int played, double bend = 0.0, double cents = 0.0, double a4 = kA4Hz,
                                uint32_t f_cpu = kF) {
  return hz_to_period_q8(note_hz(played + bend + cents / 100.0, a4), f_cpu);
}

inline AllocatorConfig poly(uint8_t motors, Priority priority = Priority::kOldest) {
  AllocatorConfig c;
  c.motor_count = motors;
  c.policy = Policy::kPoly;
  c.priority = priority;
  return c;
}

// An Allocator plus a mirror of what the boards would play, built only from handle()'s output.
struct Rig {
  explicit Rig(const AllocatorConfig &c) : a(c), board(Allocator::kMaxMotors, 0) {}

  // Sends one event; returns the entries it produced (and applies them to the mirror).
  std::vector<sc::PeriodEntry> send(const MidiEvent &e) {
    std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
    out.resize(a.handle(e, out.data(), out.size()));
    for (const auto &p : out) board[p.motor] = p.period_q8;
    return out;
  }
  std::vector<sc::PeriodEntry> on(uint8_t ch, uint8_t note, uint8_t velocity = kSoft) {
    return send(note_on(ch, note, velocity));
  }
  std::vector<sc::PeriodEntry> off(uint8_t ch, uint8_t note) { return send(note_off(ch, note)); }
  std::vector<sc::PeriodEntry> cc(uint8_t ch, uint8_t n, uint8_t v) { return send(control_change(ch, n, v)); }
  // Sends one event stamped at us (the engine's monotonic_us).
  std::vector<sc::PeriodEntry> at(MidiEvent e, uint64_t us) {
    e.timestamp_us = us;
    return send(e);
  }
  // Moves vibrato and glides on to us, as the engine's tick does; returns the entries (applied
  // to the mirror).
  std::vector<sc::PeriodEntry> tick(uint64_t us) {
    std::vector<sc::PeriodEntry> out(Allocator::kMaxMotors);
    out.resize(a.tick(us, out.data(), out.size()));
    for (const auto &p : out) board[p.motor] = p.period_q8;
    return out;
  }
  std::vector<sc::PeriodEntry> bend(uint8_t ch, uint16_t v) { return send(pitch_bend(ch, v)); }

  // Motors sounding a given key of a channel.
  std::vector<size_t> motors_on(uint8_t ch, uint8_t note) const {
    std::vector<size_t> r;
    for (size_t m = 0; m < a.motor_count(); ++m) {
      const MotorState s = a.motor(m);
      if (s.sounding && s.channel == ch && s.note == note) r.push_back(m);
    }
    return r;
  }
  size_t sounding() const {
    size_t n = 0;
    for (size_t m = 0; m < a.motor_count(); ++m) n += a.motor(m).sounding;
    return n;
  }
  bool all_silent() const {
    for (size_t m = 0; m < Allocator::kMaxMotors; ++m)
      if (board[m] != 0 || (m < a.motor_count() && (a.motor(m).sounding || a.motor(m).period_q8)))
        return false;
    return true;
  }

  Allocator a;
  std::vector<uint32_t> board;
};


// kMono on `motors` motors: motor 0 is channel 0's group, the others belong to nobody.
inline AllocatorConfig mono_on_motor_0(uint8_t motors) {
  AllocatorConfig c;
  c.motor_count = motors;
  c.policy = Policy::kMono;
  c.mono_channel[0] = 0;
  return c;
}

// Motors 0 and 1 are channel 0's group, motor 2 is channel 1's, motor 3 belongs to nobody.
inline AllocatorConfig mono_config() {
  AllocatorConfig c;
  c.motor_count = 4;
  c.policy = Policy::kMono;
  c.mono_channel[0] = 0;
  c.mono_channel[1] = 0;
  c.mono_channel[2] = 1;
  return c;
}

}  // namespace stepchoir::allocator_test

#endif  // STEPCHOIR_TESTS_ALLOCATOR_RIG_H
