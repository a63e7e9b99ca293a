// virtual_board.h: what is wired to the MCU: drivers, carriages, end switches (pure logic).
#ifndef STEPCHOIR_VBOARD_VIRTUAL_BOARD_H
#define STEPCHOIR_VBOARD_VIRTUAL_BOARD_H

#include <cstdint>
#include <string>
#include <vector>

#include "board_config.h"
#include "carriage.h"
#include "endstop_switch.h"
#include "trace_writer.h"

namespace vboard {

// What the model needs from the simulator: drive a switch input pin, and be called back later.
class SwitchPinDriver {
 public:
  virtual ~SwitchPinDriver() = default;
  // Sets the level of switch input switch_index now.
  virtual void drive_switch_pin(size_t switch_index, bool level) = 0;
  // Asks for VirtualBoard::on_wakeup at (or just after) cycle.
  virtual void wake_at(uint64_t cycle) = 0;
};

// Model parameters from the command line.
struct ModelSettings {
  int64_t travel_steps = 3200;
  int64_t start_position_steps = 1600;
  bool switch_active_low = true;
  uint64_t chatter_cycles = 0;
  int stuck_switch_motor = -1;  // the switches serving this motor read pressed all the time
  int dead_switch_motor = -1;   // the switches serving this motor never read pressed
  uint64_t seed = 1;
  // Level an undriven ENABLE pin has (pull-up on the CNC shield: drivers start disabled).
  bool enable_idle_level = true;
  // A driver takes steps this long after its SLEEP rose (--wake-us; A4988: 1 ms).
  uint64_t wake_cycles = 16000;
};

// What an output pin does for one motor.
enum class PinRole { kStep, kDir, kEnable, kSleep, kReset };

// One output pin the simulator must report changes of, with everyone using it.
struct WatchedPin {
  struct User {
    unsigned motor;
    PinRole role;
  };
  PinRef pin;
  bool initial_level;
  std::vector<User> users;
};

// One switch input pin (a shared min/max switch is one input).
struct SwitchInput {
  struct User {
    unsigned motor;
    bool max_end;  // false = min end
  };
  PinRef pin;
  unsigned trace_motor;  // motor named in endstop/bounce rows
  std::vector<User> users;
  EndstopSwitch contact;
};

// Per-motor counters and pin state.
struct MotorState {
  explicit MotorState(const Carriage &c) : carriage(c) {}
  Carriage carriage;
  bool step_level = false;
  bool dir_level = false;
  bool enable_level = true;
  bool sleep_level = true;        // SLEEP and RESET idle high (pulled up): awake, out of reset
  bool reset_level = true;
  uint64_t awake_cycle = 0;       // the driver takes steps from this cycle on (SLEEP rose + wake)
  bool rise_dir_level = false;
  uint64_t rise_cycle = 0;
  uint64_t pulses = 0;
  uint64_t min_high_cycles = 0;  // valid when pulses > 0
  uint64_t dir_changes = 0;
  uint64_t endstop_changes = 0;
};

// Routes pin changes to carriages, switches, counters and the trace.
class VirtualBoard {
 public:
  // trace may be closed (rows are then dropped).
  VirtualBoard(const BoardConfig &board, const ModelSettings &settings, TraceWriter &trace);

  // Where switch levels go; must be set before the first pin event.
  void set_driver(SwitchPinDriver *driver) { driver_ = driver; }
  // Output pins to watch.
  const std::vector<WatchedPin> &watched_pins() const { return watched_; }
  // Switch inputs to drive (their contact's pin_level() is the level to start with).
  const std::vector<SwitchInput> &switch_inputs() const { return switches_; }
  // Motors.
  const std::vector<MotorState> &motors() const { return motors_; }

  // Presses the switches a start position already touches (call once, before running).
  void settle_initial_switches();
  // Whether switch input `input` reads pressed: an end one of its motors reached, or a fault.
  bool switch_closed(const SwitchInput &input) const;
  // Output pin watched_index changed to level at cycle.
  void on_output_pin(size_t watched_index, bool level, uint64_t cycle);
  // Applies switch pin events due at cycle.
  void on_wakeup(uint64_t cycle);

  // "# initial ..." comment texts describing the state at cycle 0.
  std::vector<std::string> initial_lines() const;
  // One summary text per motor.
  std::vector<std::string> summary_lines() const;

 private:
  // A STEP pin edge.
  void on_step_edge(unsigned motor, bool level, uint64_t cycle);
  // A SLEEP or RESET pin change.
  void on_power_pin(unsigned motor, PinRole role, bool level, uint64_t cycle);
  // Re-evaluates the switches of motor after it moved.
  void update_switches_of(unsigned motor, uint64_t cycle);
  // Re-evaluates one switch input.
  void update_switch(size_t switch_index, uint64_t cycle);
  // Applies due pin events of one switch and asks for the next wakeup.
  void drain_switch(size_t switch_index, uint64_t cycle);

  const BoardConfig &board_;
  ModelSettings settings_;
  TraceWriter &trace_;
  SwitchPinDriver *driver_ = nullptr;
  std::vector<MotorState> motors_;
  std::vector<WatchedPin> watched_;
  std::vector<SwitchInput> switches_;
  std::vector<std::vector<size_t>> switches_of_motor_;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_VIRTUAL_BOARD_H
