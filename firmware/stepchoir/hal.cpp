// hal.cpp: the AVR implementation of hal.h, every function: the board table (board::active),
// the drivers (step_driver.h), the step path (scheduler.h), moves (moves.h) and the UART link
// (link.h). The host
// tests implement hal.h with a recorder (tests/firmware/fake_hal.cpp).
// Called from: the command layer (commands.cpp), in the main loop only.
#include "hal.h"

#include <avr/eeprom.h>

#include "boards/board.h"
#include "link.h"
#include "moves.h"
#include "scheduler.h"
#include "step_driver.h"

namespace hal {

uint8_t motor_count() { return board::active::kMotorCount; }

const char *board_name() { return board::active::kName; }

uint8_t endstops(uint8_t m) {
  const board::MotorPins &p = board::active::kMotors[m];
  uint8_t e = 0;
  if (p.min_switch.wired()) e |= sc::kEndstopMin;
  if (p.max_switch.wired()) e |= sc::kEndstopMax;
  if (board::same_pin(p.min_switch, p.max_switch)) e |= sc::kEndstopShared;
  return e;
}

uint32_t now_ticks() { return sched::now(); }

void set_period(uint8_t m, uint32_t period_q8) {
  // A driver woken for this note, or still waking, may step only from its ready time on: the
  // note starts then, exactly (a timed start), and so does a change made meanwhile.
  uint32_t ready;
  if (period_q8 != sc::kPeriodSilent && drivers::maybe_unready(m) && drivers::ready_time(m, &ready))
    sched::set_period_at(m, period_q8, ready);
  else sched::set_period(m, period_q8);
}

uint8_t queue_used() { return sched::queue_used(); }

void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks) {
  sched::queue_at(m, period_q8, drivers::entry_time(m, period_q8, at_ticks));
}

uint8_t late_entries(uint8_t *motor) {
  const sched::Counters c = sched::counters();
  *motor = c.late_motor;
  return c.late_entries;
}

void stop_all() {
  sched::silence_all();
  drivers::disable_all();
}

void silence(uint8_t mask) {
  sched::silence(mask);
  drivers::release(mask);
}

uint8_t configure(const sc::ConfigBody &c) { return drivers::configure(c); }

uint8_t configure_driver(const sc::DriverBody &b) { return drivers::configure_power(b); }

uint8_t driver_act(uint8_t m, uint8_t action) { return drivers::act(m, action); }

void move(const sc::MoveBody &b) { moves::start(b); }

uint8_t moving() { return moves::moving(); }

bool move_ended(sc::MoveDoneBody *out) { return moves::ended(out); }

void set_position(uint8_t m, int32_t position) { sched::set_position(m, position); }

uint8_t sounding() { return sched::sounding(); }

void motor_status(uint8_t m, sc::StatusMotor *out) { sched::motor_status(m, out); }

uint16_t late_edges() { return sched::counters().late_edges; }

uint8_t last_motor_fault() { return sched::counters().motor_fault; }

bool drivers_enabled() { return drivers::any_enabled(); }

void reset_step_counters() { sched::reset_counters(); }

uint16_t uart_overruns() { return link::rx_errors(); }

void reset_uart_overruns() { link::reset_rx_errors(); }

void send(const uint8_t *payload, uint8_t len) { link::send_frame(payload, len); }

void eeprom_read(uint16_t addr, uint8_t *out, uint8_t len) {
  eeprom_read_block(out, reinterpret_cast<const void *>(addr), len);
}

void eeprom_write(uint16_t addr, const uint8_t *data, uint8_t len) {
  eeprom_update_block(data, reinterpret_cast<void *>(addr), len);
}

}  // namespace hal
