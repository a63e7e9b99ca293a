// config.h: firmware options, each with its unit and range, checked at compile time.
#ifndef STEPCHOIR_CONFIG_H
#define STEPCHOIR_CONFIG_H

#include <stdint.h>

#include "src/stepchoir_protocol.h"

namespace cfg {

// Silence every motor and disable the drivers when no frame arrived for this long (ms): the
// protocol's default (sc::kWatchdogDefaultMs). The host sends heartbeats well inside it.
static const uint16_t kWatchdogDefaultMs = sc::kWatchdogDefaultMs;

// Timestamped set-period entries the board can hold (kMsgAt). Each costs 9 bytes of RAM.
// Range 4-64; the Uno has 2 KB of RAM in all.
static const uint8_t kQueueSize = 24;

// While a frame is coming in, the main loop takes its bytes as they arrive and defers its other
// work (poll(): late replies, the watchdog) for at most this many passes in a row and this
// many bytes taken since it last ran: about 2,000 cycles (125 us) at the worst, so the frame
// is handled right after its last byte.
static const uint8_t kDeferPasses = 8;
static const uint8_t kDeferBytes = 16;

// The step ISR takes a timestamped entry from the queue this long before its time (ticks),
// whatever the main loop is busy with. Longer than kWakeTicks, the longest the ISR sleeps,
// plus kTakeUrgentTicks: an idle ISR finds every entry before it is urgent. Handed over by
// the main loop instead, entries came late when every motor sounded high and the ISR left it
// few cycles: 100-400 us late in a black-MIDI song (`test_e2e "play: a black-MIDI*"`), 20 of
// 160 with four top notes even with a 2 ms lead (`test_e2e "at: entries keep*"`, then at MIDI
// 105-108).
static const uint16_t kTakeTicks = 48000;
// Within this long of its time (ticks), an entry is taken before any edge, however busy the
// step ISR is (taking it costs about 400 cycles; the edge waits that long at most).
static const uint16_t kTakeUrgentTicks = 8000;

// While a frame is coming in, the main loop waits this long (ticks) for its next byte before
// it goes round its loop: three byte times at 1,000,000 baud.
static const uint16_t kByteWaitTicks = 480;

// UART receive ring (bytes, power of two). At 1,000,000 baud a byte arrives every 10 us; the
// main loop drains the ring between its other work. 128 bytes = 1.28 ms of line time.
static const uint8_t kRxRingBytes = 128;
// UART transmit ring (bytes, power of two); replies are rare and at most one frame each.
static const uint8_t kTxRingBytes = 128;

// A motor due within this long after the previous edge is played in the same burst (ticks =
// CPU cycles): going back through the ISR loop and into a new burst takes about this long, so
// it would be late otherwise (traced with the planned burst: the last pulse, the loop and the
// plan 400-600 cycles, and up to 330 more in UART ISRs while a reply goes out: with 700 an
// edge due just over 700 ticks after another came 16 us late). A burst spans at most kBurstSpanTicks
// from its first edge: with kRescheduleTicks that fits in the shortest period (checked in
// scheduler.cpp), so no motor's next step comes before its bookkeeping.
static const uint16_t kComebackTicks = 1000;
static const uint16_t kBurstSpanTicks = 2800;

// A played motor's next deadline and place in the order are worked out within this long after
// a burst (ticks): the step ISR's bookkeeping of one step, stretched by nested UART ISRs.
static const uint16_t kRescheduleTicks = 400;

// The step ISR turns interrupts off this long before an edge and busy-waits for it, so the
// raise is on the exact tick whatever ran before. Longer than the longest other ISR (the
// UART receive ISR: 67 cycles measured) plus a pass of the wait loop that lowers pulses (about
// 30): with 64, an edge whose wait a UART ISR entered late came about 30 cycles late (traced).
static const uint8_t kCliLeadTicks = 112;

// Within a burst, interrupts stay off across raises closer together than kCliLeadTicks, from
// the first to the last at most this long (ticks); a longer run lets waiting interrupts in
// between two raises (its ISR takes up to 54 cycles, so that edge may then be late). With
// kCliLeadTicks before the first: 88 kept them off 247 cycles on the Mega, 72 keeps the step
// ISR's entry and return (236-243) the longest (tools/bench/run-bench.sh, also at full line speed).
static const uint8_t kMaxOffTicks = 72;

// Planned spacing of two STEP writes in a burst (ticks): the raise loop's pass from one write to
// the next (wait for the tick, write the port, note the time, load the next motor): 52 cycles
// between two raises on both boards in the benchmark's traces (59 before the wait, write and
// store went to assembly). Edges due closer together share the difference (see burst() in
// scheduler.cpp): two due on the same tick are each about 26 cycles (1.6 us) off, plus the
// wait's 8-cycle step. Same-port edges are not merged into one write: folding them in made
// the pass 94 cycles.
static const uint8_t kWriteGapTicks = 52;

// Two raises of a burst less than this far apart (ticks) but too far to keep interrupts off
// between them stay in one run: after the first, waiting interrupts are let in (a UART ISR
// takes up to ~60 cycles), then they are off again until the second. Going back to a wait with
// interrupts on between them takes about 135 cycles (traced), so a second raise 112-150 ticks
// after the first came late; the window with interrupts off after the breath stays under this.
static const uint8_t kBreatherTicks = 200;

// The compare unit fires this long before a deadline: time for the ISR's prologue, its loop and
// the burst's plan, stretched by nested UART ISRs, before kCliLeadTicks. 62.5 us: with 600 and
// 750 the planned burst came late while a frame arrived (traced: 850 cycles from the compare
// to the raise, 300 of them in six receive ISRs); 750 gave a worst edge of 4.8-130 us (Uno)
// and 13-18 us (Mega) in three bench runs a board, 1000 4-19 us (one Mega run 100 us) at the
// same stage; 1000 costs the step ISR 4 % more CPU (36 -> 40 % on the Uno), waiting.
static const uint16_t kEarlyTicks = 1000;

// An edge due within this long is waited for rather than starting a command from the main loop:
// the longest (~350 cycles) stretched by the UART's ISR nesting at full speed, plus
// kCliLeadTicks. Must exceed kEarlyTicks + kMinLeadTicks.
static const uint16_t kSoonTicks = 1600;

// A live command waits for edges due within kSoonTicks only this long into a step ISR
// invocation (ticks): with every motor near the top of its range an edge is always that close,
// and it waited until the overload guard, 1 ms or more. Past it the command is carried out at
// once; the next edge may come up to its ~350 cycles late. (Queue entries do not: forced the
// same way, they made the bench's worst-note p99 9-35 us; they have kTakeUrgentTicks.)
static const uint16_t kCmdWaitTicks = 4000;

// An edge due within this long is waited for rather than starting a played motor's bookkeeping
// (ticks): bookkeep_one (about 300 cycles) and the ISR's loop back into a burst (about 250),
// stretched by nested UART ISRs, plus kCliLeadTicks. 1200 kept every Uno edge of the pitch
// benchmark within 1.8 us, but left the Mega's five motors no gap for it (edges 45-107 us
// late); so did 1200 with less room when a played motor's own edge was near (800).
static const uint16_t kBookkeepTicks = 1000;
// ... while bytes come in (the receive ring's head moved during this step ISR invocation, or
// the ring is full: link::rx_full); the receive ISR stretches it (the transmit ISR is held off
// while the step ISR runs) (traced: 450-500 of 1,500 cycles in UART ISRs, the next edge over 5 us late).
// Always this long, bookkeeping starved (three motors whose edges came 1,600 ticks apart in
// turn left a fourth's no room: one edge 36 us late).
static const uint16_t kBookkeepBusyTicks = 1400;

// How far ahead, at the least, the step ISR arms its compare (ticks). arm() reads the time,
// works out the target (about 70 cycles from the timer read to the clear on the Uno, by its
// disassembly) and clears OCF1A after writing OCR1A, to drop a match of the previous value: a
// compare due before that clear is erased, and comes a timer wrap (4 ms) later unless the main
// loop's rescue (kRescueTicks) catches it. Measured with this firmware: with 48 here compares
// were lost; with 100, notes started on a silent motor without a miss, but with motors playing
// edges slipped (`test_e2e "link: * decodes every frame*"`: residual p99 104-136 us against 25,
// about kRescueTicks); 200 is reliable. The virtual board itself fires a compare armed 16 ticks
// or more ahead by a write-then-clear sequence every time, on its tick (`ctest -R
// vboard_compare_lead`, 2026-12-01): a lead has to cover the firmware's own sequence, not a
// simavr defect (which of the firmware's paths lost the compares at 100 was not traced).
static const uint8_t kMinLeadTicks = 200;

// How soon after the main loop posts a command the step ISR comes for it (ticks), when it is
// not already due sooner: the compare is armed this far ahead.
static const uint8_t kPostLeadTicks = 100;

// A motor that starts from silence plays its first edge this long after the step ISR took
// its command (ticks): the ISR is running then, so this only has to cover its own loop into
// the burst. 300 (was 600): a note's onset 8-10 us sooner (`test_e2e "link: a note starts*"`).
static const uint16_t kStartLeadTicks = 300;

// Overload guard (ticks): kMaxInvocationTicks into a step ISR invocation (or when it has
// starved the main loop, see the ISR), the ISR plays only edges already due, and returns once
// its bookkeeping is done, leaving the main loop kMainSliceTicks to decode frames (stop-all,
// the watchdog). Edges are late then by up to a slice, never lost. 16,000 (1 ms) made one edge
// 15-20 us late in each run of the pitch benchmark (the same edge): four timestamped entries taken
// between the edges of a 4 kHz note kept one invocation going 1.15 ms (it waits 1,000 ticks
// for each edge). kMaxIsrTicks sets the starvation window (8 times it).
static const uint16_t kMaxIsrTicks = 16000;
static const uint16_t kMaxInvocationTicks = 32000;
static const uint16_t kMainSliceTicks = 1600;

// The main loop re-arms a compare this long overdue (ticks): while the main loop runs, the step
// ISR is held up at most by its critical sections (a few hundred ticks), so 125 us past the
// armed time means the compare was missed.
static const uint16_t kRescueTicks = 2000;

// The step ISR wakes at least this often (ticks) to extend the 16-bit timer to 32 bits.
static const uint16_t kWakeTicks = 32768;

// An endstop that fired stays ignored until it has read "released" at every step for this long
// (ticks): switch chatter after a reversal gives no second reversal. 20 ms.
static const uint32_t kRearmTicks = 320000ul;

// A switch still pressed after this many steps away from it is stuck: the motor ignores it,
// reports kErrEndstopStuck and keeps to its soft limits.
static const uint16_t kStuckSteps = 400;

// With a switch wired, soft limits sit this many steps beyond the configured travel, as a
// backstop if the switch fails.
static const uint8_t kSoftMarginSteps = 8;

// Default STEP pulse (us) per driver type; a kMsgConfig frame may set 2-10 us.
static const uint8_t kPulseUsA4988 = 2;
static const uint8_t kPulseUsDrv8825 = 2;
static const uint8_t kPulseUsTb6600 = 5;
static const uint8_t kPulseUsMin = 2;
static const uint8_t kPulseUsMax = 10;

// Default travel (steps) before soft limits reverse the motor, until the host configures it.
static const uint32_t kDefaultTravelSteps = 3200;

static_assert(kTakeTicks > kWakeTicks + kTakeUrgentTicks, "the step ISR finds every entry before it is urgent");
static_assert(kQueueSize >= 4 && kQueueSize <= 64, "kQueueSize: 4-64");
static_assert((kRxRingBytes & (kRxRingBytes - 1)) == 0, "kRxRingBytes: power of two");
static_assert((kTxRingBytes & (kTxRingBytes - 1)) == 0, "kTxRingBytes: power of two");
static_assert(kCliLeadTicks + kPulseUsMax * 16u <= 320u, "lead + longest pulse: at most 20 us with interrupts off");
static_assert(kSoonTicks > kEarlyTicks + kMinLeadTicks, "an armed edge is never already soon");
static_assert(kWakeTicks <= 32768u, "kWakeTicks: the 16-bit timer extension needs <= 32768");
static_assert(kStartLeadTicks > kCliLeadTicks, "start lead covers the wait before an edge");

}  // namespace cfg

#endif  // STEPCHOIR_CONFIG_H
