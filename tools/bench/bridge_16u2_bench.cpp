// bridge_16u2_bench.cpp: stepchoir-bench-16u2, the Uno and Mega R3's USB bridge measured: Arduino's
// usbserial firmware on a simulated chip (chip_16u2.h), timed in its cycles, against the figures
// the virtual board's 16u2 link model uses (tools/vboard/src/usb_bridge.cpp). The hex comes from
// an Arduino IDE installation (hardware/arduino/avr/firmwares/atmegaxxu2/arduino-usbserial/);
// Debian's arduino-core-avr ships the firmware's source only. Hand-run; results in
// bench/results/usb-16u2-firmware.md.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "analysis.h"
#include "bench_date.h"
#include "chip_16u2.h"
#include "stepchoir_protocol.h"
#include "usb_bridge.h"

namespace {

using chip_16u2::Chip;
using chip_16u2::kFrameCycles;
using chip_16u2::kHz;
using sc::trace::percentile_nearest_rank;

constexpr double kCyclesPerUs = kHz / 1e6;
constexpr uint64_t kPollCycles = 16;  // IN polls 1 us apart find when the chip releases bytes

struct Stats {
  double min = 0, p50 = 0, p99 = 0, max = 0;
};
Stats stats_of(const std::vector<double> &v) {
  if (v.empty()) return {};
  return {*std::min_element(v.begin(), v.end()), percentile_nearest_rank(v, 0.5), percentile_nearest_rank(v, 0.99),
          *std::max_element(v.begin(), v.end())};
}
std::string fmt(double v, int decimals = 1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}
std::string row_us(const std::string &what, const Stats &s_cycles) {
  auto us = [](double c) { return fmt(c / kCyclesPerUs, 2); };
  return "| " + what + " | " + fmt(s_cycles.min, 0) + " / " + fmt(s_cycles.p50, 0) + " / " + fmt(s_cycles.max, 0) +
         " | " + us(s_cycles.min) + " / " + us(s_cycles.p50) + " / " + us(s_cycles.max) + " |\n";
}

// Host -> board, one frame of `bytes` at a time, each OUT packet at a random phase of the
// firmware's main loop. Per packet: the first byte's start bit after the packet, and each gap.
struct HostToBoard {
  std::vector<double> first, gaps, last_gaps, spans;
  size_t packets = 0, lost = 0;
};
bool host_to_board(Chip &chip, size_t trials, size_t bytes, std::mt19937_64 &rng, HostToBoard &r, std::string &error) {
  std::uniform_int_distribution<uint64_t> phase(0, kFrameCycles - 1);
  std::vector<uint8_t> frame(bytes);
  for (size_t i = 0; i < bytes; ++i) frame[i] = uint8_t(i + 1);
  for (size_t t = 0; t < trials; ++t) {
    if (!chip.run_to(chip.cycle() + kFrameCycles + phase(rng))) break;
    chip.sent().clear();
    const uint64_t at = chip.cycle();
    if (!chip.bulk_out(frame.data(), bytes)) {
      error = "the OUT endpoint refused a packet with the chip idle";
      return false;
    }
    ++r.packets;
    if (!chip.run_to(at + kFrameCycles)) break;
    const std::vector<chip_16u2::TxByte> &sent = chip.sent();
    if (sent.size() != bytes) {
      ++r.lost;
      continue;
    }
    r.first.push_back(double(sent[0].cycle - at));
    for (size_t i = 1; i + 1 < bytes; ++i) r.gaps.push_back(double(sent[i].cycle - sent[i - 1].cycle));
    r.last_gaps.push_back(double(sent[bytes - 1].cycle - sent[bytes - 2].cycle));
    r.spans.push_back(double(sent[bytes - 1].cycle - sent[0].cycle));
  }
  return r.packets == trials;
}

// Host -> board at full load: 64-byte packets offered at every poll (poll_cycles apart) for
// one second; bytes per second that reached USART1.
double host_to_board_rate(Chip &chip, uint64_t poll_cycles) {
  uint8_t packet[64];
  for (int i = 0; i < 64; ++i) packet[i] = uint8_t(i);
  chip.run_to(chip.cycle() + 10 * kFrameCycles);
  chip.sent().clear();
  const uint64_t start = chip.cycle(), end = start + kHz;
  for (uint64_t t = start; t < end; t += poll_cycles) {
    chip.run_to(t);
    chip.bulk_out(packet, sizeof packet);
  }
  chip.run_to(end);
  size_t count = 0;
  for (const chip_16u2::TxByte &b : chip.sent()) count += b.cycle < end ? 1 : 0;
  chip.run_to(end + 20 * kFrameCycles);  // drain before the next measurement
  return double(count);
}

// Board -> host: `bytes` from the board at a random time (uniform over two of the flush timer's
// periods after the last reply); IN polled every kPollCycles. Per reply: from its last byte's
// stop bit to the poll that returned it; and every release's cycle, to find the timer's period.
struct BoardToHost {
  std::vector<double> waits;
  std::vector<uint64_t> releases;
  size_t replies = 0, short_replies = 0;
};
bool board_to_host(Chip &chip, size_t trials, size_t bytes, uint64_t period, std::mt19937_64 &rng, BoardToHost &r) {
  std::uniform_int_distribution<uint64_t> gap(2 * kFrameCycles, 2 * kFrameCycles + 2 * period - 1);
  std::vector<uint8_t> reply(bytes, 0x55);
  std::vector<uint8_t> got;
  for (size_t t = 0; t < trials; ++t) {
    if (!chip.run_to(chip.cycle() + gap(rng))) return false;
    const uint64_t last_in = chip.cycle() + bytes * chip.byte_cycles();
    chip.from_board(reply.data(), bytes);
    ++r.replies;
    got.clear();
    const uint64_t give_up = chip.cycle() + 10 * kFrameCycles;
    while (got.size() < bytes && chip.cycle() < give_up) {
      if (!chip.run_to(chip.cycle() + kPollCycles)) return false;
      const size_t before = got.size();
      chip.bulk_in(got);
      if (got.size() > before) r.releases.push_back(chip.cycle());
    }
    if (got.size() < bytes) {
      ++r.short_replies;
      continue;
    }
    r.waits.push_back(double(chip.cycle() - last_in));
  }
  return true;
}

// Board -> host past the threshold: `bytes` back to back at the line's rate, `trials` times at
// random phases of the flush timer. Per burst: cycles from the stop bit of the byte that takes
// the count past `threshold` to the poll that returns the first bytes; bursts whose first
// bytes came before that byte (the timer's flush came first) are left out.
std::vector<double> threshold_release(Chip &chip, size_t trials, size_t bytes, size_t threshold,
                                      std::mt19937_64 &rng) {
  std::uniform_int_distribution<uint64_t> gap(10 * kFrameCycles, 20 * kFrameCycles);
  std::vector<uint8_t> burst(bytes, 0x33), got;
  std::vector<double> waits;
  for (size_t t = 0; t < trials; ++t) {
    if (!chip.run_to(chip.cycle() + gap(rng))) break;
    const uint64_t start = chip.cycle();
    const uint64_t crossing = start + (threshold + 1) * chip.byte_cycles();
    chip.from_board(burst.data(), bytes);
    got.clear();
    while (got.empty() && chip.cycle() < start + 10 * kFrameCycles) {
      if (!chip.run_to(chip.cycle() + kPollCycles)) break;
      chip.bulk_in(got);
    }
    if (!got.empty() && chip.cycle() >= crossing) waits.push_back(double(chip.cycle() - crossing));
    while (!got.empty()) {  // the rest of the burst
      got.clear();
      chip.run_to(chip.cycle() + 10 * kFrameCycles);
      chip.bulk_in(got);
    }
  }
  return waits;
}

// Where each release falls in the flush timer's period, cycles from the first release's place
// (in [-period/2, period/2)): all within one pass of the main loop when the timer's period is
// `period` exactly; a period off by a cycle would spread them by a cycle a period.
std::vector<double> release_phases(const std::vector<uint64_t> &releases, uint64_t period) {
  std::vector<double> phases;
  for (uint64_t r : releases) {
    const int64_t phase = int64_t((r - releases.front()) % period);
    phases.push_back(double(phase >= int64_t(period / 2) ? phase - int64_t(period) : phase));
  }
  return phases;
}

}  // namespace

int main(int argc, char **argv) {
  CLI::App app{"stepchoir-bench-16u2: Arduino's usbserial firmware (16U2) measured on a simulated chip"};
  std::string hex, out_dir = "bench/results", name = "usb-16u2-firmware";
  size_t trials = 1000;
  uint64_t seed = 1;
  app.add_option("--hex", hex, "the firmware: Arduino-usbserial-atmega16u2-Uno-Rev3.hex (or the Mega's)")->required();
  app.add_option("--trials", trials, "frames each way (default 1000)")->check(CLI::Range(10, 100000));
  app.add_option("--seed", seed, "random phases (default 1)");
  app.add_option("--out", out_dir, "directory for the results (default bench/results)");
  app.add_option("--name", name, "results file name without .md (default usb-16u2-firmware)");
  CLI11_PARSE(app, argc, argv);
  std::string error;
  Chip chip;
  if (!chip.load(hex, error) || !chip.enumerate(sc::kBaud, error)) {
    std::fprintf(stderr, "stepchoir-bench-16u2: %s\n", error.c_str());
    return 1;
  }
  std::mt19937_64 rng(seed);
  const size_t note_bytes = sc::frame_wire_size(sc::kSetPeriodBytes);
  const vboard::BridgeTiming model = vboard::link_model_timing(vboard::LinkModel::k16u2);
  const uint64_t model_period = model.flush_period_ns * kHz / 1000000000ull;
  const double model_pace = double(model.host_byte_ns) * kHz / 1e9;
  HostToBoard h2b;
  BoardToHost b2h;
  if (!host_to_board(chip, trials, note_bytes, rng, h2b, error) || !board_to_host(chip, trials, note_bytes, model_period, rng, b2h)) {
    std::fprintf(stderr, "stepchoir-bench-16u2: %s\n", error.empty() ? "the firmware stopped" : error.c_str());
    return 1;
  }
  const std::vector<double> burst_waits =
      threshold_release(chip, std::max<size_t>(10, trials / 20), model.packet_bytes + 8, model.packet_bytes - 1, rng);
  const double rate_frames = host_to_board_rate(chip, kFrameCycles);
  const double rate_fast = host_to_board_rate(chip, kFrameCycles / 8);
  const Stats gaps = stats_of(h2b.gaps), last_gaps = stats_of(h2b.last_gaps), spans = stats_of(h2b.spans);
  const Stats first = stats_of(h2b.first), waits = stats_of(b2h.waits), bursts = stats_of(burst_waits);
  const Stats phases = stats_of(release_phases(b2h.releases, model_period));
  const double periods = b2h.releases.empty() ? 0 : double(b2h.releases.back() - b2h.releases.front()) / model_period;

  std::ostringstream out;
  out << "# The 16U2 bridge measured: Arduino's usbserial firmware on a simulated chip\n\n"
      << "Command: `build/bin/stepchoir-bench-16u2 --hex Arduino-usbserial-atmega16u2-Uno-Rev3.hex --trials " << trials
      << " --seed " << seed << "`\n\nDate: " << utc_now_text() << "\n\n"
      << "Method: the firmware (`" << hex.substr(hex.find_last_of('/') + 1)
      << "`, from an Arduino IDE's `firmwares/atmegaxxu2/arduino-usbserial/`) runs on simavr's AT90USB162 "
         "(the ATmega16U2's predecessor: the same AVR core, USB controller, USART1 and Timer0) at 16 MHz. "
         "The bench plays the host: a bus reset, SET_ADDRESS, SET_CONFIGURATION, SET_LINE_CODING ("
      << sc::kBaud << " baud, 8N1) and DTR, then bulk OUT packets to endpoint 4 and bulk IN polls of endpoint 3. "
         "Every time is in the chip's cycles, exact; simavr does not model the USB bus itself, so an OUT packet "
         "lands in the endpoint at the instant the bench hands it over (on a real bus, after its transaction: "
      << fmt((model.bus_ns + model.bus_byte_ns * note_bytes) / 1e3, 2)
      << " us into the frame for a note, as the model counts it). USART1's data register is modelled as the chip has it "
         "(empty once its byte enters the shift register; simavr 1.6 lacks the double buffer), and each "
         "byte's time is its start bit.\n\n";
  out << "## Host -> board: " << h2b.packets << " note frames (" << note_bytes << " bytes), each at a random phase\n\n"
      << "| figure | cycles min / p50 / max | us min / p50 / max |\n|---|---|---|\n"
      << row_us("OUT packet -> first byte's start bit", first)
      << row_us("gap between bytes 1-" + std::to_string(note_bytes - 1), gaps)
      << row_us("gap before the last byte (the firmware releases the endpoint after reading it)", last_gaps)
      << row_us("first byte -> last byte", spans) << "\n"
      << "Packets whose bytes did not all reach USART1 within a frame: " << h2b.lost << ".\n\n"
      << "At full load (64-byte packets offered at every poll, for one second): " << fmt(rate_frames, 0)
      << " bytes a second reach USART1 when the host offers one packet a 1 ms frame, " << fmt(rate_fast, 0)
      << " when it offers one every 125 us (one pass of the main loop a byte: " << fmt(kHz / gaps.p50, 0)
      << " at the median gap).\n\n";
  out << "## Board -> host: " << b2h.replies << " replies of " << note_bytes << " bytes at random times\n\n"
      << "IN polled every " << fmt(kPollCycles / kCyclesPerUs, 0)
      << " us, to find when the chip releases bytes (a host's controller polls a bulk IN endpoint at its own "
         "pace; what it adds is not the chip's).\n\n"
      << "| figure | cycles min / p50 / max | us min / p50 / max |\n|---|---|---|\n"
      << row_us("last byte's stop bit -> released to the host", waits)
      << row_us("each release's place in a Timer0 period of " + std::to_string(model_period) +
                    " cycles, from the first's (" + fmt(periods, 0) + " periods)",
                phases)
      << row_us("burst of " + std::to_string(model.packet_bytes + 8) + " bytes: the " +
                    std::to_string(model.packet_bytes) + "th byte's stop bit -> the first bytes released",
                bursts)
      << "\nReplies not released within 10 ms: " << b2h.short_replies << "; bursts measured: " << burst_waits.size()
      << " (a burst whose first bytes the timer released first is left out).\n\n";
  out << "## Against the virtual board's 16u2 model\n\n"
      << "| figure | model (tools/vboard/src/usb_bridge.cpp) | measured |\n|---|---|---|\n"
      << "| host byte pace | " << fmt(model_pace, 0) << " cycles | p50 " << fmt(gaps.p50, 0) << ", last byte "
      << fmt(last_gaps.p50, 0) << " |\n"
      << "| note frame, first -> last byte | " << fmt(model_pace * double(note_bytes - 1) / kCyclesPerUs, 2)
      << " us | p50 " << fmt(spans.p50 / kCyclesPerUs, 2) << " us |\n"
      << "| OUT packet -> first byte | " << fmt(model.first_byte_min_ns / 1e3, 2) << "-"
      << fmt(model.first_byte_max_ns / 1e3, 2) << " us (a note's packet lands "
      << fmt((model.bus_ns + model.bus_byte_ns * note_bytes) / 1e3, 2) << " us into its frame) | "
      << fmt(first.min / kCyclesPerUs, 2) << "-" << fmt(first.max / kCyclesPerUs, 2) << " us |\n"
      << "| board -> host flush period | " << model_period << " cycles (" << fmt(model.flush_period_ns / 1e6, 3)
      << " ms), each release up to " << model.release_wander_ns * kHz / 1000000000ull
      << " cycles late (uniform) | every release within " << fmt(phases.max - phases.min, 0) << " cycles of one place in it, over "
      << fmt(periods, 0) << " periods |\n"
      << "| board -> host wait, min / p50 / max | the period's rest, then " << fmt(model.release_delay_ns / 1e3, 2)
      << " us | " << fmt(waits.min / kCyclesPerUs / 1000, 4) << " / " << fmt(waits.p50 / kCyclesPerUs / 1000, 3)
      << " / " << fmt(waits.max / kCyclesPerUs / 1000, 3) << " ms |\n"
      << "| released without the timer | " << fmt(model.packet_delay_ns / 1e3, 1) << " us after the byte that makes "
      << model.packet_bytes << " wait | p50 " << fmt(bursts.p50 / kCyclesPerUs, 1) << " us after that byte |\n";
  const std::string path = out_dir + "/" + name + ".md";
  std::ofstream file(path);
  file << out.str();
  std::fputs(out.str().c_str(), stdout);
  if (!file) {
    std::fprintf(stderr, "stepchoir-bench-16u2: cannot write %s\n", path.c_str());
    return 1;
  }
  return 0;
}
