// synth_trace.h: builds synthetic vboard traces (exact fractional periods, injected jitter) for tests.
#ifndef STEPCHOIR_TESTS_SYNTH_TRACE_H
#define STEPCHOIR_TESTS_SYNTH_TRACE_H

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "analysis.h"

namespace synth {

constexpr double kFCpuHz = 16000000.0;  // the Uno's clock, as the vboard header says
constexpr uint32_t kWidthCycles = 32;   // STEP high time written for every synthetic step
constexpr int64_t kTravelSteps = 3200;

// One note of a synthetic motor part: a MIDI pitch held from start_s for duration_s.
struct Note {
  double midi_note;
  double start_s;
  double duration_s;
};

// Rise cycles of a note: round(start + k * period) for every step inside the duration.
inline std::vector<uint64_t> note_edges_cycles(const Note& note, double f_cpu_hz = kFCpuHz) {
  const double period_cycles = f_cpu_hz / sc::trace::hz_from_midi(note.midi_note);
  const double start_cycles = note.start_s * f_cpu_hz;
  const double end_cycles = (note.start_s + note.duration_s) * f_cpu_hz;
  std::vector<uint64_t> edges;
  for (long k = 0;; ++k) {
    double at = start_cycles + double(k) * period_cycles;
    if (at > end_cycles) break;
    edges.push_back(uint64_t(std::llround(at)));
  }
  return edges;
}

// Builds trace text: a header, the column line, then each motor's steps (positions bounce
// between 0 and travel, reversing at the ends), and the end line.
inline std::string make_trace_text(const std::vector<std::vector<Note>>& parts, double end_s,
                                   double clock_ppm = 0, const std::string& board = "uno") {
  std::ostringstream os;
  os << "# stepchoir-vboard trace v1 board=" << board << " f_cpu=" << uint64_t(kFCpuHz)
     << " clock_ppm=" << clock_ppm << " motors=" << parts.size() << " travel_steps=" << kTravelSteps
     << "\n";
  os << "event,motor,cycle,value,position,width\n";
  for (size_t m = 0; m < parts.size(); ++m) {
    os << "enable,"<< m << ",5,0,,\n";
    int64_t position = kTravelSteps / 2;
    int dir = 1;
    for (const Note& note : parts[m]) {
      for (uint64_t cycle : note_edges_cycles(note)) {
        if ((dir == 1 && position == kTravelSteps) || (dir == 0 && position == 0)) {
          dir ^= 1;
          os << "dir," << m << "," << cycle - 100 << "," << dir << "," << position << ",\n";
        }
        position += dir ? 1 : -1;
        os << "step," << m << "," << cycle << "," << dir << "," << position << "," << kWidthCycles << "\n";
      }
    }
  }
  os << "# end cycle=" << uint64_t(std::llround(end_s * kFCpuHz)) << "\n";
  for (size_t m = 0; m < parts.size(); ++m) os << "# summary motor=" << m << " note=synthetic\n";
  return os.str();
}

// A scratch directory for this test process's outputs, created on first use.
inline std::filesystem::path scratch_dir() {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("stepchoir_test_trace_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// Writes text to a file in the scratch directory and returns its path.
inline std::string write_scratch(const std::string& name, const std::string& text) {
  std::filesystem::path path = scratch_dir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

// A three-motor C-major scale with a chord at the end: the picture a person should read.
inline std::vector<std::vector<Note>> three_motor_scale() {
  const double kNoteS = 0.5;
  const int scale[] = {60, 62, 64, 65, 67, 69, 71, 72};
  std::vector<std::vector<Note>> parts(3);
  for (int i = 0; i < 8; ++i) {
    parts[0].push_back({double(scale[i]), i * kNoteS, kNoteS * 0.9});       // melody
    parts[1].push_back({double(scale[i] - 12), i * kNoteS, kNoteS * 0.9});  // an octave below
  }
  parts[2].push_back({64, 0.0, 2.0});  // a held third, then a chord under the last notes
  parts[2].push_back({67, 2.2, 1.7});
  parts[0].push_back({72, 4.2, 1.0});
  parts[1].push_back({64, 4.2, 1.0});
  parts[2].push_back({55, 4.2, 1.0});
  return parts;
}

}  // namespace synth

#endif  // STEPCHOIR_TESTS_SYNTH_TRACE_H
