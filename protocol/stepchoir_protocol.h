// stepchoir_protocol.h: the one definition of the host <-> board wire format.
//
// Every constant of the protocol lives here and nowhere else. The header compiles with
// avr-gcc 5.4 (-std=gnu++11, no STL, no heap) for the firmware and with the host's C++17,
// so the frame codec below is the same code on both ends. protocol/PROTOCOL.md explains the
// format in prose and carries the hex test vectors both test suites decode.
//
// Nothing here allocates, blocks or logs; every function is safe to call from any thread
// or from the firmware's main loop. None of them is meant for an ISR.
#ifndef STEPCHOIR_PROTOCOL_H
#define STEPCHOIR_PROTOCOL_H

#include <stdint.h>
#include <stddef.h>

namespace sc {

// ---------------------------------------------------------------------------------------------
// Link and framing
// ---------------------------------------------------------------------------------------------

static const uint8_t kProtocolVersion = 3;     // in caps: the message layouts of this header
static const uint32_t kBaud = 1000000;         // bit/s; exact at 16 MHz with U2X clear, UBRR 0
static const uint8_t kDelimiter = 0x00;        // ends every frame on the wire (COBS never emits it)
static const uint8_t kMaxPayload = 60;         // bytes of message (type byte included), before CRC
static const uint8_t kCrcBytes = 2;            // CRC-16/CCITT-FALSE, little-endian after payload
static const uint8_t kMaxFrameWire = kMaxPayload + kCrcBytes + 2;  // + COBS code byte + delimiter

// ---------------------------------------------------------------------------------------------
// Periods: CPU ticks with 8 fractional bits ("q8"), so the firmware never divides.
// ---------------------------------------------------------------------------------------------

static const uint8_t kPeriodFracBits = 8;
static const uint32_t kPeriodQ8Max = 0x0FFFFFFFul;  // 28 bits: 1,048,575.996 ticks (15.26 Hz at 16 MHz)
// Shortest period the firmware accepts from any message: 200 us (5 kHz steps), above the top
// of a piano (C8, 4186 Hz) and within what the step ISR sustains while the board still answers.
static const uint32_t kPeriodQ8Min = 3200ul << kPeriodFracBits;
static const uint32_t kPeriodSilent = 0;      // period 0 means: stop stepping

// Watchdog: a board silences every motor when no accepted frame arrived for this long (ms),
// until a kMsgWatchdog frame sets another time (0 = off).
static const uint16_t kWatchdogDefaultMs = 300;
static const uint16_t kWatchdogMinMs = 20;  // shorter (but not 0) is refused: kErrConfig

// Link budget: a host keeps what it sends under kLinkBudgetBytesPerSecond, in bursts of at
// most kLinkBurstBytes (a token bucket). A board then decodes every frame even with every
// motor playing fast (tests/e2e/test_link.cpp: five motors at about 5,800 steps a second,
// every motor's period again and heartbeats). Bursts longer than the board's 128-byte receive
// ring, or frames back to back at the full line rate, are lost in part (bench/results): the
// motors' step ISRs leave the main loop too little time to keep up. 10,000 bytes a second is three times what a MIDI cable carries:
// 1,250 one-motor frames a second. The host's writer coalesces to it (only the latest period
// per motor is sent; a silence is never dropped).
static const uint32_t kLinkBudgetBytesPerSecond = 10000;
static const uint8_t kLinkBurstBytes = 80;

// Longest travel a motor may be configured with (steps); positions are signed 32-bit.
static const uint32_t kMaxTravelSteps = 1000000000ul;

// ---------------------------------------------------------------------------------------------
// Message types: the first payload byte.
// ---------------------------------------------------------------------------------------------
//
// A first byte with the top bit set starts a set-period entry (4 bytes):
//   byte 0: 1 m m m p p p p   m = motor index 0-7, pppp = period bits 27..24
//   byte 1-3: period bits 0..23, little-endian
// A frame whose first byte has the top bit set holds 1 to 15 such entries and nothing else:
// one motor costs 4 + 2 (CRC) + 1 (COBS) + 1 (delimiter) = 8 bytes on the wire; a chord
// costs 4 bytes more per extra motor.
static const uint8_t kSetPeriodFlag = 0x80;
static const uint8_t kSetPeriodBytes = 4;
static const uint8_t kMaxMotors = 8;           // what the entry format can address

enum MsgType : uint8_t {
  // host -> board
  kMsgHello = 0x01,       // (empty) -> kMsgCaps
  kMsgConfig = 0x02,      // ConfigBody: configure one motor's driver, travel and limits
  kMsgHeartbeat = 0x03,   // (empty): keeps the watchdog fed, no reply
  kMsgStopAll = 0x04,     // (empty): silence every motor now, disable the drivers
  kMsgStatusReq = 0x05,   // (empty) -> kMsgStatus
  kMsgClockReq = 0x06,    // u8 seq -> kMsgClock
  kMsgAt = 0x07,          // u32 board time, then 1-13 set-period entries: play them at that time
  kMsgWatchdog = 0x08,    // u16 timeout in ms (0 = never): silence after that long without a frame
  kMsgResetCounters = 0x09,  // (empty): zero the status counters
  kMsgDriver = 0x0A,      // DriverBody: one driver's SLEEP and RESET pins and its idle power-down
  kMsgDriverAct = 0x0B,   // DriverActBody: wake, sleep, disable or reset one driver now
  kMsgIdReq = 0x0C,       // (empty) -> kMsgId
  kMsgSetId = 0x0D,       // 8-byte board id (not kBoardIdNone, not all 0xFF) -> kMsgId
  kMsgMove = 0x0E,        // MoveBody: one motor moves a number of steps on a ramp -> kMsgMoveDone
  kMsgSetPosition = 0x0F, // SetPositionBody: a motor's counted position (steps) from now on
  kMsgSilence = 0x10,     // u8 motor mask: those motors silent now, their timed entries dropped
  // board -> host
  kMsgCaps = 0x41,        // CapsBody + board name (ASCII, rest of payload)
  kMsgStatus = 0x42,      // StatusHead + one StatusMotor per motor
  kMsgClock = 0x43,       // u8 seq, u32 board ticks when the request was decoded
  kMsgError = 0x44,       // u8 error code, u8 message type it concerns, u8 detail
  kMsgId = 0x45,          // 8-byte board id, kept in EEPROM; all zero: none set yet
  kMsgMoveDone = 0x46,    // MoveDoneBody: a move ended (its steps, a switch, or a stop)
};

// A board's identity: 8 bytes the host chooses at random and the board keeps in its EEPROM
// from kEepromIdAddr on, so the host knows the board again (its crystal's error) whatever port
// it is on. An erased EEPROM (all 0xFF) reads as no id.
static const uint8_t kBoardIdBytes = 8;
static const uint16_t kEepromIdAddr = 0;

// ---------------------------------------------------------------------------------------------
// Error codes: one table, numbered for good. PROTOCOL.md gives each a sentence.
// ---------------------------------------------------------------------------------------------
enum ErrorCode : uint8_t {
  kErrNone = 0,
  kErrCrc = 1,            // frame failed its CRC (counted, never answered: it may be noise)
  kErrFrameTooLong = 2,   // no delimiter within kMaxFrameWire bytes
  kErrCobs = 3,           // COBS code byte points past the frame end
  kErrUnknownType = 4,    // first byte is no known message type
  kErrLength = 5,         // payload length does not fit the message type
  kErrMotor = 6,          // motor index >= the board's motor count
  kErrPeriodRange = 7,    // period outside the motor's configured range
  kErrQueueFull = 8,      // timestamped entry dropped: the board's queue is full
  kErrUartOverrun = 9,    // bytes lost in the UART (firmware too busy or line too fast)
  kErrLate = 10,          // timestamped entry arrived after its time; played at once
  kErrWatchdog = 11,      // no frame within the watchdog time: every motor stopped
  kErrEndstopStuck = 12,  // an endstop stayed active after the bounce; the motor ignores it
  kErrConfig = 13,        // configuration value out of range
  kErrShortFrame = 14,    // frame too short to hold a type byte and a CRC
  kErrBusy = 15,          // the motor is moving (a note, a move or a set-position), or sounding (a move)
};

// A short name for an error code, for logs and tests (host side; the firmware never calls it).
inline const char *error_name(uint8_t code) {
  switch (code) {
    case kErrNone: return "none";
    case kErrCrc: return "crc";
    case kErrFrameTooLong: return "frame-too-long";
    case kErrCobs: return "cobs";
    case kErrUnknownType: return "unknown-type";
    case kErrLength: return "length";
    case kErrMotor: return "motor";
    case kErrPeriodRange: return "period-range";
    case kErrQueueFull: return "queue-full";
    case kErrUartOverrun: return "uart-overrun";
    case kErrLate: return "late";
    case kErrWatchdog: return "watchdog";
    case kErrEndstopStuck: return "endstop-stuck";
    case kErrConfig: return "config";
    case kErrShortFrame: return "short-frame";
    case kErrBusy: return "busy";
    default: return "unknown-error";
  }
}

// Drivers the StepDriver code knows (ConfigBody::driver).
enum DriverType : uint8_t { kDriverA4988 = 0, kDriverDrv8825 = 1, kDriverTb6600 = 2 };

// A driver's power-down when its motor has been silent for DriverBody::idle_ms.
enum DriverIdle : uint8_t {
  kIdleNone = 0,     // stays energized (holding torque; the driver and motor stay warm)
  kIdleSleep = 1,    // SLEEP low (needs a SLEEP pin)
  kIdleDisable = 2,  // ENABLE off; a shared ENABLE only once every motor on it is idle
};

// What kMsgDriverAct does to one driver (DriverActBody::action).
enum DriverAction : uint8_t {
  kActWake = 0,     // SLEEP high and ENABLE on; steps wait the wake time
  kActSleep = 1,    // silence the motor, SLEEP low (needs a SLEEP pin)
  kActDisable = 2,  // silence the motor (every motor on a shared ENABLE), ENABLE off
  kActReset = 3,    // silence the motor, pulse RESET low (needs a RESET pin), then the wake time
};

// Longest driver wake-up time a board takes (us; DriverBody::wake_us): the A4988 asks 1,000 us
// after SLEEP goes high, the DRV8825 1,700 us. A timed entry is taken 3 ms before its time
// (the firmware's cfg::kTakeTicks), so a driver woken then is awake by the entry's time.
static const uint16_t kWakeUsMax = 2500;
// Pin number meaning "not wired" (DriverBody::sleep_pin, reset_pin).
static const int8_t kPinNone = -1;

// Endstop wiring per motor, as reported in CapsBody::endstops[m].
static const uint8_t kEndstopMin = 0x01;     // a switch at the low end of travel
static const uint8_t kEndstopMax = 0x02;     // a switch at the high end of travel
static const uint8_t kEndstopShared = 0x04;  // one input for both ends (CNC Shield V3)

// ---------------------------------------------------------------------------------------------
// Message bodies (after the type byte). Little-endian, packed, fixed size.
// ---------------------------------------------------------------------------------------------

struct __attribute__((packed)) ConfigBody {
  uint8_t motor;
  uint8_t driver;            // DriverType
  uint8_t microsteps;        // 1, 2, 4, 8, 16 or 32 (what the driver supports)
  uint8_t endstop_active_high;  // 1: a switch reads HIGH when pressed; 0: LOW when pressed
  uint32_t travel_steps;     // length of travel in steps; 0 = unlimited (no soft limits)
  uint32_t min_period_q8;    // shortest period allowed (highest frequency), ticks q8
  uint32_t max_period_q8;    // longest period allowed (lowest frequency), ticks q8
  uint32_t start_period_q8;  // onset ramp starts at this period; 0 = no ramp
  uint32_t accel_q8;         // onset ramp: period shrinks by this much per step (ticks q8)
  uint8_t pulse_us;          // STEP high time, microseconds (2-10)
};

// kMsgDriver: pins are Arduino pin numbers of the board (D0 = 0, A0 = 14 on the Uno, 54 on the
// Mega), kPinNone when not wired. The board refuses (kErrConfig) a pin it does not have, the
// UART's pins 0 and 1, a pin any motor's STEP, DIR, ENABLE, switch or microstep select uses, a
// pin another driver's SLEEP or RESET uses, the same pin for SLEEP and RESET, idle above
// kIdleDisable, kIdleSleep without a SLEEP pin, and wake_us above kWakeUsMax.
struct __attribute__((packed)) DriverBody {
  uint8_t motor;
  int8_t sleep_pin;          // the driver's SLEEP input (low = asleep)
  int8_t reset_pin;          // the driver's RESET input (low = in reset)
  uint8_t idle;              // DriverIdle
  uint16_t idle_ms;          // silence before the idle power-down, ms
  uint16_t wake_us;          // the driver's wake-up time, us: no STEP edge sooner after a wake
};

// kMsgDriverAct.
struct __attribute__((packed)) DriverActBody {
  uint8_t motor;
  uint8_t action;            // DriverAction
};

struct __attribute__((packed)) CapsBody {
  uint8_t protocol_version;
  uint8_t motor_count;
  uint32_t f_cpu_hz;
  uint8_t queue_size;        // timestamped entries the board can hold
  uint8_t endstops[5];       // per motor: kEndstopMin | kEndstopMax | kEndstopShared
  uint8_t flags;             // kCapsAnnounced
};
static_assert(sizeof(CapsBody) == 13, "caps as PROTOCOL.md shows it");

// CapsBody::flags bit 0: the board sent these capabilities unasked as it started (power-up,
// its reset button, a brown-out); clear in a hello's answer.
static const uint8_t kCapsAnnounced = 0x01;
// The protocol version from which CapsBody carries flags; an older board's body ends at endstops.
static const uint8_t kCapsFlagsSinceVersion = 3;

// Whether a kMsgCaps payload (type byte included) is a board's announcement as it started:
// protocol version 3 on; a board of an older version never says so.
inline bool caps_announced(const uint8_t *p, uint8_t len) {
  return len >= 1 + sizeof(CapsBody) && p[0] == kMsgCaps && p[1] >= kCapsFlagsSinceVersion &&
         (p[1 + offsetof(CapsBody, flags)] & kCapsAnnounced);
}

struct __attribute__((packed)) StatusHead {
  uint32_t frames_ok;
  uint16_t frames_bad;       // frames that failed CRC or COBS, or were refused
  uint16_t uart_overruns;
  uint16_t reversals;        // every motor's endstop and soft-limit reversals since the counters were
                             // reset: the sum of the StatusMotor::reversals that follow (wraps at 65536)
  uint16_t late_edges;       // steps the scheduler had to raise itself, late: their compare was armed too late (should stay 0)
  uint8_t queue_used;
  uint8_t last_error;        // ErrorCode of the most recent fault
  uint8_t motor_count;
  uint8_t flags;             // kStatusWatchdogTripped ...
};
static const uint8_t kStatusWatchdogTripped = 0x01;
static const uint8_t kStatusDriversEnabled = 0x02;

struct __attribute__((packed)) StatusMotor {
  int32_t position_steps;
  uint8_t flags;             // kMotorDirUp | kMotorSounding | kMotorEndstopFault
  uint16_t reversals;        // this motor's endstop and soft-limit reversals since the counters
                             // were reset (wraps at 65536)
};
static const uint8_t kMotorDirUp = 0x01;
static const uint8_t kMotorSounding = 0x02;
static const uint8_t kMotorEndstopFault = 0x04;

// kMsgMove: motor `motor` moves `steps` steps (or fewer: see kMoveToSwitch), its speed on the
// seed's Torricelli ramp: from speed_min up at `accel` (v^2 = v0^2 + 2as), at most speed_max,
// and down again to speed_min at its last step. Speeds in steps/s, accel in steps/s^2. Refused
// (kErrBusy) while the motor sounds or moves; a note for a moving motor is refused too. The
// board answers kMsgMoveDone when the move ends. No soft limits and no bounce-back meanwhile.
struct __attribute__((packed)) MoveBody {
  uint8_t motor;
  uint8_t flags;             // kMoveUp | kMoveToSwitch
  uint32_t steps;            // 1 .. kMaxTravelSteps: the most the move takes
  uint16_t speed_min;        // kMoveSpeedMin .. speed_max, steps/s: the first and last steps
  uint16_t speed_max;        // .. kMoveSpeedMax, steps/s
  uint32_t accel;            // 1 .. kMoveAccelMax, steps/s^2
};
static const uint8_t kMoveUp = 0x01;        // position counts up (DIR high)
static const uint8_t kMoveToSwitch = 0x02;  // ends at the first step that finds the switch ahead pressed
// Speeds a move may take at 16 MHz: the periods kPeriodQ8Max (15.3 Hz) to kPeriodQ8Min.
static const uint16_t kMoveSpeedMin = 16;
static const uint16_t kMoveSpeedMax = 5000;
static const uint32_t kMoveAccelMax = 1000000ul;

// kMsgMoveDone.
struct __attribute__((packed)) MoveDoneBody {
  uint8_t motor;
  uint8_t end;               // MoveEnd
  int32_t position;          // the motor's counted position after the move, steps
  uint32_t steps;            // steps the move took
};
enum MoveEnd : uint8_t {
  kMoveEndSteps = 0,    // it took all its steps
  kMoveEndSwitch = 1,   // kMoveToSwitch: the switch ahead read pressed after its last step
  kMoveEndStopped = 2,  // stop-all or the watchdog ended it
};

// kMsgSetPosition: the motor's position counts from this (steps) from now on; refused
// (kErrBusy) while it moves.
struct __attribute__((packed)) SetPositionBody {
  uint8_t motor;
  int32_t position;
};

static_assert(sizeof(ConfigBody) + 1 <= kMaxPayload, "config fits a frame");
static_assert(sizeof(MoveBody) == 14 && sizeof(MoveDoneBody) == 10 && sizeof(SetPositionBody) == 5,
              "motion bodies as PROTOCOL.md shows them");
static_assert(sizeof(DriverBody) == 8 && sizeof(DriverActBody) == 2, "driver bodies as PROTOCOL.md shows them");
static_assert(sizeof(StatusHead) == 16 && sizeof(StatusMotor) == 7, "status records as PROTOCOL.md shows them");
static_assert(sizeof(StatusHead) + 1 + 5 * sizeof(StatusMotor) <= kMaxPayload, "status fits");

// ---------------------------------------------------------------------------------------------
// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection): check("123456789") = 0x29B1.
// Byte-wise without a table, no flash for a table. Written in 8-bit halves: the AVR then needs
// no 16-bit shifts (the 16-bit form, (crc << 8) ^ (x << 12) ^ (x << 5) ^ x, took 120 cycles a
// byte there, more than a byte's 160-cycle time on the line leaves the main loop).
// ---------------------------------------------------------------------------------------------
static const uint16_t kCrcInit = 0xFFFF;

inline __attribute__((always_inline)) uint16_t crc16_update(uint16_t crc, uint8_t byte) {
  uint8_t x = (uint8_t)((uint8_t)(crc >> 8) ^ byte);
  x ^= (uint8_t)(x >> 4);
  const uint8_t hi = (uint8_t)((uint8_t)crc ^ (uint8_t)(x << 4) ^ (uint8_t)(x >> 3));
  const uint8_t lo = (uint8_t)((uint8_t)(x << 5) ^ x);
  return (uint16_t)(((uint16_t)hi << 8) | lo);
}

inline uint16_t crc16(const uint8_t *data, size_t len) {
  uint16_t crc = kCrcInit;
  for (size_t i = 0; i < len; ++i) crc = crc16_update(crc, data[i]);
  return crc;
}

// ---------------------------------------------------------------------------------------------
// Little-endian field access (the AVR and x86 are both little-endian, but say so explicitly).
// ---------------------------------------------------------------------------------------------
inline uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }
inline uint32_t get_u32(const uint8_t *p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
inline void put_u16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
inline void put_u32(uint8_t *p, uint32_t v) {
  p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); p[2] = (uint8_t)(v >> 16); p[3] = (uint8_t)(v >> 24);
}

// A board id as its 8 bytes, little-endian (host side; the firmware copies the bytes).
inline void put_board_id(uint8_t *p, uint64_t id) {
  for (uint8_t i = 0; i < kBoardIdBytes; ++i) p[i] = (uint8_t)(id >> (8 * i));
}
inline uint64_t get_board_id(const uint8_t *p) {
  uint64_t id = 0;
  for (uint8_t i = kBoardIdBytes; i > 0; --i) id = (id << 8) | p[i - 1];
  return id;
}

// One set-period entry: motor index and period (ticks q8, 0 = silent).
struct PeriodEntry {
  uint8_t motor;
  uint32_t period_q8;
};

// Writes one 4-byte entry. The caller keeps motor < kMaxMotors and period <= kPeriodQ8Max.
inline void put_entry(uint8_t *p, uint8_t motor, uint32_t period_q8) {
  p[0] = (uint8_t)(kSetPeriodFlag | ((motor & 7u) << 4) | ((period_q8 >> 24) & 0x0Fu));
  p[1] = (uint8_t)period_q8;
  p[2] = (uint8_t)(period_q8 >> 8);
  p[3] = (uint8_t)(period_q8 >> 16);
}

// Reads one 4-byte entry; false when the first byte lacks the set-period flag.
inline bool get_entry(const uint8_t *p, PeriodEntry *out) {
  if (!(p[0] & kSetPeriodFlag)) return false;
  out->motor = (uint8_t)((p[0] >> 4) & 7u);
  out->period_q8 = ((uint32_t)(p[0] & 0x0Fu) << 24) | ((uint32_t)p[3] << 16) |
                   ((uint32_t)p[2] << 8) | p[1];
  return true;
}

// kMsgDriver and kMsgDriverAct payloads, type byte included, field by field (the one encoder
// and parser of both ends). put_* write 1 + sizeof body bytes and return that count; get_*
// read a payload of len bytes (type byte included) and return false when len does not fit.
inline uint8_t put_driver(uint8_t *p, const DriverBody &b) {
  p[0] = kMsgDriver;
  p[1] = b.motor;
  p[2] = (uint8_t)b.sleep_pin;
  p[3] = (uint8_t)b.reset_pin;
  p[4] = b.idle;
  put_u16(p + 5, b.idle_ms);
  put_u16(p + 7, b.wake_us);
  return 1 + sizeof(DriverBody);
}
inline bool get_driver(const uint8_t *p, uint8_t len, DriverBody *out) {
  if (len != 1 + sizeof(DriverBody)) return false;
  out->motor = p[1];
  out->sleep_pin = (int8_t)p[2];
  out->reset_pin = (int8_t)p[3];
  out->idle = p[4];
  out->idle_ms = get_u16(p + 5);
  out->wake_us = get_u16(p + 7);
  return true;
}
inline uint8_t put_driver_act(uint8_t *p, const DriverActBody &b) {
  p[0] = kMsgDriverAct;
  p[1] = b.motor;
  p[2] = b.action;
  return 1 + sizeof(DriverActBody);
}
inline bool get_driver_act(const uint8_t *p, uint8_t len, DriverActBody *out) {
  if (len != 1 + sizeof(DriverActBody)) return false;
  out->motor = p[1];
  out->action = p[2];
  return true;
}

// kMsgMove, kMsgMoveDone and kMsgSetPosition payloads, type byte included, as put_driver and
// get_driver above.
inline uint8_t put_move(uint8_t *p, const MoveBody &b) {
  p[0] = kMsgMove;
  p[1] = b.motor;
  p[2] = b.flags;
  put_u32(p + 3, b.steps);
  put_u16(p + 7, b.speed_min);
  put_u16(p + 9, b.speed_max);
  put_u32(p + 11, b.accel);
  return 1 + sizeof(MoveBody);
}
inline bool get_move(const uint8_t *p, uint8_t len, MoveBody *out) {
  if (len != 1 + sizeof(MoveBody)) return false;
  out->motor = p[1];
  out->flags = p[2];
  out->steps = get_u32(p + 3);
  out->speed_min = get_u16(p + 7);
  out->speed_max = get_u16(p + 9);
  out->accel = get_u32(p + 11);
  return true;
}
inline uint8_t put_move_done(uint8_t *p, const MoveDoneBody &b) {
  p[0] = kMsgMoveDone;
  p[1] = b.motor;
  p[2] = b.end;
  put_u32(p + 3, (uint32_t)b.position);
  put_u32(p + 7, b.steps);
  return 1 + sizeof(MoveDoneBody);
}
inline bool get_move_done(const uint8_t *p, uint8_t len, MoveDoneBody *out) {
  if (len != 1 + sizeof(MoveDoneBody)) return false;
  out->motor = p[1];
  out->end = p[2];
  out->position = (int32_t)get_u32(p + 3);
  out->steps = get_u32(p + 7);
  return true;
}
inline uint8_t put_set_position(uint8_t *p, const SetPositionBody &b) {
  p[0] = kMsgSetPosition;
  p[1] = b.motor;
  put_u32(p + 2, (uint32_t)b.position);
  return 1 + sizeof(SetPositionBody);
}
inline bool get_set_position(const uint8_t *p, uint8_t len, SetPositionBody *out) {
  if (len != 1 + sizeof(SetPositionBody)) return false;
  out->motor = p[1];
  out->position = (int32_t)get_u32(p + 2);
  return true;
}

// ---------------------------------------------------------------------------------------------
// Frame encoder: payload -> COBS(payload + CRC) + delimiter.
// ---------------------------------------------------------------------------------------------

// Bytes on the wire for a payload of len bytes (len <= kMaxPayload).
inline uint8_t frame_wire_size(uint8_t len) { return (uint8_t)(len + kCrcBytes + 2); }

// Encodes payload[0..len) into out (room for frame_wire_size(len) bytes). Returns the byte
// count written, or 0 when len is 0 or above kMaxPayload. Payloads stay below 254 bytes, so
// COBS needs exactly one code byte and no block splits.
inline uint8_t encode_frame(const uint8_t *payload, uint8_t len, uint8_t *out) {
  if (len == 0 || len > kMaxPayload) return 0;
  uint16_t crc = crc16(payload, len);
  uint8_t code_at = 0, n = 1, code = 1;
  const uint8_t total = (uint8_t)(len + kCrcBytes);
  for (uint8_t i = 0; i < total; ++i) {
    uint8_t b = i < len ? payload[i] : (i == len ? (uint8_t)crc : (uint8_t)(crc >> 8));
    if (b == 0) {
      out[code_at] = code;
      code_at = n++;
      code = 1;
    } else {
      out[n++] = b;
      ++code;
    }
  }
  out[code_at] = code;
  out[n++] = kDelimiter;
  return n;
}

// ---------------------------------------------------------------------------------------------
// Frame decoder: a byte-at-a-time state machine, the same code in the firmware and the host.
// ---------------------------------------------------------------------------------------------
//
// Feed every received byte to push(). It returns kFrameNone while a frame is in progress,
// kFrameOk when a frame ended with a valid CRC (payload() / payload_len() hold it until the
// next push), or the ErrorCode of a frame that ended badly. After garbage the decoder is back
// in step at the next delimiter: the worst case loses the one frame whose bytes followed the
// garbage without a delimiter between them.
//
// COBS and the CRC are undone a byte at a time as the bytes arrive (the CRC trails the decoded
// bytes by two: the last two are the frame's CRC), so the delimiter only compares and the
// frame is ready as soon as its last byte is in (bench/results/onset-latency.md).
static const uint8_t kFrameNone = 0xFF;
static const uint8_t kFrameOk = 0;

class FrameDecoder {
 public:
  FrameDecoder() : n_(0), out_(0), left_(0), overflow_(false), len_(0), crc_(kCrcInit) {}

  // Called from: firmware main loop / host reader thread. Does not allocate or block.
  // Always inlined: on the AVR the call alone cost a third of a byte's work.
  __attribute__((always_inline)) uint8_t push(uint8_t byte) {
    if (byte != kDelimiter) {  // fields read once into locals: the stores to buf_ may alias them
      const uint8_t n = n_;
      if (n >= sizeof(buf_)) {
        overflow_ = true;
        return kFrameNone;
      }
      n_ = (uint8_t)(n + 1);
      const uint8_t left = left_;
      if (left != 0) {  // a data byte of the current COBS block
        left_ = (uint8_t)(left - 1);
        emit(byte);
      } else {          // a code byte: the block before it (if any) ended in a zero
        left_ = (uint8_t)(byte - 1);
        if (n != 0) emit(0);
      }
      return kFrameNone;
    }
    const uint8_t n = n_, out = out_, left = left_;
    const bool overflow = overflow_;
    const uint16_t crc = crc_;
    n_ = 0;
    out_ = 0;
    left_ = 0;
    overflow_ = false;
    crc_ = kCrcInit;
    len_ = 0;
    if (overflow) return kErrFrameTooLong;
    if (n == 0) return kFrameNone;  // idle delimiters are allowed (the host sends one to resync)
    if (left != 0) return kErrCobs;  // a code byte promised more bytes than came
    if (out < 1 + kCrcBytes) return kErrShortFrame;
    const uint8_t len = (uint8_t)(out - kCrcBytes);
    if (crc != get_u16(buf_ + len)) return kErrCrc;
    len_ = len;
    return kFrameOk;
  }

  const uint8_t *payload() const { return buf_; }
  uint8_t payload_len() const { return len_; }
  // True between a frame's first byte and its delimiter.
  bool in_frame() const { return n_ != 0; }

 private:
  // Called from: push. Stores one decoded byte and folds the one two places back into the CRC.
  __attribute__((always_inline)) void emit(uint8_t b) {
    const uint8_t out = out_;
    if (out >= kCrcBytes) crc_ = crc16_update(crc_, buf_[out - kCrcBytes]);
    out_ = (uint8_t)(out + 1);
    buf_[out] = b;
  }

  uint8_t buf_[kMaxFrameWire - 1];  // decoded bytes of the frame so far (payload, then CRC)
  uint8_t n_;        // COBS bytes of this frame so far, without its delimiter
  uint8_t out_;      // decoded bytes in buf_
  uint8_t left_;     // data bytes still due in the current COBS block
  bool overflow_;
  uint8_t len_;
  uint16_t crc_;     // CRC of buf_[0 .. out_ - kCrcBytes)
};

}  // namespace sc

#endif  // STEPCHOIR_PROTOCOL_H
