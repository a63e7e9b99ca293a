// live_parts.cpp: see live_parts.h.
#include "live_parts.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace live_parts {
namespace {

// A motor's first STEP edge after a silence: when (monotonic clock, s) and its cycle.
struct Start {
  double wall_s;
  uint64_t cycle;
  bool operator<(const Start &o) const { return wall_s < o.wall_s; }
};

constexpr double kSilenceS = 0.015;  // a motor that stepped within this did not start

std::vector<Start> starts_of(const sc::trace::Trace &t) {
  std::vector<Start> out;
  for (const auto &m : t.motor)
    for (size_t i = 0; i < m.steps.size(); ++i)
      if (i == 0 || t.real_seconds(m.steps[i].rise_cycle) - t.real_seconds(m.steps[i - 1].rise_cycle) > kSilenceS)
        out.push_back({t.wall_seconds(t.real_seconds(m.steps[i].rise_cycle)), m.steps[i].rise_cycle});
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * static_cast<double>(values.size() - 1))];
}

Split split_notes(const sc::trace::Trace &t, const std::vector<NoteStamps> &notes) {
  Split out;
  const std::vector<Start> starts = starts_of(t);
  auto wall_us = [&](uint64_t cycle) { return t.wall_seconds(t.real_seconds(cycle)) * 1e6; };
  for (const NoteStamps &n : notes) {
    const auto it = std::lower_bound(starts.begin(), starts.end(), Start{n.key_us / 1e6, 0});
    if (it == starts.end() || it->wall_s - n.key_us / 1e6 >= kWithinS) continue;
    const double total = it->wall_s * 1e6 - static_cast<double>(n.key_us);
    out.totals_us.push_back(total);
    if (n.callback_us == 0) {
      ++out.no_stamps;
      continue;
    }
    const auto end = std::lower_bound(t.frame_ends.begin(), t.frame_ends.end(), it->cycle);
    if (end == t.frame_ends.begin()) {
      ++out.no_frame;
      continue;
    }
    const size_t f = static_cast<size_t>(end - t.frame_ends.begin()) - 1;
    const uint64_t first = t.frame_starts[f], last = t.frame_ends[f];
    NoteParts p;
    p.jack = static_cast<double>(n.callback_us) - static_cast<double>(n.key_us);
    p.host = static_cast<double>(n.written_us) - static_cast<double>(n.callback_us);
    p.link = wall_us(first) - static_cast<double>(n.written_us);
    p.wire = static_cast<double>(last - first) / t.real_f_cpu_hz() * 1e6;
    p.firmware = static_cast<double>(it->cycle - last) / t.real_f_cpu_hz() * 1e6;
    p.total = total;
    out.worst_sum_error_us = std::max(out.worst_sum_error_us, std::fabs(p.sum() - p.total));
    out.parts.push_back(p);
  }
  return out;
}

std::string parts_table(const Split &split, size_t onsets, double jack_period_us, const std::string &link_model,
                        unsigned frame_bytes, unsigned baud) {
  struct Row {
    const char *name, *span;
    double (*part)(const NoteParts &);
    std::string bound;
  };
  const double wire_us = frame_bytes * 10.0 * 1e6 / baud;
  const Row rows[] = {
      {"JACK", "sender hands the note to JACK -> the MIDI callback's stamp", [](const NoteParts &p) { return p.jack; },
       "one period, " + std::to_string(static_cast<int>(std::lround(jack_period_us))) + " us"},
      {"host", "callback -> write() on the link returned", [](const NoteParts &p) { return p.host; },
       "none (the live path's own work)"},
      {"link", "write returned -> the frame's first byte at the board's UART", [](const NoteParts &p) { return p.link; },
       link_model == "ideal" ? "none on a native UART; here the virtual board's lead on the wall clock "
                               "(docs/decisions/020-vboard-pacing-catch-up.md)"
                             : link_model == "16u2"
                                   ? "the next 1 ms USB frame, its bus transaction (15 us) and up to 17 us for the "
                                     "16U2's loop to reach the packet (docs/usb-bridges.md), then the virtual board's "
                                     "lead where the frame starts inside it"
                                   : "the next 1 ms USB frame and its bus transaction (15 us), then the virtual board's "
                                     "lead where the frame starts inside it"},
      {"wire", "first byte -> last byte at the UART", [](const NoteParts &p) { return p.wire; },
       std::to_string(frame_bytes - 1) + " bytes after the first: " +
           std::to_string(static_cast<int>(std::lround(wire_us * (frame_bytes - 1) / frame_bytes))) +
           " us at the line's rate" + (link_model == "16u2" ? ", more at the 16U2's pace (docs/usb-bridges.md)" : "")},
      {"firmware", "last byte -> first STEP edge", [](const NoteParts &p) { return p.firmware; },
       "bench/results/onset-latency.md"},
      {"after MIDI in", "the MIDI callback's stamp -> first STEP edge", [](const NoteParts &p) { return p.after_midi(); },
       "all but JACK: stepchoir, the link and the board"},
      {"JACK and the link", "total less the host's and the firmware's parts",
       [](const NoteParts &p) { return p.jack + p.link + p.wire; },
       "what the JACK server and the USB bridge take: stepchoir's own parts come on top"},
      {"total", "key -> first STEP edge", [](const NoteParts &p) { return p.total; }, ""},
  };
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  out << "## key -> first STEP edge, part by part\n\n"
      << split.parts.size() << " of " << onsets << " single notes split (" << split.totals_us.size()
      << " with their edge found; " << split.no_stamps << " without the host's stamps, " << split.no_frame
      << " without a traced frame). Every time is on the monotonic clock: the sender's and the host's stamps "
         "directly, the board's UART and STEP edges through the trace's wall_start line; wire and firmware in "
         "the board's cycles. Each note's parts add up to its total within "
      << split.worst_sum_error_us << " us (the bench fails past 5 us). Percentiles are of each part alone: "
         "they do not add up.\n\n"
      << "| part | from -> to | p50 us | p99 us | max us | bound |\n|---|---|---|---|---|---|\n";
  for (const Row &r : rows) {
    std::vector<double> v;
    for (const NoteParts &p : split.parts) v.push_back(r.part(p));
    out << "| " << r.name << " | " << r.span << " | " << percentile(v, 0.5) << " | " << percentile(v, 0.99)
        << " | " << percentile(v, 1.0) << " | " << r.bound << " |\n";
  }
  out << "\nThe virtual board hands a frame's first byte to the UART as soon as the bridge releases it, each "
         "next one a byte time later, or at the bridge's own pace when that is slower (the 16U2's: "
         "docs/usb-bridges.md): the wire part is the frame's other " << frame_bytes - 1
      << " bytes (on a real bridge the first byte takes one byte time more, " << wire_us / frame_bytes << " us).\n";
  return out.str();
}

}  // namespace live_parts
