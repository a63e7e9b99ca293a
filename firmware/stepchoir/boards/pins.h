// pins.h: how a board table names a pin; shared by the firmware and the virtual board.
//
// A pin is its Arduino number plus the AVR port letter and bit it maps to. The firmware
// drives pins through the port registers (fast, usable in the step ISR); the virtual board
// watches the same port bits in simavr; a host test checks every entry against the Arduino
// core's own variant table. An Arduino number of -1 means "not wired".
//
// Each board table also maps every Arduino pin number to its port and bit (kPinMap, one byte a
// pin, in flash on the AVR): the pins the host names at run time (kMsgDriver: SLEEP, RESET).
#ifndef STEPCHOIR_BOARDS_PINS_H
#define STEPCHOIR_BOARDS_PINS_H

#include <stdint.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define SC_FLASH PROGMEM
#define SC_FLASH_BYTE(p) pgm_read_byte(p)
#else
#define SC_FLASH
#define SC_FLASH_BYTE(p) (*(p))
#endif

// One kPinMap entry: port letter ('A'..'L') and bit (0..7) in a byte.
#define SC_PB(port, bit) (uint8_t)((((port) - 'A') << 3) | (bit))

namespace board {

struct Pin {
  int8_t arduino;  // Arduino pin number, -1 = not wired
  char port;       // 'A'..'L'
  uint8_t bit;     // 0..7
  constexpr bool wired() const { return arduino >= 0; }
};

constexpr Pin kNoPin = {-1, '-', 0};

// Arduino pin `arduino` of a board's pin map (`count` entries, SC_FLASH), or kNoPin when the
// board has no such pin. Called from: the main loop (kMsgDriver), the virtual board's options.
inline Pin pin_from_map(const uint8_t *map, uint8_t count, int8_t arduino) {
  if (arduino < 0 || arduino >= (int)count) return kNoPin;
  const uint8_t v = SC_FLASH_BYTE(map + arduino);
  return Pin{arduino, (char)('A' + (v >> 3)), (uint8_t)(v & 7u)};
}

// Everything one driver socket connects to.
struct MotorPins {
  char axis;         // silk-screen name: 'X', 'Y', 'Z', 'A', '0' (E0), '1' (E1)
  Pin step, dir, enable;
  Pin min_switch, max_switch;  // the same pin in both = one switch for both ends
  Pin m0, m1, m2;              // microstep selects (MS1-MS3 on an A4988)
  Pin reset, sleep;
};

// Wiring rules, checked at compile time by each board table (see static_asserts there).
constexpr bool same_pin(Pin a, Pin b) { return a.wired() && b.wired() && a.port == b.port && a.bit == b.bit; }

constexpr bool pin_differs_from_motor(Pin p, const MotorPins &m, bool allow_shared_enable) {
  return !same_pin(p, m.step) && !same_pin(p, m.dir) &&
         (allow_shared_enable || !same_pin(p, m.enable)) && !same_pin(p, m.min_switch) &&
         !same_pin(p, m.max_switch) && !same_pin(p, m.m0) && !same_pin(p, m.m1) &&
         !same_pin(p, m.m2) && !same_pin(p, m.reset) && !same_pin(p, m.sleep);
}

// A motor's own pins are distinct, except the switch pins (a shared switch) and the enable.
constexpr bool motor_pins_distinct(const MotorPins &m) {
  return !same_pin(m.step, m.dir) && !same_pin(m.step, m.enable) && !same_pin(m.dir, m.enable) &&
         !same_pin(m.step, m.min_switch) && !same_pin(m.step, m.max_switch) &&
         !same_pin(m.dir, m.min_switch) && !same_pin(m.dir, m.max_switch) &&
         m.step.wired() && m.dir.wired();
}

// Motor a's STEP, DIR and switches appear nowhere in motor b (enables may be shared).
constexpr bool motors_disjoint(const MotorPins &a, const MotorPins &b, bool shared_enable) {
  return pin_differs_from_motor(a.step, b, true) && pin_differs_from_motor(a.dir, b, true) &&
         pin_differs_from_motor(a.min_switch, b, true) &&
         pin_differs_from_motor(a.max_switch, b, true) &&
         (shared_enable || !same_pin(a.enable, b.enable));
}

}  // namespace board

#endif  // STEPCHOIR_BOARDS_PINS_H
