// stepchoir.ino: stepper-motor instrument firmware. setup() and loop() only; see README.md.
// Board: Arduino Uno + CNC Shield V3 or Arduino Mega 2560 + RAMPS 1.4, picked by the MCU.
#include "commands.h"
#include "link.h"
#include "moves.h"
#include "scheduler.h"
#include "step_driver.h"

static cmd::Commands g_commands;

// Called from: loop(). Decodes the bytes received so far, and the rest of a frame once one has
// begun, each byte as it arrives (the wait for one: at most cfg::kByteWaitTicks). Returns how
// many it took: from 64 on it stops between frames, and at 128 in any case (a stream of bytes
// with no delimiter is one endless frame; the watchdog must still run). Between frames, once
// cfg::kPollBytes bytes came since it last looked, it takes the timed entries that are due
// (sched::poll: about 40 cycles when none is): under a full line and busy ISRs a pass of the
// loop can outlast cfg::kTakeTicks (2.7 ms measured on the Mega), and an entry taken that late
// misses its time.
static inline uint8_t take_bytes(uint16_t idle_passes) {
  uint8_t n = 0, since_poll = 0, b;
  while (link::wait_byte(&b, g_commands.in_frame() ? link::wait_passes(cfg::kByteWaitTicks) : n == 0 ? idle_passes : 0)) {
    g_commands.on_byte(b);
    link::feed_tx();  // a reply goes out a byte per byte received (or per wait pass)
    if (++n >= 64 && (!g_commands.in_frame() || n == 128)) break;
    if (++since_poll >= cfg::kPollBytes && !g_commands.in_frame()) {
      since_poll = 0;
      sched::poll();
    }
  }
  return n;
}

void setup() {
  TIMSK0 = 0;  // no millis() tick: its ISR would delay step edges; board time is Timer1's
  drivers::begin();
  link::begin();
  g_commands.init();
  g_commands.announce();
}

// Main loop: a moving motor's next speed (moves::poll, once a step), take received bytes into
// the frame decoder, watchdog, late and move-done replies (poll), the drivers' idle power-down
// (drivers::poll), a missed compare. Bytes are taken one by one, and
// once a frame has begun the loop waits for each of its bytes as it arrives (a byte every 160
// cycles; the receive ISR takes about 75 of them for a lone byte, decoding one about 85), so a
// frame's delimiter is handled right after its receive ISR: taken in batches between passes, a
// frame's last four bytes and a pass came first, about 600 cycles (the virtual board's PC
// trace). The other pieces run between frames, or when a frame stalls (a byte later than
// cfg::kByteWaitTicks) for at most cfg::kDeferPasses passes and cfg::kDeferBytes bytes in a
// row.
void loop() {
  sched::poll();
  moves::poll();
  static uint8_t deferred_passes = 0, deferred_bytes = 0;
  const uint8_t n = take_bytes(link::wait_passes(cfg::kIdleWaitTicks));
  deferred_bytes = (uint8_t)(deferred_bytes + n > 255 ? 255 : deferred_bytes + n);
  if (g_commands.in_frame() && deferred_passes < cfg::kDeferPasses && deferred_bytes < cfg::kDeferBytes) {
    ++deferred_passes;
    return;
  }
  deferred_passes = 0;
  deferred_bytes = 0;
  g_commands.poll();
  drivers::poll();
  take_bytes(0);
}
