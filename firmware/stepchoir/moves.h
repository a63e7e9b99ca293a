// moves.h: moves (kMsgMove) on the AVR: starts one on the step path (scheduler.h) with its
// driver awake, keeps its speed on the Torricelli ramp (move_ramp.h) step by step, and hands
// back how each ended for the kMsgMoveDone reply. Everything here runs in the main loop.
#ifndef STEPCHOIR_MOVES_H
#define STEPCHOIR_MOVES_H

#include <stdint.h>

#include "src/stepchoir_protocol.h"

namespace moves {

// Called from: main loop (hal::move; the command layer checked the body, that the motor is
// silent and that no timed entry waits). Wakes the driver and starts the move at speed_min.
void start(const sc::MoveBody &b);

// Called from: main loop, every pass. One load when no motor moves; else, for a motor that
// stepped since the last pass, its speed for the next interval (about 700 cycles a motor).
void poll();

// Bit m: motor m moves (from start until ended() has reported the end).
uint8_t moving();

// Called from: main loop (Commands::poll). A move that ended since the last call: true with
// its reply body (one motor a call).
bool ended(sc::MoveDoneBody *out);

}  // namespace moves

#endif  // STEPCHOIR_MOVES_H
