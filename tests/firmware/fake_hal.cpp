// fake_hal.cpp: a recording hal for host-side tests of the firmware's command layer.
#include "fake_hal.h"

FakeHal g_hal;

namespace hal {
uint8_t motor_count() { return g_hal.motors; }
uint8_t endstops(uint8_t m) { return m < 3 ? (sc::kEndstopMin | sc::kEndstopMax | sc::kEndstopShared) : 0; }
const char *board_name() { return "uno_cnc_shield_v3"; }
uint32_t now_ticks() { return g_hal.now; }
void set_period(uint8_t m, uint32_t p) { g_hal.calls.push_back({FakeHal::kSet, m, p, 0}); g_hal.period[m] = p; }
uint8_t queue_used() { return g_hal.queued; }
void queue_at(uint8_t m, uint32_t p, uint32_t at) {
  g_hal.calls.push_back({FakeHal::kQueued, m, p, at});
  ++g_hal.queued;
}
uint8_t late_entries(uint8_t *motor) {
  *motor = g_hal.late_motor;
  return g_hal.late;
}
void stop_all() {
  g_hal.calls.push_back({FakeHal::kStop, 0, 0, 0});
  for (auto &p : g_hal.period) p = 0;
  g_hal.queued = 0;
}
void silence(uint8_t mask) {
  g_hal.calls.push_back({FakeHal::kSilence, mask, 0, 0});
  for (size_t m = 0; m < g_hal.period.size(); ++m)
    if (mask & (1u << m)) g_hal.period[m] = 0;
}
uint8_t configure(const sc::ConfigBody &c) {
  g_hal.configs.push_back(c);
  return c.microsteps == 32 && c.driver == sc::kDriverA4988 ? sc::kErrConfig : sc::kErrNone;
}
uint8_t configure_driver(const sc::DriverBody &b) {
  g_hal.drivers.push_back(b);
  return g_hal.driver_rc;
}
uint8_t driver_act(uint8_t m, uint8_t action) {
  g_hal.acts.push_back({m, action});
  return g_hal.driver_rc;
}
void move(const sc::MoveBody &b) {
  g_hal.moves.push_back(b);
  g_hal.moving |= static_cast<uint8_t>(1u << b.motor);
}
uint8_t moving() { return g_hal.moving; }
bool move_ended(sc::MoveDoneBody *out) {
  if (g_hal.ended.empty()) return false;
  *out = g_hal.ended.front();
  g_hal.ended.erase(g_hal.ended.begin());
  g_hal.moving &= static_cast<uint8_t>(~(1u << out->motor));
  return true;
}
void set_position(uint8_t m, int32_t position) { g_hal.position.at(m) = position; }
uint8_t sounding() {
  uint8_t bits = 0;
  for (size_t m = 0; m < g_hal.period.size(); ++m)
    if (g_hal.period[m]) bits |= static_cast<uint8_t>(1u << m);
  return bits;
}
void motor_status(uint8_t m, sc::StatusMotor *out) {
  out->position_steps = 100 * m;
  out->flags = g_hal.period[m] ? sc::kMotorSounding : 0;
  out->reversals = g_hal.reversals[m];
}
uint16_t late_edges() { return 0; }
uint8_t last_motor_fault() { return 0; }
bool drivers_enabled() { return true; }
void reset_step_counters() { g_hal.reversals.fill(0); }
uint16_t uart_overruns() { return 0; }
void reset_uart_overruns() {}
void send(const uint8_t *payload, uint8_t len) {
  uint8_t buf[sc::kMaxFrameWire];
  const uint8_t n = sc::encode_frame(payload, len, buf);
  g_hal.sent.insert(g_hal.sent.end(), buf, buf + n);
  g_hal.replies.emplace_back(payload, payload + len);
}
void eeprom_read(uint16_t addr, uint8_t *out, uint8_t len) {
  for (uint8_t i = 0; i < len; ++i) out[i] = g_hal.eeprom.at(addr + i);
}
void eeprom_write(uint16_t addr, const uint8_t *data, uint8_t len) {
  ++g_hal.eeprom_writes;
  for (uint8_t i = 0; i < len; ++i) g_hal.eeprom.at(addr + i) = data[i];
}
}  // namespace hal
