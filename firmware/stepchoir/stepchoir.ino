// stepchoir.ino: stepper-motor instrument firmware. setup() and loop() only; see README.md.
// Board: Arduino Uno + CNC Shield V3 or Arduino Mega 2560 + RAMPS 1.4, picked by the MCU.
#include "commands.h"
#include "link.h"
#include "scheduler.h"
#include "step_driver.h"

static cmd::Commands g_commands;

void setup() {
  TIMSK0 = 0;  // no millis() tick: its ISR would delay step edges; board time is Timer1's
  drivers::begin();
  link::begin();
  g_commands.init();
}

// Main loop: drain the UART into the frame decoder, start due timestamped notes, watchdog.
// The UART is drained again between the other pieces, and while a frame is coming in the
// other pieces wait (cfg::kDeferPasses, cfg::kDeferBytes), so a frame's last byte is handled
// at once rather than after the rest of a pass.
void loop() {
  sched::main_loop_alive();
  static uint8_t deferred_passes = 0, deferred_bytes = 0;
  uint8_t bytes[32];
  const uint8_t n = link::read_some(bytes, sizeof bytes);
  g_commands.on_bytes(bytes, n);
  deferred_bytes = (uint8_t)(deferred_bytes + n);  // n <= 32: no wrap below kDeferBytes + 32
  if (g_commands.in_frame() && deferred_passes < cfg::kDeferPasses && deferred_bytes < cfg::kDeferBytes) {
    ++deferred_passes;
    return;
  }
  deferred_passes = 0;
  deferred_bytes = 0;
  g_commands.poll();
  g_commands.on_bytes(bytes, link::read_some(bytes, sizeof bytes));
  sched::rescue_missed_compare();
}
