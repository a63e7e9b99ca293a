// pitch_report.cpp: the pitch bench's Markdown report: method, per-pass summary, worst edges, per-note tables.
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis.h"
#include "pitch_bench.h"

namespace pitch_bench {

namespace {

// Notes listed under "Worst edges", per pass.
constexpr size_t kWorstEdgesListed = 10;

// MCU name per board, for the report heading.
std::string mcu_name(const std::string &board_name) { return board_name == "mega" ? "ATmega2560" : "ATmega328P"; }

// Note name with octave, MIDI 60 = C4.
std::string note_name(int midi_note) {
  static const char *const kNames[12] = {"C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"};
  return std::string(kNames[((midi_note % 12) + 12) % 12]) + std::to_string(midi_note / 12 - 1);
}

// The summary section of one pass.
std::string summary_markdown(const PassResult &r) {
  const Worst w = worst_of(r);
  std::ostringstream o;
  o << "### " << traffic_title(r.traffic) << "\n\n";
  o << "Traffic: " << traffic_description(r.traffic) << ".\n\n";
  if (!r.failure.empty()) {
    o << "**FAILED**: " << r.failure << "\n\nTrace: `" << r.trace_path << "`\n\n";
    return o.str();
  }
  o << "| measure | value |\n|---|---|\n";
  const std::string scope = w.wrong_notes ? " (notes played as scheduled)" : "";
  o << "| worst \\|cents\\| | " << fixed(w.abs_cents, 5) << " |\n";
  o << "| notes not played as scheduled | " << w.wrong_notes + w.unmeasured << " of " << w.note_count;
  if (w.wrong_notes) o << " (" << w.wrong_notes << " off by > " << fixed(kWrongNoteCents, 0) << " cents: a lost or late `at` frame)";
  if (w.unmeasured) o << " (" << w.unmeasured << " with < 2 edges)";
  o << " |\n";
  o << "| worst motor's jitter p99, all its edges" << scope << " | "
    << (w.motor_p99_us > 0 ? fixed(w.motor_p99_us, 3) + " us" : std::string("n/a (no motor of ") + std::to_string(tr::kMinEdgesForP99) + "+ edges)")
    << " |\n";
  o << "| worst note's jitter p99, notes of " << tr::kMinEdgesForP99 << "+ edges" << scope << " | " << fixed(w.p99_us, 3)
    << " us |\n";
  o << "| worst jitter max" << scope << " | " << fixed(w.max_us, 3) << " us |\n";
  o << "| shortest STEP pulse | " << fixed(w.min_pulse_us, 3) << " us |\n";
  o << "| interrupts-off max | " << r.irq_off_max_cycles << " cycles = " << fixed(cycles_us(r.irq_off_max_cycles, r.f_cpu_hz), 2)
    << " us (in " << (r.irq_off_max_at.empty() ? "?" : "`" + r.irq_off_max_at + "`") << ", at "
    << fixed(r.irq_off_max_cycle / r.f_cpu_hz, 3) << " s) |\n";
  if (r.step_isr) {
    o << "| step ISRs worst | " << r.step_isr->max_cycles << " cycles = "
      << fixed(cycles_us(r.step_isr->max_cycles, r.f_cpu_hz), 2) << " us |\n";
    o << "| step ISR CPU load | " << fixed(100 * r.step_isr->load_fraction, 2) << " % of " << fixed(r.sim_seconds, 2)
      << " s simulated (" << fixed(r.music_seconds, 2) << " s of music) |\n";
    o << "| step ISR entries | " << r.step_isr->entries << " |\n";
  } else {
    o << "| step ISR | not found in the vboard summary |\n";
  }
  o << "| UART would-overrun (vboard) | " << r.uart_would_overrun << " |\n";
  o << "| UART xoff / bytes lost (vboard) | " << r.uart_xoff << " / " << r.uart_in_lost << " |\n";
  if (r.last_status) {
    const auto &h = r.last_status->head;
    o << "| board counters (last status) | frames ok " << h.frames_ok << ", bad " << h.frames_bad << ", uart overruns "
      << h.uart_overruns << ", late edges " << h.late_edges << ", last error " << sc::error_name(h.last_error)
      << ((h.flags & sc::kStatusWatchdogTripped) ? ", watchdog tripped" : "") << " |\n";
  } else {
    o << "| board counters | no status reply received |\n";
  }
  std::string errors;
  for (const auto &e : r.board_errors) errors += (errors.empty() ? "" : ", ") + e.first + " x" + std::to_string(e.second);
  o << "| board error replies | " << (errors.empty() ? "none" : errors) << " |\n";
  o << "| frames sent by the host | " << r.frames_sent << " (line use during the music: " << fixed(100 * r.line_use_fraction, 1)
    << " % of " << sc::kBaud / 1000 << " kbaud) |\n";
  o << "| run | " << fixed(r.sim_seconds, 3) << " s simulated in " << fixed(r.wall_seconds, 3)
    << " s wall; host connected at " << fixed(r.connect_seconds, 3) << " s, music from "
    << fixed(r.connect_seconds + kLeadSeconds, 3) << " s";
  if (r.traffic == Traffic::kLight) o << ", pacing lag max " << r.pacing_lag_max_us << " us";
  o << " |\n\n";
  o << "ISRs:";
  for (const IsrLine &i : r.isrs)
    if (i.entries)
      o << " `__vector_" << i.vector << "` " << i.entries << " entries, max " << i.max_cycles << " cycles, I-clear total per invocation max "
        << i.max_irq_off_cycles << ", load " << fixed(100 * i.load_fraction, 2) << " %;";
  o << "\n\nTrace: `" << r.trace_path << "`\n\n";
  return o.str();
}

// The per-note table of one pass.
std::string table_markdown(const PassResult &r) {
  std::ostringstream o;
  if (!r.failure.empty()) return "";
  o << "### Per note, " << traffic_title(r.traffic) << "\n\n";
  o << "| note | name | motor | target Hz | measured Hz | cents | jitter p99 us | jitter max us | min pulse us | edges | remark |\n";
  o << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const NoteResult &n : r.notes) {
    o << "| " << n.note << " | " << note_name(n.note) << " | " << n.motor << " | " << fixed(n.target_hz, 3) << " | ";
    std::string remark;
    if (played_as_scheduled(n))
      o << fixed(n.measured_hz, 4) << " | " << fixed(n.cents, 5) << " | " << fixed(n.jitter_p99_us, 3) << " | "
        << fixed(n.jitter_max_us, 3) << " | " << fixed(n.min_pulse_us, 3);
    else if (n.measured)
      o << fixed(n.measured_hz, 4) << " | " << fixed(n.cents, 2) << " | - | - | " << fixed(n.min_pulse_us, 3),
          remark = "wrong note: MIDI " + fixed(tr::midi_from_hz(n.measured_hz), 1) + " played";
    else
      o << "- | - | - | - | -", remark = "not played";
    o << " | " << n.edge_count << " | " << remark << " |\n";
  }
  o << "\n";
  return o.str();
}

// The pass's worst edges, one per note (those played as scheduled), furthest off first.
std::string worst_edges_markdown(const PassResult &r) {
  if (!r.failure.empty()) return "";
  std::vector<const NoteResult *> notes;
  for (const NoteResult &n : r.notes)
    if (played_as_scheduled(n)) notes.push_back(&n);
  std::stable_sort(notes.begin(), notes.end(), [](const NoteResult *a, const NoteResult *b) {
    return std::abs(a->worst_edge_us) > std::abs(b->worst_edge_us);
  });
  if (notes.size() > kWorstEdgesListed) notes.resize(kWorstEdgesListed);
  std::ostringstream o;
  o << "### Worst edges, " << traffic_title(r.traffic) << "\n\n";
  o << "Each note's edge furthest off its grid (+ late), the " << notes.size()
    << " furthest, with the other motors' edges from " << kNeighbourCycles
    << " cycles before it (cycles from it). Trace one with `STEPCHOIR_VBOARD_PCTRACE_WATCH` "
       "(docs/ARCHITECTURE.md, Debugging aids).\n\n";
  o << "| board s | cycle | note | motor | off us | other motors' edges |\n|---:|---:|---:|---:|---:|---|\n";
  for (const NoteResult *n : notes)
    o << "| " << fixed(static_cast<double>(n->worst_edge_cycle) / r.f_cpu_hz, 6) << " | " << n->worst_edge_cycle
      << " | " << n->note << " | " << n->motor << " | " << fixed(n->worst_edge_us, 3) << " | " << n->worst_edge_others
      << " |\n";
  o << "\n";
  return o.str();
}

// Local date and time, ISO 8601.
std::string now_text() {
  const std::time_t now = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S %Z", std::localtime(&now));
  return text;
}

// Output of a shell command's first line, or "" when it fails.
std::string command_line_output(const std::string &command) {
  FILE *p = popen(command.c_str(), "r");
  if (!p) return "";
  char line[256] = "";
  const bool got = std::fgets(line, sizeof line, p) != nullptr;
  pclose(p);
  std::string s = got ? line : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  return s;
}

// Which firmware ran: ELF path and time, source commit and whether firmware/ had local changes.
std::string firmware_identity(const Options &opt) {
  const std::string elf = opt.firmware_elf();
  std::string text = "`" + elf + "`";
  struct stat st;
  if (stat(elf.c_str(), &st) == 0) {
    char when[64];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::localtime(&st.st_mtime));
    text += " (built " + std::string(when) + ")";
  }
  if (!opt.elf_path.empty()) return text;  // built elsewhere: the source tree says nothing about it
  const std::string src = STEPCHOIR_SOURCE_DIR;
  const std::string commit = command_line_output("git -C '" + src + "' rev-parse --short HEAD 2>/dev/null");
  if (!commit.empty()) {
    const std::string dirty =
        command_line_output("git -C '" + src + "' status --porcelain -- firmware protocol 2>/dev/null | head -1");
    text += ", source " + commit + (dirty.empty() ? "" : " + uncommitted changes in firmware/ or protocol/");
  }
  return text;
}

}  // namespace

// Writes the report; returns its path.
std::string write_report(const Options &opt, const std::vector<PassResult> &passes) {
  std::filesystem::create_directories(opt.out_dir);
  const std::string path = opt.out_dir + "/pitch-" + opt.board_name + ".md";
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  size_t motor_count = 0, rounds = 0;
  for (const PassResult &r : passes)
    if (r.motor_count) motor_count = r.motor_count, rounds = r.rounds;
  out << "# Pitch benchmark: " << opt.board_name << " (" << mcu_name(opt.board_name) << ", " << motor_count
      << " motors)\n\n";
  out << "Command: `" << opt.command_line << "`\n\n";
  out << "Date: " << now_text() << "\n\n";
  out << "Firmware: " << firmware_identity(opt) << "\n\n";
  out << "Method: " << rounds << " rounds of " << fixed(opt.round_seconds, 3)
      << " s board time, scheduled with timestamped `at` frames on the board clock; in round r motor m plays note "
         "r + m * ceil(notes / motors) of the list (wrapped), so all motors sound different notes at once and every "
         "note is played. Per note: edges from "
      << fixed(kSettleSeconds * 1000, 0)
      << " ms after the round start to its end are fitted to the commanded period (board time); cents = measured vs "
         "equal-tempered target (A4 = 440 Hz, includes the host's q8 rounding, < 0.002 cents); jitter = |edge - ideal "
         "grid|, p99 (nearest rank) and max, shown only for notes within "
      << fixed(kWrongNoteCents, 0) << " cents of the target (others are a different note: the board did not play "
         "what was scheduled); the summary's p99s: each motor's over all its edges (each note's offset removed), "
         "and the worst note's, of the motors and notes with "
      << tr::kMinEdgesForP99
      << " edges or more (of fewer, the p99 is their largest, which the max covers); min pulse = shortest STEP "
         "high time. Step ISRs = vectors "
      << step_isr_vectors(opt.board_name) << ", one a motor; their worst invocation and their load (summed) include the ISRs nested in "
         "them.\n\n";
  out << "## Summary\n\n";
  for (const PassResult &r : passes) out << summary_markdown(r);
  out << "## Worst edges\n\n";
  for (const PassResult &r : passes) out << worst_edges_markdown(r);
  out << "## Per-note results\n\n";
  for (const PassResult &r : passes) out << table_markdown(r);
  return path;
}

}  // namespace pitch_bench
