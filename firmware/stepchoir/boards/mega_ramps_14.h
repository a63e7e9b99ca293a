// mega_ramps_14.h: Arduino Mega 2560 (16 MHz) + RAMPS 1.4, 5 driver sockets (X, Y, Z, E0, E1).
//
// Each socket has its own ENABLE (active low). X, Y and Z have separate MIN and MAX switch
// inputs; E0 and E1 have none and rely on soft limits. Microstep jumpers sit under each socket
// (M0-M2 are not wired to the Arduino). On RAMPS the two Z sockets are paralleled: Z here is
// one motor as far as the firmware knows. RESET and SLEEP are tied together under each socket; a
// builder who wires them to free pins names them in a kMsgDriver frame.
#ifndef STEPCHOIR_BOARD_MEGA_RAMPS_14_H
#define STEPCHOIR_BOARD_MEGA_RAMPS_14_H

#include "pins.h"

namespace board {
namespace mega_ramps_14 {

constexpr const char *kName = "mega_ramps_14";
constexpr const char *kMcu = "atmega2560";
constexpr uint8_t kMotorCount = 5;
constexpr bool kEnableActiveLow = true;
constexpr bool kSharedEnable = false;

constexpr Pin D2 = {2, 'E', 4}, D3 = {3, 'E', 5}, D14 = {14, 'J', 1}, D15 = {15, 'J', 0},
              D18 = {18, 'D', 3}, D19 = {19, 'D', 2}, D24 = {24, 'A', 2}, D26 = {26, 'A', 4},
              D28 = {28, 'A', 6}, D30 = {30, 'C', 7}, D34 = {34, 'C', 3}, D36 = {36, 'C', 1},
              D38 = {38, 'D', 7}, D46 = {46, 'L', 3}, D48 = {48, 'L', 1}, D54 = {54, 'F', 0},
              D55 = {55, 'F', 1}, D56 = {56, 'F', 2}, D60 = {60, 'F', 6}, D61 = {61, 'F', 7},
              D62 = {62, 'K', 0};

// Arduino pin -> port and bit (variant "mega"): D0-D53, then A0-A15 as 54-69.
constexpr uint8_t kPinCount = 70;
constexpr uint8_t kPinMap[kPinCount] SC_FLASH = {
    SC_PB('E', 0), SC_PB('E', 1), SC_PB('E', 4), SC_PB('E', 5), SC_PB('G', 5), SC_PB('E', 3), SC_PB('H', 3),  // D0-D6
    SC_PB('H', 4), SC_PB('H', 5), SC_PB('H', 6), SC_PB('B', 4), SC_PB('B', 5), SC_PB('B', 6), SC_PB('B', 7),  // D7-D13
    SC_PB('J', 1), SC_PB('J', 0), SC_PB('H', 1), SC_PB('H', 0), SC_PB('D', 3), SC_PB('D', 2), SC_PB('D', 1),  // D14-D20
    SC_PB('D', 0), SC_PB('A', 0), SC_PB('A', 1), SC_PB('A', 2), SC_PB('A', 3), SC_PB('A', 4), SC_PB('A', 5),  // D21-D27
    SC_PB('A', 6), SC_PB('A', 7), SC_PB('C', 7), SC_PB('C', 6), SC_PB('C', 5), SC_PB('C', 4), SC_PB('C', 3),  // D28-D34
    SC_PB('C', 2), SC_PB('C', 1), SC_PB('C', 0), SC_PB('D', 7), SC_PB('G', 2), SC_PB('G', 1), SC_PB('G', 0),  // D35-D41
    SC_PB('L', 7), SC_PB('L', 6), SC_PB('L', 5), SC_PB('L', 4), SC_PB('L', 3), SC_PB('L', 2), SC_PB('L', 1),  // D42-D48
    SC_PB('L', 0), SC_PB('B', 3), SC_PB('B', 2), SC_PB('B', 1), SC_PB('B', 0), SC_PB('F', 0), SC_PB('F', 1),  // D49-D55
    SC_PB('F', 2), SC_PB('F', 3), SC_PB('F', 4), SC_PB('F', 5), SC_PB('F', 6), SC_PB('F', 7), SC_PB('K', 0),  // D56-D62
    SC_PB('K', 1), SC_PB('K', 2), SC_PB('K', 3), SC_PB('K', 4), SC_PB('K', 5), SC_PB('K', 6), SC_PB('K', 7),  // D63-D69
};

//                          axis step dir  enable min   max   m0     m1     m2     reset  sleep
constexpr MotorPins kMotors[kMotorCount] = {
    {'X', D54, D55, D38, D3, D2, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'Y', D60, D61, D56, D14, D15, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'Z', D46, D48, D62, D18, D19, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'0', D26, D28, D24, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
    {'1', D36, D34, D30, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin, kNoPin},
};

static_assert(motor_pins_distinct(kMotors[0]) && motor_pins_distinct(kMotors[1]) &&
                  motor_pins_distinct(kMotors[2]) && motor_pins_distinct(kMotors[3]) &&
                  motor_pins_distinct(kMotors[4]),
              "mega_ramps_14: a motor's STEP, DIR, ENABLE and switch pins must differ");
static_assert(motors_disjoint(kMotors[0], kMotors[1], kSharedEnable) &&
                  motors_disjoint(kMotors[0], kMotors[2], kSharedEnable) &&
                  motors_disjoint(kMotors[0], kMotors[3], kSharedEnable) &&
                  motors_disjoint(kMotors[0], kMotors[4], kSharedEnable) &&
                  motors_disjoint(kMotors[1], kMotors[2], kSharedEnable) &&
                  motors_disjoint(kMotors[1], kMotors[3], kSharedEnable) &&
                  motors_disjoint(kMotors[1], kMotors[4], kSharedEnable) &&
                  motors_disjoint(kMotors[2], kMotors[3], kSharedEnable) &&
                  motors_disjoint(kMotors[2], kMotors[4], kSharedEnable) &&
                  motors_disjoint(kMotors[3], kMotors[4], kSharedEnable),
              "mega_ramps_14: two motors share a STEP, DIR, ENABLE or switch pin");

}  // namespace mega_ramps_14
}  // namespace board

#endif  // STEPCHOIR_BOARD_MEGA_RAMPS_14_H
