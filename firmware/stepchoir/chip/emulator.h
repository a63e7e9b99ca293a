// emulator.h: workarounds for the virtual board's AVR emulator (simavr 1.6), each beside what
// a real chip needs. Used by the timer channels (channel.h); `ctest -R vboard_timer_quirks`
// and `vboard_compare_lead` measure each quirk on the emulator itself.
//
// 1. Writing any bit of a TIFR register clears every flag of that timer (simavr ignores the
//    value written), so the firmware never clears a flag by writing TIFR: a match of an old
//    compare value still waiting is let in while the channel's busy bit is set and returns at
//    once. A real chip clears only the bits written; the rule costs it nothing.
// 2. Writing an OCR register makes the emulator reschedule the timer's compares, and a sibling
//    compare due in that instruction is lost. settle*() first waits (kSettleTicks at most)
//    until a sibling compare due that soon has set its flag. A real chip loses none; the wait
//    costs it a few cycles.
// 3. The emulator schedules a wrap's Timer1 (and Timer3) compares when it processes the
//    overflow, after the instruction the overflow fell in (up to 5 cycles), and drops a
//    compare due before that: at OCRnx 0 or 1 a match is lost in some wraps and its edge comes
//    a wrap (4.1 ms) late. No OCRnx is set below kOcr1Min: such an edge rises at most kOcr1Min
//    cycles late (0.25 us, one edge in 16,000), its deadline kept. A real chip needs no floor.
//    Timer2's compares come at least one tick (8 cycles) after its overflow, past any
//    instruction.
// 4. A waiting interrupt is taken two instructions after sei (a real AVR takes it after one):
//    a "let one in" window is sei; nop; nop; nop; cli.
#ifndef STEPCHOIR_CHIP_EMULATOR_H
#define STEPCHOIR_CHIP_EMULATOR_H

#include <stdint.h>

namespace sched {
namespace emu {

const uint8_t kSettleTicks = 32;

// Waits while the compare in `ocr` of the same timer is due within kSettleTicks and has not yet
// set its flag (`flag` in `tifr`). Interrupts off.
__attribute__((always_inline)) inline void settle16(volatile uint16_t &ocr, volatile uint16_t &tcnt, volatile uint8_t &tifr, uint8_t flag) {
  while (!(tifr & flag) && (uint16_t)(ocr + 1 - tcnt) < kSettleTicks) {
  }
}
__attribute__((always_inline)) inline void settle8(volatile uint8_t &ocr, volatile uint8_t &tcnt, volatile uint8_t &tifr, uint8_t flag) {
  while (!(tifr & flag) && (uint8_t)(ocr + 1 - tcnt) < (kSettleTicks >> 3)) {
  }
}

const uint16_t kOcr1Min = 4;
// A 16-bit compare value, held to kOcr1Min.
__attribute__((always_inline)) inline uint16_t ocr16(uint16_t v) { return v < kOcr1Min ? kOcr1Min : v; }

}  // namespace emu
}  // namespace sched

#endif  // STEPCHOIR_CHIP_EMULATOR_H
