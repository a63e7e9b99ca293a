// virtual_board.cpp: pin events -> carriage moves, end switch changes, counters and trace rows.
#include "virtual_board.h"

#include <sstream>

namespace vboard {

namespace {

// Index of pin in watched, adding it (with initial_level) if new.
size_t watched_index_of(std::vector<WatchedPin> &watched, const PinRef &pin, bool initial_level) {
  for (size_t i = 0; i < watched.size(); ++i)
    if (watched[i].pin.same_as(pin)) return i;
  watched.push_back({pin, initial_level, {}});
  return watched.size() - 1;
}

// "D9 (PB1)" style name of a pin.
std::string pin_name(const PinRef &pin) {
  std::ostringstream text;
  text << "D" << pin.arduino << "(P" << pin.port << static_cast<int>(pin.bit) << ")";
  return text.str();
}

}  // namespace

// Builds motor state and the pin lists from the board table.
VirtualBoard::VirtualBoard(const BoardConfig &board, const ModelSettings &settings, TraceWriter &trace)
    : board_(board), settings_(settings), trace_(trace) {
  const unsigned motor_count = static_cast<unsigned>(board.motors.size());
  switches_of_motor_.resize(motor_count);
  for (unsigned m = 0; m < motor_count; ++m) {
    const MotorConfig &cfg = board.motors[m];
    motors_.emplace_back(Carriage(settings.travel_steps, settings.start_position_steps));
    motors_.back().enable_level = settings.enable_idle_level;
    watched_[watched_index_of(watched_, cfg.step, false)].users.push_back({m, PinRole::kStep});
    watched_[watched_index_of(watched_, cfg.dir, false)].users.push_back({m, PinRole::kDir});
    if (cfg.enable.wired)
      watched_[watched_index_of(watched_, cfg.enable, settings.enable_idle_level)].users.push_back(
          {m, PinRole::kEnable});
    else
      motors_.back().enable_level = !board.enable_active_low;  // no pin: always enabled
    if (cfg.sleep.wired) watched_[watched_index_of(watched_, cfg.sleep, true)].users.push_back({m, PinRole::kSleep});
    if (cfg.reset.wired) watched_[watched_index_of(watched_, cfg.reset, true)].users.push_back({m, PinRole::kReset});

    const PinRef ends[2] = {cfg.min_switch, cfg.max_switch};
    for (int end = 0; end < 2; ++end) {
      if (!ends[end].wired) continue;
      size_t index = switches_.size();
      for (size_t s = 0; s < switches_.size(); ++s)
        if (switches_[s].pin.same_as(ends[end])) index = s;
      if (index == switches_.size()) {
        const uint64_t seed = settings.seed * 1000003ull + static_cast<uint64_t>(ends[end].port) * 8 +
                              ends[end].bit;
        switches_.push_back({ends[end], m, {},
                             EndstopSwitch(settings.switch_active_low, settings.chatter_cycles, seed)});
      }
      switches_[index].users.push_back({m, end == 1});
      std::vector<size_t> &mine = switches_of_motor_[m];
      if (mine.empty() || mine.back() != index) mine.push_back(index);
    }
  }
}

// Presses the switches a start position already touches (no chatter at power-up).
void VirtualBoard::settle_initial_switches() {
  for (SwitchInput &input : switches_) input.contact.reset_to(switch_closed(input));
}

bool VirtualBoard::switch_closed(const SwitchInput &input) const {
  bool pressed = false;
  for (const SwitchInput::User &user : input.users) {
    const Carriage &c = motors_[user.motor].carriage;
    if (int(user.motor) == settings_.dead_switch_motor) continue;
    pressed = pressed || (user.max_end ? c.at_max() : c.at_min()) || int(user.motor) == settings_.stuck_switch_motor;
  }
  return pressed;
}

// Output pin watched_index changed to level at cycle.
void VirtualBoard::on_output_pin(size_t watched_index, bool level, uint64_t cycle) {
  for (const WatchedPin::User &user : watched_[watched_index].users) {
    MotorState &motor = motors_[user.motor];
    switch (user.role) {
      case PinRole::kStep:
        on_step_edge(user.motor, level, cycle);
        break;
      case PinRole::kDir:
        if (level == motor.dir_level) break;
        motor.dir_level = level;
        ++motor.dir_changes;
        trace_.dir(user.motor, cycle, level, motor.carriage.position_steps());
        break;
      case PinRole::kEnable:
        if (level == motor.enable_level) break;
        motor.enable_level = level;
        trace_.enable(user.motor, cycle, level);
        break;
      case PinRole::kSleep:
      case PinRole::kReset:
        on_power_pin(user.motor, user.role, level, cycle);
        break;
    }
  }
}

// A SLEEP or RESET pin change: SLEEP rising starts the driver's wake time.
void VirtualBoard::on_power_pin(unsigned motor_index, PinRole role, bool level, uint64_t cycle) {
  MotorState &motor = motors_[motor_index];
  bool &now = role == PinRole::kSleep ? motor.sleep_level : motor.reset_level;
  if (level == now) return;
  now = level;
  if (role == PinRole::kSleep) {
    if (level) motor.awake_cycle = cycle + settings_.wake_cycles;
    trace_.sleep(motor_index, cycle, level);
  } else {
    trace_.reset(motor_index, cycle, level);
  }
}

// A STEP pin edge: the rising edge moves the carriage, the falling edge writes the row.
void VirtualBoard::on_step_edge(unsigned motor_index, bool level, uint64_t cycle) {
  MotorState &motor = motors_[motor_index];
  if (level == motor.step_level) return;
  motor.step_level = level;
  if (level) {
    motor.rise_cycle = cycle;
    motor.rise_dir_level = motor.dir_level;
    // The driver takes the step only enabled, awake for its wake time and out of reset.
    const bool ready = motor.enable_level != board_.enable_active_low && motor.sleep_level &&
                       cycle >= motor.awake_cycle && motor.reset_level;
    if (motor.carriage.step(motor.dir_level, ready)) update_switches_of(motor_index, cycle);
    return;
  }
  const uint64_t high_cycles = cycle - motor.rise_cycle;
  if (motor.pulses == 0 || high_cycles < motor.min_high_cycles) motor.min_high_cycles = high_cycles;
  ++motor.pulses;
  trace_.step(motor_index, motor.rise_cycle, motor.rise_dir_level, motor.carriage.position_steps(),
              high_cycles);
}

// Re-evaluates the switches of a motor after it moved.
void VirtualBoard::update_switches_of(unsigned motor, uint64_t cycle) {
  for (size_t s : switches_of_motor_[motor]) update_switch(s, cycle);
}

// Re-evaluates one switch input: pressed if any end it serves is reached.
void VirtualBoard::update_switch(size_t switch_index, uint64_t cycle) {
  SwitchInput &input = switches_[switch_index];
  const bool pressed = switch_closed(input);
  if (!input.contact.set_pressed(pressed, cycle)) return;
  ++motors_[input.trace_motor].endstop_changes;
  trace_.endstop(input.trace_motor, cycle, pressed, motors_[input.trace_motor].carriage.position_steps());
  drain_switch(switch_index, cycle);
}

// Applies due pin events of one switch and asks for the next wakeup.
void VirtualBoard::drain_switch(size_t switch_index, uint64_t cycle) {
  SwitchInput &input = switches_[switch_index];
  SwitchPinEvent event;
  while (input.contact.pop_due(cycle, event)) {
    if (driver_) driver_->drive_switch_pin(switch_index, event.level);
    if (event.bounce)
      trace_.bounce(input.trace_motor, cycle, event.level,
                    motors_[input.trace_motor].carriage.position_steps());
  }
  if (input.contact.has_pending() && driver_) driver_->wake_at(input.contact.next_event_cycle());
}

// Applies switch pin events due at cycle.
void VirtualBoard::on_wakeup(uint64_t cycle) {
  for (size_t s = 0; s < switches_.size(); ++s)
    if (switches_[s].contact.has_pending()) drain_switch(s, cycle);
}

// "# initial ..." comment texts describing the state at cycle 0.
std::vector<std::string> VirtualBoard::initial_lines() const {
  std::vector<std::string> lines;
  for (unsigned m = 0; m < motors_.size(); ++m) {
    const MotorState &motor = motors_[m];
    std::ostringstream text;
    text << "initial motor=" << m << " axis=" << board_.motors[m].axis
         << " position=" << motor.carriage.position_steps() << " dir=" << (motor.dir_level ? 1 : 0)
         << " enable=" << (motor.enable_level ? 1 : 0) << " step=" << pin_name(board_.motors[m].step)
         << " dir_pin=" << pin_name(board_.motors[m].dir);
    if (board_.motors[m].sleep.wired) text << " sleep_pin=" << pin_name(board_.motors[m].sleep);
    if (board_.motors[m].reset.wired) text << " reset_pin=" << pin_name(board_.motors[m].reset);
    lines.push_back(text.str());
  }
  for (const SwitchInput &input : switches_) {
    std::ostringstream text;
    text << "initial switch motor=" << input.trace_motor << " pin=" << pin_name(input.pin)
         << " pressed=" << (input.contact.pressed() ? 1 : 0)
         << " level=" << (input.contact.pin_level() ? 1 : 0) << " ends=";
    for (size_t u = 0; u < input.users.size(); ++u)
      text << (u ? "+" : "") << (input.users[u].max_end ? "max" : "min");
    lines.push_back(text.str());
  }
  return lines;
}

// One summary text per motor.
std::vector<std::string> VirtualBoard::summary_lines() const {
  std::vector<std::string> lines;
  for (unsigned m = 0; m < motors_.size(); ++m) {
    const MotorState &motor = motors_[m];
    std::ostringstream text;
    text << "motor=" << m << " axis=" << board_.motors[m].axis << " steps=" << motor.carriage.steps()
         << " lost_steps=" << motor.carriage.lost_steps()
         << " position=" << motor.carriage.position_steps()
         << " overshoot=" << motor.carriage.overshoot_steps()
         << " min_high_cycles=" << (motor.pulses ? motor.min_high_cycles : 0)
         << " dir_changes=" << motor.dir_changes << " endstop_changes=" << motor.endstop_changes;
    lines.push_back(text.str());
  }
  return lines;
}

}  // namespace vboard
