// command_feed.h: a fresh command layer on the fake board, and frames fed to it as the main
// loop feeds received bytes. Used by the command layer's tests (test_commands.cpp,
// test_commands_timing.cpp, test_commands_motors.cpp).
#ifndef STEPCHOIR_TESTS_COMMAND_FEED_H
#define STEPCHOIR_TESTS_COMMAND_FEED_H

#include <cstdint>
#include <vector>

#include "commands.h"
#include "fake_hal.h"

// A fresh command layer on a fresh fake board.
inline cmd::Commands &fresh() {
  static cmd::Commands c;
  g_hal.reset();
  c = cmd::Commands();
  c.init();
  return c;
}

// Feeds bytes one at a time, as the main loop does.
inline void feed(cmd::Commands &c, const std::vector<uint8_t> &bytes) {
  for (uint8_t b : bytes) c.on_byte(b);
}

// Encodes a payload as the host would.
inline std::vector<uint8_t> wire(const std::vector<uint8_t> &payload) {
  std::vector<uint8_t> out(sc::kMaxFrameWire);
  out.resize(sc::encode_frame(payload.data(), uint8_t(payload.size()), out.data()));
  return out;
}

// Feeds one `at` frame: motor m to period p at board time t.
inline void feed_at(cmd::Commands &c, uint32_t t, uint8_t m, uint32_t p) {
  std::vector<uint8_t> pl(9);
  pl[0] = sc::kMsgAt;
  sc::put_u32(&pl[1], t);
  sc::put_entry(&pl[5], m, p);
  feed(c, wire(pl));
}

#endif  // STEPCHOIR_TESTS_COMMAND_FEED_H
