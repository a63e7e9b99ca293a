// motion.h: moves on one board (kMsgMove) and what the host builds from them: a jog by a
// distance, and homing a carriage to the middle of its rail (the seed's StepDriver motion:
// acceleration, minimum and maximum speed, steps per mm or per turn).
//
// Called from: the one-board commands (`stepchoir home`, `jog`, `center`) and, with
// home_on_start, live, play and jam before the first note. Blocks on the board's replies and
// sends heartbeats meanwhile (the board's watchdog stops a move 300 ms after the last frame,
// so a host that dies leaves no motor running). Not for the real-time path.
#ifndef STEPCHOIR_HOST_BOARD_MOTION_H
#define STEPCHOIR_HOST_BOARD_MOTION_H

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "board/board.h"

namespace stepchoir {

// One motor's motion settings (the rig file's [[boards.motors]] keys of the same names).
struct MotionSettings {
  double steps_per_mm = 80.0;      // 200 full steps x 16 microsteps / 40 mm a turn (GT2, 20 teeth)
  double steps_per_turn = 3200.0;  // 200 full steps x 16 microsteps
  double acceleration = 500.0;     // mm/s^2
  double min_speed = 5.0;          // mm/s: a move's first and last steps
  double max_speed = 40.0;         // mm/s
  double home_speed = 20.0;        // mm/s: toward a switch
  double backoff_mm = 2.0;         // off a switch once it fired
};

// A distance of `steps` in mm with one decimal ("12.5 mm"), for messages.
std::string mm_text(double steps, const MotionSettings &ms);

// How a move ended.
struct MoveResult {
  uint8_t end = sc::kMoveEndSteps;  // sc::MoveEnd
  int32_t position = 0;             // the board's counted position after it, steps
  uint32_t steps = 0;               // steps taken
};

// One motor's move: `steps` (the sign gives the direction: up counts the position up) at most,
// on the ramp from min_speed to `speed` (mm/s) with `ms`'s acceleration; toward a switch, it
// ends where the switch ahead fires.
struct MoveOrder {
  uint8_t motor = 0;
  int64_t steps = 0;
  double speed = 0;
  MotionSettings ms;
  bool to_switch = false;
};

// Starts every order's move at once (one motor each) and waits until all have ended; their
// results in the orders' order (a zero-step order: a default result). Throws std::runtime_error
// naming the port and the motors when the board refuses a move, stops one (stop-all, the
// watchdog) or one does not end in time; a motor still moving then is stopped with stop-all.
std::vector<MoveResult> move_motors(Board &board, const std::string &port, const std::vector<MoveOrder> &orders);

// One motor's move (move_motors with one order).
MoveResult move_motor(Board &board, const std::string &port, uint8_t motor, int64_t steps, double speed,
                      const MotionSettings &ms, bool to_switch);

// What homing found.
struct HomeResult {
  int32_t travel_steps = 0;  // between the two switches as measured, or the configured travel
  bool measured = false;     // both ends have switches: travel_steps was measured
  int32_t middle = 0;        // where the carriage stopped (its position from now on), steps
  std::string failure;       // not empty: a switch did not fire, the motor stopped; what to check
};

// A motor to home, with its configured travel (steps) and motion settings.
struct HomeJob {
  uint8_t motor = 0;
  uint32_t travel_steps = 0;
  MotionSettings ms;
};

// Homes the jobs' motors, all at once, on a board whose capabilities say they have switches
// (caps.endstops). Each runs to one switch at home_speed, backs off, touches it again at a
// quarter of that speed and counts from it (0 at the min end, travel at the max end); where
// both ends have switches (one input for both counts), runs to the other and measures the
// travel; then moves to the middle. The motors take each of these stages together, and the
// next once every one has ended it. A switch that does not fire within the travel and a
// quarter stops that motor where its search ends, and it takes no further stage (its result's
// failure says which switch and what to check); the others go on. A motor without switches
// throws before any moves, pointing at jog and center; so does a move the board refuses or
// stops (move_motors). `say` gets a line for each motor's stages. Results in the jobs' order.
std::vector<HomeResult> home_motors(Board &board, const Caps &caps, const std::string &port,
                                    const std::vector<HomeJob> &jobs, const std::function<void(const std::string &)> &say);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_BOARD_MOTION_H
