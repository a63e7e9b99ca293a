// render_main.cpp: stepchoir-render, turns a virtual-board trace into a WAV and a PNG piano roll.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "analysis.h"
#include "merge.h"
#include "render.h"
#include "trace.h"

namespace {

constexpr int kMaxSampleRateHz = 384000;

// Prints how to call the program.
void usage(FILE* out) {
  std::fprintf(out,
               "usage: stepchoir-render TRACE.csv [--first-note S] [TRACE.csv --first-note S ...] [-o out.wav]\n"
               "                        [--png roll.png] [--rate HZ]\n"
               "  --first-note S  the song time (s) of the trace's first step: several boards' traces of one\n"
               "               song (each given it) become one, every board's motors on one time line\n"
               "  -o FILE      write a 16-bit mono WAV (real-time axis)\n"
               "  --png FILE   write a piano-roll PNG\n"
               "  --rate HZ    WAV sample rate (default %d)\n"
               "At least one of -o and --png is required. A per-motor summary goes to stdout.\n",
               sc::trace::kDefaultSampleRateHz);
}

// Prints one line per motor: steps, notes, reversals, overshoot, shortest pulse.
void print_summary(const sc::trace::Trace& trace) {
  using namespace sc::trace;
  const SegmentOptions segment_options;
  const uint64_t gap_cycles = uint64_t(segment_options.max_gap_s * trace.f_cpu_hz);
  std::printf("board=%s f_cpu=%.0f clock_ppm=%g motors=%d travel_steps=%lld end=%.3fs (real)\n",
              trace.board.c_str(), trace.f_cpu_hz, trace.clock_ppm, trace.motors,
              static_cast<long long>(trace.travel_steps), trace.real_seconds(trace.end_cycle));
  for (size_t m = 0; m < trace.motor.size(); ++m) {
    const std::vector<Step>& steps = trace.motor[m].steps;
    auto width_cycles = min_pulse_width_cycles(steps);
    char width_us[32] = "-";
    if (width_cycles)
      std::snprintf(width_us, sizeof width_us, "%.3f", *width_cycles * kMicrosPerSecond / trace.f_cpu_hz);
    std::printf("motor %zu: steps=%zu notes=%zu reversals=%zu overshoot_steps=%lld min_width_us=%s\n", m,
                steps.size(), segment_notes(steps, trace.f_cpu_hz, segment_options).size(),
                reversal_count(steps, gap_cycles),
                static_cast<long long>(max_overshoot_steps(steps, trace.travel_steps)), width_us);
  }
}

}  // namespace

// Parses the command line, reads the trace and writes the requested outputs.
int main(int argc, char** argv) {
  std::vector<std::string> trace_paths;
  std::vector<double> first_notes;  // NaN: not given
  std::string wav_path, png_path;
  int rate_hz = sc::trace::kDefaultSampleRateHz;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    auto value = [&](const char* name) -> std::string {  // the argument after an option
      if (i + 1 >= argc) {
        std::fprintf(stderr, "stepchoir-render: %s needs a value\n", name);
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "-h" || arg == "--help") {
      usage(stdout);
      return 0;
    } else if (arg == "-o") {
      wav_path = value("-o");
    } else if (arg == "--png") {
      png_path = value("--png");
    } else if (arg == "--rate") {
      std::string text = value("--rate");
      char* end = nullptr;
      long rate = std::strtol(text.c_str(), &end, 10);
      if (text.empty() || *end != '\0' || rate <= 0 || rate > kMaxSampleRateHz) {
        std::fprintf(stderr, "stepchoir-render: bad --rate '%s' (1..%d)\n", text.c_str(), kMaxSampleRateHz);
        return 2;
      }
      rate_hz = int(rate);
    } else if (arg == "--first-note") {
      const std::string text = value("--first-note");
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (trace_paths.empty() || text.empty() || *end != '\0' || !std::isfinite(v) || v < 0) {
        std::fprintf(stderr, "stepchoir-render: --first-note '%s': a time in seconds after a trace\n", text.c_str());
        return 2;
      }
      first_notes.back() = v;
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr, "stepchoir-render: unknown option '%s'\n", arg.c_str());
      usage(stderr);
      return 2;
    } else {
      trace_paths.push_back(arg);
      first_notes.push_back(NAN);
    }
  }
  if (trace_paths.empty() || (wav_path.empty() && png_path.empty())) {
    usage(stderr);
    return 2;
  }
  if (trace_paths.size() > 1)
    for (size_t k = 0; k < trace_paths.size(); ++k)
      if (std::isnan(first_notes[k])) {
        std::fprintf(stderr, "stepchoir-render: %s: several traces need --first-note after each\n",
                     trace_paths[k].c_str());
        return 2;
      }
  try {
    std::vector<sc::trace::Trace> traces;
    for (const std::string& path : trace_paths) traces.push_back(sc::trace::read_trace(path));
    sc::trace::Trace trace = traces.size() == 1 ? std::move(traces[0]) : sc::trace::merge_traces(traces, first_notes);
    print_summary(trace);
    if (!wav_path.empty()) {
      sc::trace::AudioOptions audio;
      audio.sample_rate_hz = rate_hz;
      sc::trace::write_wav(wav_path, sc::trace::render_audio(trace, audio), rate_hz);
      std::printf("wrote %s\n", wav_path.c_str());
    }
    if (!png_path.empty()) {
      sc::trace::write_png(png_path, sc::trace::render_piano_roll(trace));
      std::printf("wrote %s\n", png_path.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stepchoir-render: %s\n", e.what());
    return 1;
  }
  return 0;
}
