// live_fakes.h: what the live path's test files share: a Link that records every frame, the
// set-period entries among them, and a bounded wait for a condition.
#ifndef STEPCHOIR_TESTS_LIVE_FAKES_H
#define STEPCHOIR_TESTS_LIVE_FAKES_H

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "board/link.h"
#include "live/rt_guard.h"
#include "stepchoir_protocol.h"

namespace stepchoir::live_test {

// A Link that keeps every byte written; reads return what the test had the board say
// (board_says), else time out with nothing. While closed, writes
// wait: a link slower than anything the test sends. With `direct`, try_write takes a frame at
// once while open and refuses it while closed (like a port whose OS buffer is full); without,
// it always refuses (a link that cannot tell).
class FakeLink : public Link {
 public:
  explicit FakeLink(bool direct = false) : direct_(direct) {}
  bool try_write(const uint8_t *data, size_t len) override {
    const bool rt = in_rt_scope();
    RtExempt exempt;  // the recording allocates; a real link's write does not
    std::lock_guard<std::mutex> lock(mu_);
    count_scope(rt);
    if (!direct_ || !open_) return false;
    bytes_.insert(bytes_.end(), data, data + len);
    return true;
  }
  bool write(const uint8_t *data, size_t len) override {
    const bool rt = in_rt_scope();
    RtExempt exempt;  // the recording allocates; a real link's write does not
    std::unique_lock<std::mutex> lock(mu_);
    count_scope(rt);
    opened_.wait(lock, [this] { return open_; });
    bytes_.insert(bytes_.end(), data, data + len);
    return true;
  }
  // Called from: the test. Holds writes back (close) or lets them through (open).
  void set_open(bool open) {
    std::lock_guard<std::mutex> lock(mu_);
    open_ = open;
    opened_.notify_all();
  }
  // The bytes the board says (board_says), else nothing within the timeout.
  long read(uint8_t *data, size_t len, int timeout_ms) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!said_.empty()) {
        const size_t n = std::min(len, said_.size());
        std::copy(said_.begin(), said_.begin() + static_cast<long>(n), data);
        said_.erase(said_.begin(), said_.begin() + static_cast<long>(n));
        return static_cast<long>(n);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::min(timeout_ms, 5)));
    return 0;
  }
  // Called from: the test. Bytes for the next reads, as if the board sent them.
  void board_says(const std::vector<uint8_t> &bytes) {
    std::lock_guard<std::mutex> lock(mu_);
    said_.insert(said_.end(), bytes.begin(), bytes.end());
  }
  std::string name() const override { return "fake"; }
  // Writes from threads other than the one that made the link (the session's engine and
  // writer), inside and outside a real-time scope.
  std::pair<int, int> thread_writes() {
    std::lock_guard<std::mutex> lock(mu_);
    return {rt_writes_, other_writes_};
  }
  // Every frame written so far, decoded (payloads).
  std::vector<std::vector<uint8_t>> frames() {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<std::vector<uint8_t>> out;
    sc::FrameDecoder dec;
    for (uint8_t b : bytes_)
      if (dec.push(b) == sc::kFrameOk) out.emplace_back(dec.payload(), dec.payload() + dec.payload_len());
    return out;
  }

 private:
  bool direct_;
  bool open_ = true;
  std::condition_variable opened_;
  std::mutex mu_;
  std::vector<uint8_t> bytes_;
  std::vector<uint8_t> said_;
  const std::thread::id maker_ = std::this_thread::get_id();
  int rt_writes_ = 0, other_writes_ = 0;
  void count_scope(bool rt) {  // mu_ held
    if (std::this_thread::get_id() != maker_) ++(rt ? rt_writes_ : other_writes_);
  }
};

// The set-period entries among payloads, in wire order.
inline std::vector<sc::PeriodEntry> entries_of(const std::vector<std::vector<uint8_t>> &frames) {
  std::vector<sc::PeriodEntry> out;
  for (const auto &f : frames) {
    if (!(f[0] & sc::kSetPeriodFlag)) continue;
    for (size_t i = 0; i + sc::kSetPeriodBytes <= f.size(); i += sc::kSetPeriodBytes) {
      sc::PeriodEntry e;
      REQUIRE(sc::get_entry(&f[i], &e));
      out.push_back(e);
    }
  }
  return out;
}

// Periods motor m got, in order.
inline std::vector<uint32_t> periods_of(const std::vector<sc::PeriodEntry> &entries, uint8_t m) {
  std::vector<uint32_t> out;
  for (const auto &e : entries)
    if (e.motor == m) out.push_back(e.period_q8);
  return out;
}

// Waits up to 10 s for cond; true when it held.
template <class F>
bool eventually(F cond) {
  for (int i = 0; i < 1000; ++i) {
    if (cond()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return cond();
}

}  // namespace stepchoir::live_test

#endif  // STEPCHOIR_TESTS_LIVE_FAKES_H
