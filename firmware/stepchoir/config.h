// config.h: firmware options, each with its unit and range, checked at compile time.
#ifndef STEPCHOIR_CONFIG_H
#define STEPCHOIR_CONFIG_H

#include <stdint.h>

namespace cfg {

// Silence every motor and disable the drivers when no frame arrived for this long (ms).
// The host sends heartbeats well inside it. Range 20-60000; 0 in a kMsgWatchdog frame disables it.
static const uint16_t kWatchdogDefaultMs = 300;

// Timestamped set-period entries the board can hold (kMsgAt). Each costs 9 bytes of RAM.
// Range 4-64; the Uno has 2 KB of RAM in all.
static const uint8_t kQueueSize = 24;

// UART receive ring (bytes, power of two). At 1,000,000 baud a byte arrives every 10 us; the
// main loop drains the ring between its other work. 128 bytes = 1.28 ms of line time.
static const uint8_t kRxRingBytes = 128;
// UART transmit ring (bytes, power of two); replies are rare and at most one frame each.
static const uint8_t kTxRingBytes = 128;

// Edges closer than this after a burst's first edge are played inside the same step ISR, each
// at its own time by busy-waiting (ticks = CPU cycles). Longer keeps more edges exact but keeps
// interrupts off longer: 8 us + the 2 us pulse stays inside the 15 us the UART allows.
static const uint16_t kChainTicks = 128;

// Minimum lead when arming the compare unit (ticks): closer deadlines are busy-waited instead,
// since the compare match could pass before OCR1A is written.
static const uint8_t kMinLeadTicks = 48;

// A motor that starts from silence plays its first edge this long after the command (ticks):
// long enough to insert it in the sorted order and arm the timer before it is due. 15 us.
static const uint8_t kStartLeadTicks = 240;

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

static_assert(kQueueSize >= 4 && kQueueSize <= 64, "kQueueSize: 4-64");
static_assert((kRxRingBytes & (kRxRingBytes - 1)) == 0, "kRxRingBytes: power of two");
static_assert((kTxRingBytes & (kTxRingBytes - 1)) == 0, "kTxRingBytes: power of two");
static_assert(kChainTicks + kPulseUsMax * 16u <= 320u, "chain wait + longest pulse: at most 20 us with interrupts off");
static_assert(kWakeTicks <= 32768u, "kWakeTicks: the 16-bit timer extension needs <= 32768");
static_assert(kStartLeadTicks > kMinLeadTicks, "start lead must exceed the arming lead");

}  // namespace cfg

#endif  // STEPCHOIR_CONFIG_H
