// stub.h: the entry stub of motor m's compare interrupt, in assembly (SC_STEP_ENTRY), and the
// two C entry points it jumps to. Expanded once a motor by scheduler.cpp (SC_MOTOR_VECTORS),
// after the handlers (sched::serve<m>) it jumps to. AVR only.
#ifndef STEPCHOIR_CHIP_STUB_H
#define STEPCHOIR_CHIP_STUB_H

#include <avr/interrupt.h>
#include <avr/io.h>

#include "chip/channel.h"
#include "chip/step_pin.h"

// Channel ISRs. Who: motor m's compare match. The stub returns at once while the motor's busy
// bit is set. With bit m of GPIOR0 clear it raises STEP (13 cycles after the match), sets the
// busy bit and jumps to the motor's handler, which turns interrupts back on as its first
// instruction (interrupts off 19 cycles in all, by the instruction count). With it set, the match comes before the
// edge's: the stub counts it off g_wraps (interrupts off 29 cycles, 37 at the last, by the
// instruction count) and clears the bit at the last, or enters the handler (kWrapsVisit).
#define SC_STEP_ENTRY(M, VECT)                                                                          \
  extern "C" void __vector_sc_edge##M(void) __attribute__((interrupt, used, externally_visible));        \
  extern "C" void __vector_sc_visit##M(void) __attribute__((interrupt, used, externally_visible));       \
  extern "C" void __vector_sc_edge##M(void) { sched::serve<M>(true); }                                 \
  extern "C" void __vector_sc_visit##M(void) { sched::serve<M>(false); }                               \
  ISR(VECT, ISR_NAKED) {                                                                               \
    __asm__ __volatile__("sbic %[bio], %[bb]\n\t"                                                      \
                         "reti\n\t"                                                                   \
                         "sbic %[gp], %[m]\n\t"                                                        \
                         "rjmp 2f\n\t" SC_STEP_RAISE_ASM                                                 \
                         "sbi %[bio], %[bb]\n\t"                                                       \
                         "jmp %x[edge]\n\t"                                                            \
                         "2:\n\t"                                                                   \
                         "push r24\n\t"                                                             \
                         "in r24, __SREG__\n\t"                                                     \
                         "push r24\n\t"                                                             \
                         "lds r24, %[wraps]\n\t"                                                    \
                         "sbrc r24, 7\n\t"                                                          \
                         "rjmp 4f\n\t"                                                              \
                         "dec r24\n\t"                                                              \
                         "sts %[wraps], r24\n\t"                                                    \
                         "brne 3f\n\t"                                                              \
                         "lds r24, %[then]\n\t"                                                     \
                         "sts %[wraps], r24\n\t"                                                    \
                         "sbrs r24, 7\n\t"                                                          \
                         "cbi %[gp], %[m]\n\t"                                                      \
                         "3:\n\t"                                                                   \
                         "pop r24\n\t"                                                              \
                         "ori r24, 0x80\n\t"                                                        \
                         "out __SREG__, r24\n\t"                                                    \
                         "pop r24\n\t"                                                              \
                         "reti\n\t"                                                                 \
                         "4:\n\t"                                                                   \
                         "pop r24\n\t"                                                              \
                         "out __SREG__, r24\n\t"                                                    \
                         "pop r24\n\t"                                                              \
                         "sbi %[bio], %[bb]\n\t"                                                    \
                         "jmp %x[visit]\n\t" ::[gp] "I"(_SFR_IO_ADDR(GPIOR0)),                          \
                         [m] "I"(M), [bio] "I"(SC_BUSY_IO(M)), [bb] "I"(SC_BUSY_BIT(M)),                   \
                         [wraps] "i"(&sched::g_wraps[M]), [then] "i"(&sched::g_wraps_then[M]), [visit] "i"(__vector_sc_visit##M), \
                         [edge] "i"(__vector_sc_edge##M), SC_STEP_RAISE_OPERANDS(M));                                                \
  }

#endif  // STEPCHOIR_CHIP_STUB_H
