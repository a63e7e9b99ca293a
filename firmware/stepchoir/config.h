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

// The main loop takes a timestamped entry from the queue this long before its time (ticks),
// so that it starts or strikes its motor exactly on the time: 3 ms. It looks at the queue at
// the start of every pass and, between frames, every kPollBytes bytes it takes: at most about
// a frame (sc::kMaxFrameWire bytes), kPollBytes and the pass's other work apart, under 1 ms.
static const uint16_t kTakeTicks = 48000;
static const uint8_t kPollBytes = 16;

// While a frame is coming in, the main loop waits this long (ticks) for its next byte before
// it goes round its loop: three byte times at 1,000,000 baud.
static const uint16_t kByteWaitTicks = 480;

// With no frame coming in, the main loop waits up to this long (ticks) for a byte before it
// goes round its loop (the wait reads the receive ring only): an idle pass reads the clock
// (for the watchdog and the queue), with interrupts off for a moment, and the motors' edges
// may wait that moment. 100 us: well inside the queue's lead (kTakeTicks) and the watchdog's
// millisecond.
static const uint16_t kIdleWaitTicks = 1600;

// UART receive ring (bytes, power of two). At 1,000,000 baud a byte arrives every 10 us; the
// main loop drains the ring between its other work. 128 bytes = 1.28 ms of line time.
static const uint8_t kRxRingBytes = 128;
// UART transmit ring (bytes, power of two); replies are rare and at most one frame each.
static const uint8_t kTxRingBytes = 128;

// arm() arms a channel for an edge at least this far ahead (ticks; trigger() writes a compare
// kTriggerLeadTicks ahead): its compare register and flag are written, then the
// time left is checked, with interrupts off (about 30 cycles); the
// Uno's Timer2 counts cycles / 8 and may stand a tick off Timer1. Closer, the ISR raises the
// edge itself (late).
static const uint8_t kArmGuardTicks = 64;
// ... and the channel's next match must still be this far ahead when its busy bit is cleared
// (ticks): it then finds the channel free (the Uno's Timer2 may match up to 7 cycles before
// the time its count says).
static const uint8_t kArmFinalTicks = 16;

// A command for a sounding motor brings its channel's ISR (a visit) this soon (ticks), unless
// the channel's next match is due within kTriggerAfterTicks anyway: the visit re-arms the
// channel from the motor's next deadline, which must still be kArmGuardTicks away then. A live
// note on a silent motor plays its first edge this soon (fire). trigger() writes the compare a
// few cycles after reading the channel's timer; the Uno's Timer2 counts cycles / 8; the
// emulator fires a compare written 16 ticks or more ahead on its tick
// (docs/decisions/014-emulator-workarounds.md).
static const uint8_t kTriggerLeadTicks = 48;
static const uint16_t kTriggerAfterTicks = 800;
// ... but no visit is brought when the motor's next edge is due within this long (ticks; 256
// us): that edge's handler takes the command. A visit's handler (the command, then the arming)
// held up by the handlers nested in it took up to about 2,500 cycles at full line speed.
static const uint16_t kVisitMarginTicks = 4096;

// A motor that starts from silence by arm() (a timed entry, a move, a live note its handler
// takes after it fell silent) plays its first edge at the soonest this long after its channel
// is armed, after DIR was set; a sounding motor's retune comes
// at the soonest this long after the command was taken (ticks): more than kArmGuardTicks plus
// the arming.
static const uint16_t kStartLeadTicks = 288;

// The main loop checks the motors' silence for their drivers' idle power-down this often
// (ticks; 1 ms): a driver powers down at most this long after its idle time. Between checks a
// pass costs a clock read and a compare (about 100 cycles, 14 of them with interrupts off).
static const uint16_t kDriverPollTicks = 16000;

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

static_assert(kStartLeadTicks >= kArmGuardTicks + 224, "arm() (about 200 cycles) finds the first edge far enough ahead");
static_assert(kTriggerLeadTicks >= 16 + 16, "a compare brought by trigger() is written 16 ticks ahead of its match at least");
static_assert(kStartLeadTicks >= kPulseUsMax * 16u, "a start armed after DIR waits the set-up time of every supported driver");
static_assert(kPulseUsMax * 16u < 256u, "pulse_ticks fits a byte");
static_assert(kTakeTicks >= 4 * kVisitMarginTicks, "a timed entry is taken well before its motor's edges near its time");
static_assert((uint32_t)sc::kWakeUsMax * (F_CPU / 1000000ul) + kStartLeadTicks <= kTakeTicks,
              "a driver woken when its timed entry is taken is awake by the entry's time");
static_assert(kQueueSize >= 4 && kQueueSize <= 64, "kQueueSize: 4-64");
static_assert((kRxRingBytes & (kRxRingBytes - 1)) == 0, "kRxRingBytes: power of two");
static_assert((kTxRingBytes & (kTxRingBytes - 1)) == 0, "kTxRingBytes: power of two");

}  // namespace cfg

#endif  // STEPCHOIR_CONFIG_H
