// usb_bridge.h: the USB-serial bridge between the host and the board's UART, as a real board has
// one: when bytes written by the host reach the UART, and when bytes the board sends reach the
// host. Pure (no simavr, no pty): time is the host's, in ns; unit-tested.
//
// Models (sources: docs/usb-bridges.md). Every USB model's host write lands in the bridge's
// OUT endpoint when its full-speed transaction ends: the next 1 ms frame's start-of-frame packet,
// the OUT token and the data packet (15.3 us for an 8-byte note frame).
//   ideal  bytes pass at once both ways (a pty, a native UART).
//   16u2   the Uno R3 and Mega R3 (ATmega16U2, Arduino's usbserial firmware): the first host
//          byte 7.6-16.9 us after the packet lands (the 16U2's main loop coming round to the
//          endpoint), then a byte a pass of that loop (15.3 us); board -> host 60.5 us after
//          the 16U2's loop sees its Timer0 overflow (every 4.096 ms, free-running; the loop
//          sees it up to 56.1 us late), or 432.9 us after the byte that makes more than 96
//          wait.
//   ftdi   FT232R boards: board -> host when the latency timer expires (16 ms by default,
//          restarted by every packet sent) or a 62-byte packet is full.
//   ch340  CH340 clones: board -> host in the next 1 ms frame, or at once when a 32-byte
//          packet is full.
#ifndef STEPCHOIR_VBOARD_USB_BRIDGE_H
#define STEPCHOIR_VBOARD_USB_BRIDGE_H

#include <cstddef>
#include <cstdint>
#include <deque>
#include <random>
#include <string>
#include <vector>

namespace vboard {

enum class LinkModel { kIdeal, k16u2, kFtdi, kCh340 };

// "ideal" | "16u2" | "ftdi" | "ch340"; false for anything else.
bool parse_link_model(const std::string &name, LinkModel &model);
const char *link_model_name(LinkModel model);

// The bridge's figures (ns, bytes); what link_model_timing gives per model.
struct BridgeTiming {
  uint64_t usb_frame_ns = 1000000;  // host -> board: a write goes out in the next frame
  uint64_t bus_ns = 0;              // ... and lands this long after the frame's start, plus
  uint64_t bus_byte_ns = 0;         // this per byte of its first (64-byte) packet
  uint64_t first_byte_min_ns = 0;   // ... its first byte reaches the UART this long after it
  uint64_t first_byte_max_ns = 0;   // lands, drawn uniformly from [min, max] per write
  uint64_t host_byte_ns = 0;        // ... and the bridge hands the UART a byte at most this often
                                    // (0: back to back at the line's rate); AvrAdapter paces it
  uint64_t flush_period_ns = 0;     // board -> host: waiting bytes go at each period's end (0: at once)
  uint64_t release_delay_ns = 0;    // ... that long after the period's end
  uint64_t release_wander_ns = 0;   // ... both later by up to this much (the bridge's loop coming
                                    // round to the timer's flag), drawn uniformly per period
  bool restart_on_packet = false;   // a full packet restarts the period (FTDI's latency timer)
  size_t packet_bytes = 0;          // ... and a full packet goes (0: no such rule)
  uint64_t packet_delay_ns = 0;     // ... this long after the byte that filled it
};
// ftdi_latency_ms: the FT232R's latency timer (1-255; 16 by default, 1 with low_latency).
BridgeTiming link_model_timing(LinkModel model, unsigned ftdi_latency_ms = 16);

class UsbBridge {
 public:
  // phase_ns: where the host's USB frames and the bridge's timer stand at host time 0 (a real
  // bridge's clock starts at no particular moment); each below period. seed: the draws of
  // first_byte_*_ns.
  UsbBridge(LinkModel model, const BridgeTiming &timing, uint64_t frame_phase_ns, uint64_t flush_phase_ns,
            uint64_t seed = 1);

  // Called from: the pty loop. Bytes the host wrote, read at host time now_ns.
  void from_host(const uint8_t *bytes, size_t count, uint64_t now_ns);
  // Called from: the UART bridge (AvrAdapter: the cycle it hands the byte to the UART). When
  // the next host byte reaches the board (ns, host time); UINT64_MAX when none waits.
  uint64_t next_board_byte_ns() const { return to_board_.empty() ? UINT64_MAX : to_board_.front().at_ns; }
  // True when a host byte has reached the board by now_ns.
  bool board_byte_ready(uint64_t now_ns) const { return next_board_byte_ns() <= now_ns; }
  // Takes that byte (its time has come).
  uint8_t board_byte_pop();
  // Host bytes not yet taken by the board (released or not).
  size_t host_bytes_waiting() const { return to_board_.size(); }

  // Called from: the UART bridge. One byte the board sent, at host time now_ns.
  void from_board(uint8_t byte, uint64_t now_ns);
  // Called from: the pty loop. Appends to out the board's bytes the bridge has passed to the
  // host by now_ns, in order.
  void to_host(uint64_t now_ns, std::vector<uint8_t> &out);
  // Board bytes the bridge still holds.
  size_t board_bytes_waiting() const { return from_board_.size() + leaving_.size(); }
  // When the bridge next passes board bytes to the host (ns, host time): 0 when some are passed
  // already (no batching), UINT64_MAX when it holds none.
  uint64_t next_host_pass_ns() const;

  LinkModel model() const { return model_; }
  const BridgeTiming &timing() const { return timing_; }

 private:
  struct Timed {
    uint64_t at_ns;  // host -> board: when it reaches the UART; board -> host: when it came
    uint8_t byte;
  };
  // Every held board byte that came before t_ns leaves at leave_ns (or after the bytes before
  // it): into leaving_.
  void release_before(uint64_t t_ns, uint64_t leave_ns);
  // The timer's expiries whose bytes are taken by now_ns: their bytes into leaving_.
  void expire(uint64_t now_ns);
  // When the bridge takes the held bytes at the expiry at expiry_ns (the expiry and that
  // period's wander: a function of the period alone, so that it can be known ahead).
  uint64_t taken_ns(uint64_t expiry_ns) const;

  LinkModel model_;
  BridgeTiming timing_;
  uint64_t frame_phase_ns_;
  uint64_t flush_phase_ns_;  // the bridge's first timer expiry
  uint64_t next_flush_ns_;   // the bridge's next timer expiry whose bytes are not yet taken
  uint64_t seed_;
  std::minstd_rand draw_;
  std::deque<Timed> to_board_;
  std::deque<Timed> from_board_;   // board -> host: held, at_ns when each came
  std::deque<Timed> leaving_;      // ... released, at_ns when each reaches the host
  std::vector<uint8_t> released_;  // passed at once (no batching), not yet handed to to_host
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_USB_BRIDGE_H
