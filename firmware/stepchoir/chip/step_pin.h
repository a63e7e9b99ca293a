// step_pin.h: motor m's STEP pin as the step ISRs write it, derived from the board table
// (boards/<board>.h) alone: the stubs' raise and the handlers' lower take its port address and
// bit from here, so a wrong port or bit cannot compile. AVR only.
#ifndef STEPCHOIR_CHIP_STEP_PIN_H
#define STEPCHOIR_CHIP_STEP_PIN_H

#include <avr/io.h>
#include <stdint.h>
#include <util/atomic.h>

#include "boards/board.h"

namespace sched {

// Data-space address of PORTx for a port letter (PINx is two below it), per chip family;
// each checked against avr-libc's own definition below.
constexpr uint16_t port_addr(char p) {
#if defined(__AVR_ATmega2560__)
  return p == 'A' ? 0x22 : p == 'B' ? 0x25 : p == 'C' ? 0x28 : p == 'D' ? 0x2B : p == 'E' ? 0x2E
         : p == 'F' ? 0x31 : p == 'G' ? 0x34 : p == 'H' ? 0x102 : p == 'J' ? 0x105 : p == 'K' ? 0x108
         : p == 'L' ? 0x10B : 0;
#else
  return p == 'B' ? 0x25 : p == 'C' ? 0x28 : p == 'D' ? 0x2B : 0;
#endif
}
#if defined(__AVR_ATmega2560__)
static_assert(port_addr('A') == _SFR_MEM_ADDR(PORTA) && port_addr('F') == _SFR_MEM_ADDR(PORTF) &&
                  port_addr('G') == _SFR_MEM_ADDR(PORTG) && port_addr('H') == _SFR_MEM_ADDR(PORTH) &&
                  port_addr('J') == _SFR_MEM_ADDR(PORTJ) && port_addr('K') == _SFR_MEM_ADDR(PORTK) &&
                  port_addr('L') == _SFR_MEM_ADDR(PORTL) && port_addr('E') == _SFR_MEM_ADDR(PORTE),
              "port_addr: the ATmega2560's ports");
#endif
static_assert(port_addr('B') == _SFR_MEM_ADDR(PORTB) && port_addr('C') == _SFR_MEM_ADDR(PORTC) &&
                  port_addr('D') == _SFR_MEM_ADDR(PORTD),
              "port_addr: ports B, C, D");

// Motor M's STEP pin. kIoSpace: its port is in the I/O space (sbi/cbi, atomic); otherwise
// (the Mega's Z on PORTL) the stub raises it by writing its bit to PINx (a write of 1 toggles
// the port bit; STEP is low before every raise), and lower() runs with interrupts off.
template <uint8_t M> struct StepPin {
  static constexpr board::Pin kPin = board::active::kMotors[M].step;
  static constexpr uint16_t kPort = port_addr(kPin.port);
  static constexpr uint16_t kPinReg = kPort - 2;
  static constexpr uint8_t kBit = kPin.bit;
  static constexpr uint8_t kMask = (uint8_t)(1u << kPin.bit);
  static constexpr bool kIoSpace = kPort < 0x40;
  static constexpr uint8_t kIo = kIoSpace ? (uint8_t)(kPort - 0x20) : 0;
  static_assert(kPort != 0, "STEP pin: a port this chip has");

  static inline void raise() {
    if (kIoSpace) {
      _SFR_MEM8(kPort) |= kMask;
    } else {
      ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { _SFR_MEM8(kPort) |= kMask; }
    }
  }
  static inline void lower() {
    if (kIoSpace) {
      _SFR_MEM8(kPort) &= (uint8_t)~kMask;
    } else {
      ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { _SFR_MEM8(kPort) &= (uint8_t)~kMask; }
    }
  }
};

// The stub's raise of motor M's STEP, as assembly (inline-asm operands of SC_STEP_ENTRY):
// sbi on an I/O-space port, else a PINx write through r24 (saved; no SREG change).
#define SC_STEP_RAISE_ASM                          \
  ".if %[s_io_space]\n\t"                          \
  "sbi %[s_io], %[s_bit]\n\t"                      \
  ".else\n\t"                                      \
  "push r24\n\t"                                   \
  "ldi r24, %[s_mask]\n\t"                         \
  "sts %[s_pin], r24\n\t"                          \
  "pop r24\n\t"                                    \
  ".endif\n\t"
#define SC_STEP_RAISE_OPERANDS(M)                                                              \
  [s_io_space] "n"(sched::StepPin<M>::kIoSpace ? 1 : 0), [s_io] "n"(sched::StepPin<M>::kIo),   \
      [s_bit] "n"(sched::StepPin<M>::kBit), [s_mask] "n"(sched::StepPin<M>::kMask),            \
      [s_pin] "n"(sched::StepPin<M>::kPinReg)

}  // namespace sched

#endif  // STEPCHOIR_CHIP_STEP_PIN_H
