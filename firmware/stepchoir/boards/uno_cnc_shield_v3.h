// uno_cnc_shield_v3.h: Arduino Uno (ATmega328P, 16 MHz) + CNC Shield V3, 4 driver sockets.
//
// One shared ENABLE (D8, active low) for all sockets. The shield has one limit input per axis
// (X=D9, Y=D10, Z=D11), wired to both end switches of that axis, so the firmware cannot tell
// the ends apart by pin: it reverses on the switch and knows the end from its direction.
// The A socket has no switch; it relies on soft limits. Microstep mode is set with jumpers
// (M0-M2 are not wired to the Arduino). RESET and SLEEP are tied together on the shield; a
// builder who wires them to free pins names them in a kMsgDriver frame.
#ifndef STEPCHOIR_BOARD_UNO_CNC_SHIELD_V3_H
#define STEPCHOIR_BOARD_UNO_CNC_SHIELD_V3_H

#include "pins.h"

namespace board {
namespace uno_cnc_shield_v3 {

constexpr const char *kName = "uno_cnc_shield_v3";
constexpr const char *kMcu = "atmega328p";
constexpr uint8_t kMotorCount = 4;
constexpr bool kEnableActiveLow = true;
constexpr bool kSharedEnable = true;

constexpr Pin D2 = {2, 'D', 2}, D3 = {3, 'D', 3}, D4 = {4, 'D', 4}, D5 = {5, 'D', 5},
              D6 = {6, 'D', 6}, D7 = {7, 'D', 7}, D8 = {8, 'B', 0}, D9 = {9, 'B', 1},
              D10 = {10, 'B', 2}, D11 = {11, 'B', 3}, D12 = {12, 'B', 4}, D13 = {13, 'B', 5};

// Arduino pin -> port and bit (variant "standard"): D0-D7 PD0-7, D8-D13 PB0-5, A0-A5 (14-19) PC0-5.
constexpr uint8_t kPinCount = 20;
constexpr uint8_t kPinMap[kPinCount] SC_FLASH = {
    SC_PB('D', 0), SC_PB('D', 1), SC_PB('D', 2), SC_PB('D', 3), SC_PB('D', 4), SC_PB('D', 5), SC_PB('D', 6),
    SC_PB('D', 7), SC_PB('B', 0), SC_PB('B', 1), SC_PB('B', 2), SC_PB('B', 3), SC_PB('B', 4), SC_PB('B', 5),
    SC_PB('C', 0), SC_PB('C', 1), SC_PB('C', 2), SC_PB('C', 3), SC_PB('C', 4), SC_PB('C', 5),
};

//                          axis step dir enable  min   max   m0     m1     m2     reset  sleep
constexpr MotorPins kMotors[kMotorCount] = {
    {'X', D2, D5, D8, D9, D9, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'Y', D3, D6, D8, D10, D10, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'Z', D4, D7, D8, D11, D11, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'A', D12, D13, D8, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
};

static_assert(motor_pins_distinct(kMotors[0]) && motor_pins_distinct(kMotors[1]) &&
                  motor_pins_distinct(kMotors[2]) && motor_pins_distinct(kMotors[3]),
              "uno_cnc_shield_v3: a motor's STEP, DIR, ENABLE and switch pins must differ");
static_assert(motors_disjoint(kMotors[0], kMotors[1], kSharedEnable) &&
                  motors_disjoint(kMotors[0], kMotors[2], kSharedEnable) &&
                  motors_disjoint(kMotors[0], kMotors[3], kSharedEnable) &&
                  motors_disjoint(kMotors[1], kMotors[2], kSharedEnable) &&
                  motors_disjoint(kMotors[1], kMotors[3], kSharedEnable) &&
                  motors_disjoint(kMotors[2], kMotors[3], kSharedEnable),
              "uno_cnc_shield_v3: two motors share a STEP, DIR or switch pin");

}  // namespace uno_cnc_shield_v3
}  // namespace board

#endif  // STEPCHOIR_BOARD_UNO_CNC_SHIELD_V3_H
