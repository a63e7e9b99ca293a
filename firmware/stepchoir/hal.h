// hal.h: what the command layer needs from the hardware. The AVR build implements it in
// hal.cpp; the host tests implement it with a recorder (tests/firmware/fake_hal.cpp).
//
// Every function here is called from the main loop only (never from an ISR).
#ifndef STEPCHOIR_HAL_H
#define STEPCHOIR_HAL_H

#include <stdint.h>

#include "src/stepchoir_protocol.h"

namespace hal {

// Number of driver sockets on this board.
uint8_t motor_count();

// Endstop wiring of motor m (sc::kEndstopMin | kEndstopMax | kEndstopShared).
uint8_t endstops(uint8_t m);

// The board's name as reported in kMsgCaps.
const char *board_name();

// Board time: CPU ticks since the step timer started (about 1 ms after reset), wrapping at 2^32.
uint32_t now_ticks();

// Plays motor m at period_q8 (CPU ticks, 8 fractional bits; 0 = silence) from now on, keeping
// the phase of a sounding motor. The caller has checked the range. A driver powered down is
// woken: the note then starts exactly its wake time later.
void set_period(uint8_t m, uint32_t period_q8);

// The queue of timestamped entries (kMsgAt), cfg::kQueueSize of them, emptied by the main loop
// (sched::poll, cfg::kTakeTicks before each entry's time): motor m takes period_q8 exactly at
// board time at_ticks (a silent motor's first edge
// falls on it, a sounding one strikes on it). Entries must come in time order; queue_at only
// when queue_used() < cfg::kQueueSize. stop_all() empties it. A note's driver is woken when
// it is queued; an entry due before the driver is awake plays then.
uint8_t queue_used();
void queue_at(uint8_t m, uint32_t period_q8, uint32_t at_ticks);
// Entries taken after their time (made at once), counted from power-up (wrapping),
// and the last one's motor.
uint8_t late_entries(uint8_t *motor);

// Silences every motor at once, empties the queue and disables the drivers.
void stop_all();

// Silences the motors whose bit is set in mask (the caller checked they exist) at once and
// drops their queued entries; the other motors and every driver's power are left as they are.
void silence(uint8_t mask);

// Applies a motor configuration (validated by the caller except for driver-specific modes).
// Returns sc::kErrNone or sc::kErrConfig.
uint8_t configure(const sc::ConfigBody &c);

// kMsgDriver (b.motor checked): motor b.motor's SLEEP and RESET pins, idle power-down and
// wake time. Returns sc::kErrNone or sc::kErrConfig (a value the board cannot take).
uint8_t configure_driver(const sc::DriverBody &b);

// kMsgDriverAct (m checked): sc::DriverAction on motor m's driver now. Returns sc::kErrNone or
// sc::kErrConfig (an unknown action, or one whose pin is not wired).
uint8_t driver_act(uint8_t m, uint8_t action);

// Moves (kMsgMove). move: starts one the caller checked (motor silent, not moving, no timed
// entry queued), the driver woken first. moving: bit m set while motor m moves (until
// move_ended has reported it). move_ended: a move that ended since the last call, true with its
// reply. set_position: motor m's counted position (steps) from now on.
void move(const sc::MoveBody &b);
uint8_t moving();
bool move_ended(sc::MoveDoneBody *out);
void set_position(uint8_t m, int32_t position);

// Bit m set while motor m sounds (or moves).
uint8_t sounding();

// Fills motor m's status record: position, flags, its reversals since the last reset.
void motor_status(uint8_t m, sc::StatusMotor *out);

// Step-level counters kept by the scheduler: late edges since the last reset.
uint16_t late_edges();
uint8_t last_motor_fault();  // sc::ErrorCode raised by the step ISR (endstop stuck), 0 if none
bool drivers_enabled();
void reset_step_counters();

// Bytes the UART lost (hardware overrun or a full receive ring).
uint16_t uart_overruns();
void reset_uart_overruns();

// Queues one encoded reply frame for the UART; drops it when the transmit ring is full.
void send(const uint8_t *payload, uint8_t len);

// EEPROM bytes at addr. Called from: the main loop (kMsgIdReq, kMsgSetId). A write waits for
// the EEPROM, 3.3 ms a byte that changes (datasheet tWD_EEPROM); the step ISRs run on meanwhile.
void eeprom_read(uint16_t addr, uint8_t *out, uint8_t len);
void eeprom_write(uint16_t addr, const uint8_t *data, uint8_t len);

}  // namespace hal

#endif  // STEPCHOIR_HAL_H
