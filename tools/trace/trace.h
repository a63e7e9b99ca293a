// trace.h: reads the virtual board's CSV trace of STEP / DIR / endstop / ENABLE edges.
//
// Format (written by tools/vboard):
//   # stepchoir-vboard trace v1 board=uno f_cpu=16000000 clock_ppm=0 motors=4 travel_steps=3200
//   event,motor,cycle,value,position,width
//   step,0,1234567,1,1601,34      STEP rising edge; value = DIR level; position after; width = high time
//   dir,0,2000000,0,3200,         DIR pin change
//   endstop,0,2000100,1,3200,     logical switch change (1 = pressed)
//   bounce,0,2000150,0,3200,      one chatter toggle (pin level)
//   enable,0,5,0,,                ENABLE pin change (level)
//   sleep,0,900,0,,               the driver's SLEEP input (level; 0 = asleep), where wired
//   reset,0,950,0,,               the driver's RESET input (level; 0 = in reset), where wired
//   frame,0,2000300,0,,80         a host frame's last byte (its delimiter) reached the UART,
//                                 its first byte 80 cycles before (with stepchoir-vboard
//                                 --trace-frames; motor and value unused; width may be empty)
//   reply,0,2000900,0,12,         the USB bridge passed 12 of the board's bytes to the host
//                                 (with --trace-frames)
//   mcu_reset,0,1500000,0,,       the MCU reset: the host's open of the port (DTR) or its button
//   # end cycle=160000000
//   # summary motor=0 steps=1234 ...
// Within one motor and one event kind the rows are in cycle order; read_trace checks that.
#ifndef STEPCHOIR_TRACE_H
#define STEPCHOIR_TRACE_H

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace sc {
namespace trace {

// Parts per million: converts clock_ppm into a ratio.
constexpr double kPpmPerUnit = 1e6;

// One STEP pulse.
struct Step {
  uint64_t rise_cycle = 0;    // CPU cycle of the rising edge
  uint8_t dir = 0;            // DIR level while stepping (0 or 1)
  int64_t position = 0;       // position in steps after this step
  uint32_t width_cycles = 0;  // how long STEP stayed high
};

// One change of a level-type signal (DIR, endstop, bounce, ENABLE, SLEEP, RESET).
struct LevelChange {
  uint64_t cycle = 0;          // CPU cycle of the change
  uint8_t value = 0;           // new level (0 or 1)
  bool has_position = false;   // false when the position column was empty
  int64_t position = 0;        // position in steps at the change (if has_position)
};

// Everything the trace says about one motor.
struct MotorTrace {
  std::vector<Step> steps;
  std::vector<LevelChange> dir_changes;
  std::vector<LevelChange> endstop_changes;  // logical switch state, 1 = pressed
  std::vector<LevelChange> bounces;          // raw chatter toggles of the switch pin
  std::vector<LevelChange> enables;          // ENABLE pin level
  std::vector<LevelChange> sleeps;           // SLEEP pin level (1 = awake)
  std::vector<LevelChange> resets;           // RESET pin level (1 = out of reset)
};

// A whole trace file.
struct Trace {
  std::string board;             // board=... from the header ("" if absent)
  double f_cpu_hz = 0;           // f_cpu=... (required)
  double clock_ppm = 0;          // clock_ppm=... (0 if absent)
  int motors = 0;                // motors=... (required)
  int64_t travel_steps = 0;      // travel_steps=... (0 if absent = unknown)
  // "# wall_start cycle=C monotonic_ns=N": the machine's CLOCK_MONOTONIC read N when the board
  // was at cycle C and began to keep real time (absent: has_wall_start false).
  bool has_wall_start = false;
  uint64_t wall_start_cycle = 0, wall_start_ns = 0;
  uint64_t end_cycle = 0;        // from "# end cycle=N", else the last cycle seen
  bool has_end = false;          // true when the "# end" line was present
  std::vector<MotorTrace> motor;          // motors entries
  std::vector<uint64_t> frame_ends;       // cycles of "frame" rows, in order (--trace-frames)
  std::vector<uint64_t> frame_starts;     // cycles of their first bytes (the delimiter's where width is empty)
  struct Reply {
    uint64_t cycle;  // when the bridge passed them to the host
    uint64_t bytes;
  };
  std::vector<Reply> replies;             // "reply" rows, in order (--trace-frames)
  std::vector<uint64_t> mcu_resets;       // cycles of "mcu_reset" rows, in order
  std::vector<std::string> summary_lines; // "summary ..." comment lines, without the leading "# "

  // Board time of a cycle: cycle / f_cpu.
  double board_seconds(uint64_t cycle) const { return double(cycle) / f_cpu_hz; }
  // Real CPU clock rate: f_cpu scaled by the crystal error.
  double real_f_cpu_hz() const { return f_cpu_hz * (1.0 + clock_ppm / kPpmPerUnit); }
  // Real (wall) time of a cycle: cycle / (f_cpu * (1 + clock_ppm / 1e6)).
  double real_seconds(uint64_t cycle) const { return double(cycle) / real_f_cpu_hz(); }
  // The machine's monotonic clock (s) at a real_seconds() time of this board, for laying several
  // boards' traces on one time line (needs has_wall_start; true only while the board kept real
  // time: pacing_slipped_us() == 0).
  double wall_seconds(double real_s) const {
    return wall_start_ns / 1e9 + real_s - real_seconds(wall_start_cycle);
  }
};

// Reads a trace file. Throws std::runtime_error("PATH:LINE: message") on malformed input
// and std::runtime_error("PATH: cannot open ...") when the file cannot be read.
Trace read_trace(const std::string& path);

// Reads a trace from a stream; source_name prefixes error messages ("NAME:LINE: ...").
Trace read_trace(std::istream& in, const std::string& source_name = "<stream>");

// Parses a trace held in memory; source_name prefixes error messages.
Trace parse_trace(const std::string& text, const std::string& source_name = "<string>");

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_H
