// usb_bridge.cpp: the USB-serial bridge models (see usb_bridge.h).
#include "usb_bridge.h"

#include <algorithm>

namespace vboard {

bool parse_link_model(const std::string &name, LinkModel &model) {
  if (name == "ideal") model = LinkModel::kIdeal;
  else if (name == "16u2") model = LinkModel::k16u2;
  else if (name == "ftdi") model = LinkModel::kFtdi;
  else if (name == "ch340") model = LinkModel::kCh340;
  else return false;
  return true;
}

const char *link_model_name(LinkModel model) {
  switch (model) {
    case LinkModel::kIdeal: return "ideal";
    case LinkModel::k16u2: return "16u2";
    case LinkModel::kFtdi: return "ftdi";
    case LinkModel::kCh340: return "ch340";
  }
  return "?";
}

namespace {

// Full-speed USB, 12 Mbit/s: a host write lands in the device's OUT endpoint after the frame's
// start-of-frame packet, the OUT token and the data packet's sync, PID, CRC and end (35 bit
// times each) and two inter-packet gaps (7.5 each): 120 bit times, 10 us; then 8 bit times
// (667 ns) a byte. Bit stuffing, at most one bit in seven, is left out.
constexpr uint64_t kBusNs = 10000;
constexpr uint64_t kBusByteNs = 667;
constexpr size_t kPacketBytes = 64;  // a full-speed bulk packet's most

constexpr uint64_t cycles_16mhz_ns(uint64_t cycles) { return cycles * 1000000000ull / 16000000; }

}  // namespace

BridgeTiming link_model_timing(LinkModel model, unsigned ftdi_latency_ms) {
  BridgeTiming t;
  if (model != LinkModel::kIdeal) {
    t.bus_ns = kBusNs;
    t.bus_byte_ns = kBusByteNs;
  }
  switch (model) {
    case LinkModel::kIdeal:
      t.usb_frame_ns = 0;
      break;
    case LinkModel::k16u2:
      // Timer0 at 16 MHz / 256, overflowing every 256 counts; the buffer goes when more than
      // BUFFER_NEARLY_FULL (96) bytes wait. The main loop then copies the bytes into the IN
      // endpoint: a reply reaches it 968 cycles after the overflow, and past 96 bytes the
      // first 64 go 6,926 cycles (p50) after the byte that made 97
      // (bench/results/usb-16u2-firmware.md). The model sends every held byte then. The
      // releases' place in the period wanders over 898 cycles as the loop is busy elsewhere
      // when the flag is set: the model draws it uniformly over that span (the chip's lie
      // mostly near its late end).
      t.flush_period_ns = cycles_16mhz_ns(256 * 256);
      t.release_delay_ns = cycles_16mhz_ns(968);
      t.release_wander_ns = cycles_16mhz_ns(898);
      t.packet_bytes = 97;
      t.packet_delay_ns = cycles_16mhz_ns(6926);
      // Host bytes: the main loop reads the OUT endpoint one byte a pass, 245 cycles; the
      // packet's first byte goes out 121-270 cycles after the packet lands, as the loop comes
      // round.
      t.first_byte_min_ns = cycles_16mhz_ns(121);
      t.first_byte_max_ns = cycles_16mhz_ns(270);
      t.host_byte_ns = cycles_16mhz_ns(245);
      break;
    case LinkModel::kFtdi:
      t.flush_period_ns = uint64_t(ftdi_latency_ms) * 1000000;
      t.restart_on_packet = true;
      t.packet_bytes = 62;  // a 64-byte packet less its two modem-status bytes
      break;
    case LinkModel::kCh340:
      t.flush_period_ns = t.usb_frame_ns;
      t.packet_bytes = 32;  // its bulk IN endpoint's packet size
      break;
  }
  return t;
}

UsbBridge::UsbBridge(LinkModel model, const BridgeTiming &timing, uint64_t frame_phase_ns, uint64_t flush_phase_ns,
                     uint64_t seed)
    : model_(model),
      timing_(timing),
      frame_phase_ns_(frame_phase_ns),
      flush_phase_ns_(flush_phase_ns),
      next_flush_ns_(flush_phase_ns),
      seed_(seed),
      draw_(static_cast<std::minstd_rand::result_type>(seed % 2147483646u + 1)) {}

uint64_t UsbBridge::taken_ns(uint64_t expiry_ns) const {
  if (!timing_.release_wander_ns) return expiry_ns;
  // splitmix64 of the seed and the period's number: the same period, the same wander.
  uint64_t z = seed_ + (expiry_ns - flush_phase_ns_) / timing_.flush_period_ns * 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return expiry_ns + z % (timing_.release_wander_ns + 1);
}

void UsbBridge::from_host(const uint8_t *bytes, size_t count, uint64_t now_ns) {
  uint64_t at = now_ns;
  if (timing_.usb_frame_ns) {  // the next frame after now, its transaction, then the bridge
    const uint64_t since = now_ns >= frame_phase_ns_ ? now_ns - frame_phase_ns_ : 0;
    at = frame_phase_ns_ + (since / timing_.usb_frame_ns + 1) * timing_.usb_frame_ns;
    at += timing_.bus_ns + timing_.bus_byte_ns * std::min<size_t>(count, kPacketBytes);
    if (timing_.first_byte_max_ns > timing_.first_byte_min_ns)
      at += timing_.first_byte_min_ns + draw_() % (timing_.first_byte_max_ns - timing_.first_byte_min_ns + 1);
    else
      at += timing_.first_byte_min_ns;
  }
  if (!to_board_.empty() && to_board_.back().at_ns > at) at = to_board_.back().at_ns;  // bytes keep their order
  for (size_t i = 0; i < count; ++i) to_board_.push_back({at, bytes[i]});
}

uint8_t UsbBridge::board_byte_pop() {
  const uint8_t byte = to_board_.front().byte;
  to_board_.pop_front();
  return byte;
}

void UsbBridge::from_board(uint8_t byte, uint64_t now_ns) {
  if (!timing_.flush_period_ns) {
    released_.push_back(byte);
    return;
  }
  expire(now_ns);  // an expiry before this byte came takes the bytes before it, not this one
  from_board_.push_back({now_ns, byte});
  if (timing_.packet_bytes && from_board_.size() >= timing_.packet_bytes) {
    release_before(now_ns + 1, now_ns + timing_.packet_delay_ns);
    if (timing_.restart_on_packet) next_flush_ns_ = now_ns + timing_.flush_period_ns;
  }
}

void UsbBridge::to_host(uint64_t now_ns, std::vector<uint8_t> &out) {
  out.insert(out.end(), released_.begin(), released_.end());
  released_.clear();
  if (!timing_.flush_period_ns) return;
  expire(now_ns);
  while (!leaving_.empty() && leaving_.front().at_ns <= now_ns) {
    out.push_back(leaving_.front().byte);
    leaving_.pop_front();
  }
}

uint64_t UsbBridge::next_host_pass_ns() const {
  if (!released_.empty()) return 0;
  uint64_t next = leaving_.empty() ? UINT64_MAX : leaving_.front().at_ns;
  if (from_board_.empty()) return next;
  // The first timer expiry after the oldest held byte came (expire moves next_flush_ns_ on
  // only when it is called), then the copy into the endpoint.
  const uint64_t came = from_board_.front().at_ns;
  uint64_t expiry = next_flush_ns_;
  if (expiry + timing_.release_wander_ns <= came)
    expiry += ((came - expiry) / timing_.flush_period_ns) * timing_.flush_period_ns;
  while (taken_ns(expiry) <= came) expiry += timing_.flush_period_ns;
  return std::min(next, taken_ns(expiry) + timing_.release_delay_ns);
}

void UsbBridge::expire(uint64_t now_ns) {
  for (uint64_t taken; (taken = taken_ns(next_flush_ns_)) <= now_ns; next_flush_ns_ += timing_.flush_period_ns)
    release_before(taken, taken + timing_.release_delay_ns);
}

void UsbBridge::release_before(uint64_t t_ns, uint64_t leave_ns) {
  if (!leaving_.empty()) leave_ns = std::max(leave_ns, leaving_.back().at_ns);  // bytes keep their order
  while (!from_board_.empty() && from_board_.front().at_ns < t_ns) {
    leaving_.push_back({leave_ns, from_board_.front().byte});
    from_board_.pop_front();
  }
}

}  // namespace vboard
