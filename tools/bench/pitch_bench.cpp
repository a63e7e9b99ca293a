// pitch_bench.cpp: stepchoir-bench-pitch: pitch, jitter and ISR timing of MIDI 24-108 on the virtual board, as Markdown.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "board/vboard_child.h"
#include "pitch_bench.h"

namespace pitch_bench {
namespace {

// Lowest and highest MIDI note played by default (32.7 Hz to 4186 Hz).
constexpr int kFirstNote = 24;
constexpr int kLastNote = 108;

// Parses a comma-separated list of MIDI notes.
std::vector<int> parse_notes(const std::string &text) {
  std::vector<int> notes;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    size_t used = 0;
    const int note = std::stoi(item, &used);
    if (used != item.size() || note < 0 || note > 127) throw std::invalid_argument("bad MIDI note '" + item + "'");
    notes.push_back(note);
  }
  if (notes.empty()) throw std::invalid_argument("empty note list");
  return notes;
}

// The command line as typed (arguments quoted when needed).
std::string join_command(int argc, char **argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a.empty() || a.find_first_of(" \t'\"$\\") != std::string::npos) a = "'" + a + "'";
    s += (i ? " " : "") + a;
  }
  return s;
}

}  // namespace
}  // namespace pitch_bench

using namespace pitch_bench;

// Parses the options, runs both traffic passes, writes the report; exits 1 when a pass failed.
int main(int argc, char **argv) {
  Options opt;
  std::string notes_text;
  CLI::App app{"stepchoir-bench-pitch: pitch and timing of every motor across MIDI 24-108 on the virtual board"};
  app.add_option("--board", opt.board_name, stepchoir::one_of(stepchoir::kBoardKinds))
      ->required()
      ->check(CLI::IsMember(stepchoir::kBoardKinds));
  app.add_option("--out", opt.out_dir, "directory for pitch-<board>.md (default bench/results)");
  app.add_option("--round-seconds", opt.round_seconds, "board time per round of notes (default 0.5)")
      ->check(CLI::Range(0.05, 10.0));
  app.add_option("--notes", notes_text, "comma-separated MIDI notes instead of 24-108 (e.g. 60,72)");
  app.add_option("--elf", opt.elf_path, "firmware ELF to run (default: the build's stepchoir-<board>.elf)")
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  opt.command_line = join_command(argc, argv);

  std::vector<int> notes;
  try {
    if (notes_text.empty())
      for (int n = kFirstNote; n <= kLastNote; ++n) notes.push_back(n);
    else
      notes = parse_notes(notes_text);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir-bench-pitch: --notes: %s\n", e.what());
    return 2;
  }

  std::vector<PassResult> passes;
  bool failed = false;
  for (Traffic traffic : {Traffic::kLight, Traffic::kFlood}) {
    std::fprintf(stderr, "stepchoir-bench-pitch: %s, %s ...\n", opt.board_name.c_str(), traffic_title(traffic).c_str());
    try {
      passes.push_back(run_pass(opt, notes, traffic));
    } catch (const std::exception &e) {
      std::fprintf(stderr, "stepchoir-bench-pitch: %s, %s: %s\n", opt.board_name.c_str(),
                   traffic_title(traffic).c_str(), e.what());
      PassResult r;
      r.traffic = traffic;
      r.failure = e.what();
      r.trace_path = std::string(STEPCHOIR_BENCH_SCRATCH) + "/pitch-" + opt.board_name + "-" + traffic_tag(traffic) + ".csv";
      passes.push_back(r);
      failed = true;
      continue;
    }
    const PassResult &r = passes.back();
    const Worst w = worst_of(r);
    std::printf("%s %s: not as scheduled %zu of %zu notes; worst |cents| %.5f, jitter p99 %.3f us (motor) %.3f us "
                "(note), max %.3f us; "
                "irq-off max %llu cycles (%.2f us); step ISR max %llu cycles, load %.2f %%; would-overrun %llu\n",
                opt.board_name.c_str(), traffic_tag(traffic).c_str(), w.wrong_notes + w.unmeasured, w.note_count,
                w.abs_cents, w.motor_p99_us, w.p99_us, w.max_us,
                static_cast<unsigned long long>(r.irq_off_max_cycles), cycles_us(r.irq_off_max_cycles, r.f_cpu_hz),
                static_cast<unsigned long long>(r.step_isr ? r.step_isr->max_cycles : 0),
                r.step_isr ? 100 * r.step_isr->load_fraction : 0.0, static_cast<unsigned long long>(r.uart_would_overrun));
  }
  try {
    const std::string path = write_report(opt, passes);
    std::printf("wrote %s%s\n", path.c_str(), failed ? " (with failed passes)" : "");
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir-bench-pitch: %s\n", e.what());
    return 1;
  }
  return failed ? 1 : 0;
}
