// board.cpp: reply decoding and the synchronous board session.
#include "board/board.h"

#include <chrono>
#include <cstddef>
#include <cstring>
#include <stdexcept>

namespace stepchoir {

Caps parse_caps(const uint8_t *p, size_t len) {
  // A board of protocol version 2 or older sends no flags byte: its name follows the endstops
  // (so that `stepchoir doctor` can name a board whose firmware wants updating).
  const size_t body =
      len >= 2 && p[1] < sc::kCapsFlagsSinceVersion ? offsetof(sc::CapsBody, flags) : sizeof(sc::CapsBody);
  if (len < 1 + body || p[0] != sc::kMsgCaps)
    throw std::runtime_error("caps reply: expected at least " + std::to_string(1 + body) +
                             " bytes of type 0x41, got " + std::to_string(len));
  sc::CapsBody c{};
  std::memcpy(&c, p + 1, body);
  Caps out;
  out.protocol_version = c.protocol_version;
  out.motor_count = c.motor_count;
  out.f_cpu_hz = c.f_cpu_hz;
  out.queue_size = c.queue_size;
  if (c.motor_count > sizeof c.endstops) throw std::runtime_error("caps reply: motor count " + std::to_string(c.motor_count) + " > 5");
  out.endstops.assign(c.endstops, c.endstops + c.motor_count);
  out.board_name.assign(reinterpret_cast<const char *>(p) + 1 + body, len - 1 - body);
  return out;
}

Status parse_status(const uint8_t *p, size_t len) {
  if (len < 1 + sizeof(sc::StatusHead) || p[0] != sc::kMsgStatus)
    throw std::runtime_error("status reply: too short (" + std::to_string(len) + " bytes)");
  Status s;
  std::memcpy(&s.head, p + 1, sizeof s.head);
  const size_t need = 1 + sizeof s.head + s.head.motor_count * sizeof(sc::StatusMotor);
  if (len != need)
    throw std::runtime_error("status reply: " + std::to_string(len) + " bytes for " +
                             std::to_string(s.head.motor_count) + " motors, expected " + std::to_string(need));
  for (size_t i = 0; i < s.head.motor_count; ++i) {
    sc::StatusMotor m;
    std::memcpy(&m, p + 1 + sizeof s.head + i * sizeof m, sizeof m);
    s.motors.push_back(m);
  }
  return s;
}

std::vector<uint8_t> frame(const std::vector<uint8_t> &payload) {
  std::vector<uint8_t> out(sc::kMaxFrameWire);
  const uint8_t n = sc::encode_frame(payload.data(), static_cast<uint8_t>(payload.size()), out.data());
  if (n == 0) throw std::invalid_argument("frame: payload of " + std::to_string(payload.size()) + " bytes");
  out.resize(n);
  return out;
}

std::vector<uint8_t> periods_payload(const std::vector<sc::PeriodEntry> &entries) {
  std::vector<uint8_t> p(entries.size() * sc::kSetPeriodBytes);
  for (size_t i = 0; i < entries.size(); ++i) sc::put_entry(&p[i * sc::kSetPeriodBytes], entries[i].motor, entries[i].period_q8);
  return p;
}

std::vector<uint8_t> at_payload(uint32_t at_ticks, const std::vector<sc::PeriodEntry> &entries) {
  std::vector<uint8_t> p{sc::kMsgAt, 0, 0, 0, 0};
  sc::put_u32(&p[1], at_ticks);
  const std::vector<uint8_t> body = periods_payload(entries);
  p.insert(p.end(), body.begin(), body.end());
  return p;
}

std::vector<uint8_t> watchdog_payload(uint16_t ms) {
  std::vector<uint8_t> p{sc::kMsgWatchdog, 0, 0};
  sc::put_u16(&p[1], ms);
  return p;
}

std::vector<uint8_t> config_payload(const sc::ConfigBody &c) {
  std::vector<uint8_t> p(1 + sizeof c);
  p[0] = sc::kMsgConfig;
  std::memcpy(&p[1], &c, sizeof c);
  return p;
}

std::vector<uint8_t> driver_payload(const sc::DriverBody &d) {
  std::vector<uint8_t> p(1 + sizeof d);
  sc::put_driver(p.data(), d);
  return p;
}

std::vector<uint8_t> driver_act_payload(uint8_t motor, uint8_t action) {
  std::vector<uint8_t> p(1 + sizeof(sc::DriverActBody));
  sc::put_driver_act(p.data(), sc::DriverActBody{motor, action});
  return p;
}

std::vector<uint8_t> move_payload(const sc::MoveBody &b) {
  std::vector<uint8_t> p(1 + sizeof(sc::MoveBody));
  sc::put_move(p.data(), b);
  return p;
}

std::vector<uint8_t> set_position_payload(uint8_t motor, int32_t position) {
  std::vector<uint8_t> p(1 + sizeof(sc::SetPositionBody));
  sc::put_set_position(p.data(), sc::SetPositionBody{motor, position});
  return p;
}

std::vector<uint8_t> silence_payload(const std::vector<uint8_t> &motors) {
  uint8_t mask = 0;
  for (uint8_t m : motors) mask = static_cast<uint8_t>(mask | (1u << m));
  return {sc::kMsgSilence, mask};
}

void Board::send(const std::vector<uint8_t> &payload) {
  const auto f = frame(payload);
  if (!link_->write(f.data(), f.size())) throw std::runtime_error(link_->name() + ": write failed");
}

void Board::resync() {
  const uint8_t d = sc::kDelimiter;
  if (!link_->write(&d, 1)) throw std::runtime_error(link_->name() + ": write failed");
}

std::optional<std::vector<uint8_t>> Board::wait_reply(uint8_t type, int timeout_ms) {
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + std::chrono::milliseconds(timeout_ms);
  uint8_t buf[256];
  for (;;) {
    // Bytes left over from an earlier read come first: replies can arrive back to back.
    while (pending_pos_ < pending_.size()) {
      if (decoder_.push(pending_[pending_pos_++]) != sc::kFrameOk) continue;
      const uint8_t *p = decoder_.payload();
      const uint8_t len = decoder_.payload_len();
      if (p[0] == sc::kMsgError && len >= 4) errors_.push_back({p[1], p[2], p[3]});
      if (p[0] == type) return std::vector<uint8_t>(p, p + len);
    }
    pending_.clear();
    pending_pos_ = 0;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - clock::now()).count();
    if (left <= 0) return std::nullopt;
    const long n = link_->read(buf, sizeof buf, static_cast<int>(left));
    if (n < 0) throw std::runtime_error(link_->name() + ": read failed");
    pending_.assign(buf, buf + n);
  }
}

Caps Board::greet(int boot_wait_ms, int hello_timeout_ms) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  for (;;) {
    const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(clock::now() - start).count();
    if (waited >= boot_wait_ms) break;
    auto r = wait_reply(sc::kMsgCaps, static_cast<int>(boot_wait_ms - waited));
    if (!r) break;
    // Capabilities sooner than any bootloader lets the firmware start were sent before the
    // open (a USB bridge still held them): the board may be resetting now.
    if (clock::now() - start >= std::chrono::milliseconds(kStaleMs)) return parse_caps(r->data(), r->size());
  }
  return hello(hello_timeout_ms);
}

Caps Board::hello(int timeout_ms) {
  resync();
  for (int attempt = 0; attempt < 3; ++attempt) {
    send({sc::kMsgHello});
    if (auto r = wait_reply(sc::kMsgCaps, timeout_ms / 3 + 1)) return parse_caps(r->data(), r->size());
  }
  throw std::runtime_error(link_->name() + ": no answer to hello (is the firmware running at " +
                           std::to_string(sc::kBaud) + " baud?)");
}

std::optional<Status> Board::status(int timeout_ms) {
  send({sc::kMsgStatusReq});
  if (auto r = wait_reply(sc::kMsgStatus, timeout_ms)) return parse_status(r->data(), r->size());
  return std::nullopt;
}

}  // namespace stepchoir
