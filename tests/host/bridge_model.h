// bridge_model.h: clock round trips over a model of the Uno R3's USB link, and a rate error
// in cents, for the clock fit's and the timeline's unit tests (test_player.cpp, test_timeline.cpp).
#ifndef STEPCHOIR_TESTS_HOST_BRIDGE_MODEL_H
#define STEPCHOIR_TESTS_HOST_BRIDGE_MODEL_H

#include <cmath>
#include <cstdint>
#include <functional>
#include <random>

#include "player/clock_sync.h"

namespace stepchoir {

// Round trips over a model of the Uno R3's USB link (docs/usb-bridges.md): the request waits
// for the host's next 1 ms USB frame; the board stamps it as its 6 bytes arrive; the reply
// waits in the 16U2 until its 4.096 ms timer (on its own crystal, 60 ppm off) flushes it,
// then for the next frame, then for the host's scheduler (up to 0.3 ms). The board's clock
// runs ppm off and falls behind (a stalled simulation) by lag_us(t) at host time t.
struct BridgeModel {
  double ppm = 0;
  std::function<double(double)> lag_us = [](double) { return 0.0; };
  std::mt19937 rng{9};

  double frame_phase_us = 370;  // where the host's 1 ms USB frames start

  // A byte on the board's UART: the 16U2 hands host bytes on 15.3 us apart, and the board's
  // replies go at 1,000,000 baud, 10 us a byte (docs/usb-bridges.md).
  static constexpr double kHostByteUs = 15.3, kBoardByteUs = 10.0;
  // From a frame's start to the board's stamp of the request it carries: its 6 bytes.
  static double stamp_after_frame_us() { return 6 * kHostByteUs; }

  // The board's ticks (unwrapped) at host time t_us, its clock not behind, and back.
  double board_ticks(double t_us) const { return 7e8 + t_us * 16.0 * (1 + ppm / 1e6); }
  double host_us(double ticks) const { return (ticks - 7e8) / (16.0 * (1 + ppm / 1e6)); }

  // One round trip sent at host time send_us: fed to sync; false when sync refused it.
  bool round_trip(ClockSync &sync, double send_us) {
    std::uniform_real_distribution<double> sched(0, 300);
    const double flush_period_us = 4096 * (1 + 60e-6);
    const double out = std::ceil((send_us - frame_phase_us) / 1000) * 1000 + frame_phase_us;
    const double stamp = out + stamp_after_frame_us();
    const double ready = stamp + 6 * kBoardByteUs;  // the 6-byte reply
    const double flush = std::ceil(ready / flush_period_us) * flush_period_us;
    const double in = std::ceil((flush - frame_phase_us) / 1000) * 1000 + frame_phase_us;
    const double recv = in + sched(rng);
    const double board_us = stamp - lag_us(stamp);
    const uint32_t ticks = static_cast<uint32_t>(static_cast<uint64_t>(std::llround(board_ticks(board_us))) & 0xffffffffu);
    return sync.add(static_cast<uint64_t>(send_us), static_cast<uint64_t>(recv), ticks);
  }
};

// A note's error in cents for a rate error in ppm.
inline double cents_of_ppm(double ppm_error) { return 1200 * std::log2(1 + ppm_error / 1e6); }

}  // namespace stepchoir

#endif  // STEPCHOIR_TESTS_HOST_BRIDGE_MODEL_H
