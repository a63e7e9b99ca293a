// moves.cpp: see moves.h.
#include "moves.h"

#include "boards/board.h"
#include "move_ramp.h"
#include "scheduler.h"
#include "step_driver.h"

namespace moves {
namespace {

const uint8_t kMotors = board::active::kMotorCount;

struct Move {
  ramp::Ramp ramp;
  uint32_t steps;        // the most the move takes
  uint32_t left;         // steps still to take when its speed was last set
};
Move g_move[kMotors];
uint8_t g_moving;  // bit m: motor m's move started and its end is not yet reported

}  // namespace

void start(const sc::MoveBody &b) {
  Move &mv = g_move[b.motor];
  mv.ramp = ramp::make(b.speed_min, b.speed_max, b.accel);
  mv.steps = b.steps;
  mv.left = b.steps;
  // A driver powered down steps from its ready time on.
  uint32_t at = sched::now();
  if (drivers::maybe_unready(b.motor)) drivers::ready_time(b.motor, &at);
  sched::start_move(b.motor, b.flags & sc::kMoveUp, b.steps, b.flags & sc::kMoveToSwitch,
                    ramp::period_q8(b.speed_min, F_CPU), at);
  g_moving |= (uint8_t)(1u << b.motor);
}

void poll() {
  if (!g_moving) return;
  for (uint8_t m = 0; m < kMotors; ++m) {
    if (!(g_moving & (1u << m))) continue;
    Move &mv = g_move[m];
    uint32_t left;
    uint8_t end;
    if (!sched::move_state(m, &left, &end) || left == mv.left) continue;
    mv.left = left;
    const uint32_t done = mv.steps - left;
    sched::retune_move(m, ramp::period_q8(ramp::speed(mv.ramp, done, left), F_CPU));
  }
}

uint8_t moving() { return g_moving; }

bool ended(sc::MoveDoneBody *out) {
  for (uint8_t m = 0; m < kMotors; ++m) {
    if (!(g_moving & (1u << m))) continue;
    uint32_t left;
    uint8_t end;
    if (sched::move_state(m, &left, &end)) continue;
    sc::StatusMotor s;
    sched::motor_status(m, &s);
    out->motor = m;
    out->end = end;
    out->position = s.position_steps;
    out->steps = g_move[m].steps - left;
    g_moving &= (uint8_t)~(1u << m);
    return true;
  }
  return false;
}

}  // namespace moves
