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
// The UART is drained again between the other pieces, so a frame's last byte waits for at
// most one piece of the pass, not the whole of it, before its frame is handled.
void loop() {
  uint8_t bytes[32];
  g_commands.on_bytes(bytes, link::read_some(bytes, sizeof bytes));
  g_commands.poll();
  g_commands.on_bytes(bytes, link::read_some(bytes, sizeof bytes));
  sched::rescue_missed_compare();
}
