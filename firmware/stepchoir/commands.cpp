// commands.cpp: decodes frames and runs one handler per message type (see commands.h).
#include "commands.h"

#include <string.h>

namespace cmd {

using namespace sc;

void Commands::init() {
  for (uint8_t m = 0; m < kMaxMotors; ++m) limits_[m] = {kPeriodQ8Min, kPeriodQ8Max};
  watchdog_ticks_ = ms_to_ticks(cfg::kWatchdogDefaultMs, F_CPU);
  last_frame_ticks_ = hal::now_ticks();
}

__attribute__((noinline)) void Commands::on_frame(uint8_t rc) {
  if (rc != kFrameOk) {
    ++frames_bad_;
    fault(rc);
    return;
  }
  const uint8_t type = decoder_.payload()[0];
  if (handle(decoder_.payload(), decoder_.payload_len()) != kErrNone) {
    ++frames_bad_;  // refused frames neither count as good nor feed the watchdog
    return;
  }
  ++frames_ok_;
  frame_seen_ = true;  // poll() restarts the watchdog from its own clock reading
  // The watchdog flag stays up for the status replies until music is sent again.
  if ((type & kSetPeriodFlag) || type == kMsgAt || type == kMsgResetCounters) watchdog_tripped_ = false;
}

// Checks one set-period entry against the board and the motor's configured range.
uint8_t Commands::check_entry(const PeriodEntry &e) const {
  if (e.motor >= hal::motor_count()) return kErrMotor;
  if (hal::moving() & (1u << e.motor)) return kErrBusy;
  if (e.period_q8 == kPeriodSilent) return kErrNone;
  const MotorLimits &l = limits_[e.motor];
  if (e.period_q8 < l.min_period_q8 || e.period_q8 > l.max_period_q8) return kErrPeriodRange;
  return kErrNone;
}

// A frame of set-period entries: all are checked first, then all applied (a chord is all or
// nothing, so a bad entry never leaves half a chord sounding).
uint8_t Commands::handle_periods(const uint8_t *p, uint8_t len) {
  if (len % kSetPeriodBytes != 0) return kErrLength;
  PeriodEntry e;
  for (uint8_t i = 0; i < len; i = (uint8_t)(i + kSetPeriodBytes)) {
    if (!get_entry(p + i, &e)) return kErrLength;
    const uint8_t rc = check_entry(e);
    if (rc != kErrNone) return rc;
  }
  if (len == kSetPeriodBytes) {  // one note, the live case: decoded already (63 cycles sooner)
    hal::set_period(e.motor, e.period_q8);
    return kErrNone;
  }
  for (uint8_t i = 0; i < len; i = (uint8_t)(i + kSetPeriodBytes)) {
    get_entry(p + i, &e);
    hal::set_period(e.motor, e.period_q8);
  }
  return kErrNone;
}

// kMsgAt: u32 board time, then entries; queued in arrival order (the host sends in time order)
// for the motors' channels, each one made exactly on its time.
uint8_t Commands::handle_at(const uint8_t *p, uint8_t len) {
  if (len < 4 + kSetPeriodBytes || (len - 4) % kSetPeriodBytes != 0) return kErrLength;
  const uint32_t at = get_u32(p);
  PeriodEntry e;
  for (uint8_t i = 4; i < len; i = (uint8_t)(i + kSetPeriodBytes)) {
    if (!get_entry(p + i, &e)) return kErrLength;
    const uint8_t rc = check_entry(e);
    if (rc != kErrNone) return rc;
  }
  if (hal::queue_used() + (len - 4) / kSetPeriodBytes > cfg::kQueueSize) return kErrQueueFull;
  for (uint8_t i = 4; i < len; i = (uint8_t)(i + kSetPeriodBytes)) {
    get_entry(p + i, &e);
    hal::queue_at(e.motor, e.period_q8, at);
  }
  return kErrNone;
}

// kMsgConfig: range checks here, driver-specific checks in hal::configure.
uint8_t Commands::handle_config(const uint8_t *p, uint8_t len) {
  if (len != sizeof(ConfigBody)) return kErrLength;
  ConfigBody c;
  memcpy(&c, p, sizeof c);
  if (c.motor >= hal::motor_count()) return kErrMotor;
  if (hal::moving() & (1u << c.motor)) return kErrBusy;
  if (c.driver > kDriverTb6600 || c.endstop_active_high > 1) return kErrConfig;
  if (c.pulse_us < cfg::kPulseUsMin || c.pulse_us > cfg::kPulseUsMax) return kErrConfig;
  if (c.min_period_q8 < kPeriodQ8Min || c.max_period_q8 > kPeriodQ8Max ||
      c.min_period_q8 > c.max_period_q8)
    return kErrConfig;
  if (c.start_period_q8 != 0 && (c.start_period_q8 > kPeriodQ8Max || c.accel_q8 == 0 || c.accel_q8 > kPeriodQ8Max))
    return kErrConfig;
  if (c.travel_steps > kMaxTravelSteps) return kErrConfig;
  const uint8_t rc = hal::configure(c);
  if (rc != kErrNone) return rc;
  limits_[c.motor] = {c.min_period_q8, c.max_period_q8};
  return kErrNone;
}

// kMsgMove (p: the whole payload): the body's ranges, then a silent motor that does not move
// and no timed entry waiting (it could start the motor meanwhile).
uint8_t Commands::handle_move(const uint8_t *p, uint8_t len) {
  MoveBody b;
  if (!get_move(p, len, &b)) return kErrLength;
  if (b.motor >= hal::motor_count()) return kErrMotor;
  if ((b.flags & ~(kMoveUp | kMoveToSwitch)) || b.steps == 0 || b.steps > kMaxTravelSteps ||
      b.speed_min < kMoveSpeedMin || b.speed_max > kMoveSpeedMax || b.speed_min > b.speed_max || b.accel == 0 ||
      b.accel > kMoveAccelMax)
    return kErrConfig;
  if (((hal::moving() | hal::sounding()) & (1u << b.motor)) || hal::queue_used() != 0) return kErrBusy;
  hal::move(b);
  return kErrNone;
}

// kMsgSetPosition (p: the whole payload).
uint8_t Commands::handle_set_position(const uint8_t *p, uint8_t len) {
  SetPositionBody b;
  if (!get_set_position(p, len, &b)) return kErrLength;
  if (b.motor >= hal::motor_count()) return kErrMotor;
  if (hal::moving() & (1u << b.motor)) return kErrBusy;
  hal::set_position(b.motor, b.position);
  return kErrNone;
}

// kMsgDriver (p: the whole payload): length and motor here, the values against the board in
// hal::configure_driver.
uint8_t Commands::handle_driver(const uint8_t *p, uint8_t len) {
  DriverBody b;
  if (!get_driver(p, len, &b)) return kErrLength;
  if (b.motor >= hal::motor_count()) return kErrMotor;
  return hal::configure_driver(b);
}

// kMsgDriverAct (p: the whole payload).
uint8_t Commands::handle_driver_act(const uint8_t *p, uint8_t len) {
  DriverActBody b;
  if (!get_driver_act(p, len, &b)) return kErrLength;
  if (b.motor >= hal::motor_count()) return kErrMotor;
  if (hal::moving()) return kErrBusy;  // (a disable may reach every motor on a shared ENABLE)
  return hal::driver_act(b.motor, b.action);
}

uint8_t Commands::handle(const uint8_t *p, uint8_t len) {
  const uint8_t type = p[0];
  uint8_t rc = kErrNone;
  if (type & kSetPeriodFlag) {
    rc = handle_periods(p, len);
  } else {
    const uint8_t *body = p + 1;
    const uint8_t n = (uint8_t)(len - 1);
    switch (type) {
      case kMsgHello:
        if (n != 0) { rc = kErrLength; break; }
        reply_caps(0);
        break;
      case kMsgConfig:
        rc = handle_config(body, n);
        break;
      case kMsgHeartbeat:
        if (n != 0) rc = kErrLength;
        break;
      case kMsgStopAll:
        hal::stop_all();  // a panic is obeyed even if the frame is oddly long, the queue emptied
        if (n != 0) rc = kErrLength;
        break;
      case kMsgStatusReq:
        if (n != 0) { rc = kErrLength; break; }
        reply_status();
        break;
      case kMsgClockReq:
        if (n != 1) { rc = kErrLength; break; }
        reply_clock(body[0]);
        break;
      case kMsgAt:
        rc = handle_at(body, n);
        break;
      case kMsgWatchdog:
        if (n != 2) { rc = kErrLength; break; }
        if (get_u16(body) != 0 && get_u16(body) < kWatchdogMinMs) { rc = kErrConfig; break; }
        watchdog_ticks_ = ms_to_ticks(get_u16(body), F_CPU);
        break;
      case kMsgDriver:
        rc = handle_driver(p, len);
        break;
      case kMsgDriverAct:
        rc = handle_driver_act(p, len);
        break;
      case kMsgIdReq:
        if (n != 0) { rc = kErrLength; break; }
        reply_id();
        break;
      case kMsgSetId:
        rc = handle_set_id(body, n);
        break;
      case kMsgMove:
        rc = handle_move(p, len);
        break;
      case kMsgSetPosition:
        rc = handle_set_position(p, len);
        break;
      case kMsgSilence:
        if (n != 1) { rc = kErrLength; break; }
        if (body[0] >> hal::motor_count()) { rc = kErrMotor; break; }
        hal::silence(body[0]);
        break;
      case kMsgResetCounters:
        if (n != 0) { rc = kErrLength; break; }
        frames_ok_ = 0;
        frames_bad_ = 0;
        last_error_ = 0;
        hal::reset_step_counters();
        hal::reset_uart_overruns();
        break;
      default:
        rc = kErrUnknownType;
        break;
    }
  }
  if (rc != kErrNone) {
    fault(rc);
    reply_error(rc, type, 0);
  }
  return rc;
}

void Commands::poll() {
  const uint32_t now = hal::now_ticks();
  if (frame_seen_) {
    frame_seen_ = false;
    last_frame_ticks_ = now;
  }
  const uint16_t overruns = hal::uart_overruns();
  if (overruns != seen_overruns_) {
    seen_overruns_ = overruns;
    if (overruns) fault(kErrUartOverrun);
  }
  // Timestamped entries taken after their time (made at once): the host
  // counts these replies, its lead was too short.
  uint8_t motor;
  const uint8_t late = hal::late_entries(&motor);
  if (late != seen_late_) {
    seen_late_ = late;
    fault(kErrLate);
    reply_error(kErrLate, kMsgAt, motor);
  }
  if (watchdog_ticks_ != 0 && !watchdog_tripped_ && now - last_frame_ticks_ > watchdog_ticks_) {
    watchdog_tripped_ = true;
    hal::stop_all();
    fault(kErrWatchdog);
  }
  MoveDoneBody done;
  if (hal::moving() && hal::move_ended(&done)) {
    uint8_t buf[1 + sizeof done];
    hal::send(buf, put_move_done(buf, done));
  }
}

namespace {

// True when all kBoardIdBytes of an id are v (0x00: none set; 0xFF: an erased EEPROM).
bool id_all(const uint8_t *id, uint8_t v) {
  for (uint8_t i = 0; i < kBoardIdBytes; ++i)
    if (id[i] != v) return false;
  return true;
}

}  // namespace

// kMsgSetId: keeps the host's id for this board in EEPROM (written only where it changes).
uint8_t Commands::handle_set_id(const uint8_t *body, uint8_t n) {
  if (n != kBoardIdBytes) return kErrLength;
  if (id_all(body, 0x00) || id_all(body, 0xFF)) return kErrConfig;
  hal::eeprom_write(kEepromIdAddr, body, kBoardIdBytes);
  reply_id();
  return kErrNone;
}

// kMsgId: the id in EEPROM; all zero when none was set.
void Commands::reply_id() {
  uint8_t buf[1 + kBoardIdBytes];
  buf[0] = kMsgId;
  hal::eeprom_read(kEepromIdAddr, buf + 1, kBoardIdBytes);
  if (id_all(buf + 1, 0xFF)) memset(buf + 1, 0, kBoardIdBytes);
  hal::send(buf, sizeof buf);
}

void Commands::reply_caps(uint8_t flags) {
  uint8_t buf[kMaxPayload];
  buf[0] = kMsgCaps;
  CapsBody c;
  memset(&c, 0, sizeof c);
  c.protocol_version = kProtocolVersion;
  c.motor_count = hal::motor_count();
  c.f_cpu_hz = F_CPU;
  c.queue_size = cfg::kQueueSize;
  for (uint8_t m = 0; m < c.motor_count && m < sizeof c.endstops; ++m) c.endstops[m] = hal::endstops(m);
  c.flags = flags;
  memcpy(buf + 1, &c, sizeof c);
  uint8_t n = (uint8_t)(1 + sizeof c);
  for (const char *s = hal::board_name(); *s && n < kMaxPayload; ++s) buf[n++] = (uint8_t)*s;
  hal::send(buf, n);
}

void Commands::reply_status() {
  uint8_t buf[kMaxPayload];
  buf[0] = kMsgStatus;
  StatusHead h;
  h.frames_ok = frames_ok_;
  h.frames_bad = frames_bad_;
  h.uart_overruns = hal::uart_overruns();
  h.reversals = 0;  // the motors' below, summed (wrapping as they do)
  h.late_edges = hal::late_edges();
  h.queue_used = hal::queue_used();
  const uint8_t motor_fault = hal::last_motor_fault();
  h.last_error = motor_fault ? motor_fault : last_error_;
  h.motor_count = hal::motor_count();
  h.flags = (uint8_t)((watchdog_tripped_ ? kStatusWatchdogTripped : 0) |
                      (hal::drivers_enabled() ? kStatusDriversEnabled : 0));
  uint8_t n = (uint8_t)(1 + sizeof h);
  for (uint8_t m = 0; m < h.motor_count; ++m) {
    StatusMotor s;
    hal::motor_status(m, &s);
    h.reversals = (uint16_t)(h.reversals + s.reversals);
    memcpy(buf + n, &s, sizeof s);
    n = (uint8_t)(n + sizeof s);
  }
  memcpy(buf + 1, &h, sizeof h);
  hal::send(buf, n);
}

void Commands::reply_clock(uint8_t seq) {
  uint8_t buf[6];
  buf[0] = kMsgClock;
  buf[1] = seq;
  put_u32(buf + 2, hal::now_ticks());
  hal::send(buf, sizeof buf);
}

void Commands::reply_error(uint8_t code, uint8_t type, uint8_t detail) {
  const uint8_t buf[4] = {kMsgError, code, type, detail};
  hal::send(buf, sizeof buf);
}

}  // namespace cmd
