// trace_writer.h: buffered CSV writer for the virtual board's pin-event trace (pure logic).
#ifndef STEPCHOIR_VBOARD_TRACE_WRITER_H
#define STEPCHOIR_VBOARD_TRACE_WRITER_H

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace vboard {

// Writes "stepchoir-vboard trace v1": a '#' header line, a CSV header, one row per event and
// '#' comment lines. Rows are formatted by hand into a large buffer (no printf per row).
class TraceWriter {
 public:
  TraceWriter() = default;
  TraceWriter(const TraceWriter &) = delete;
  TraceWriter &operator=(const TraceWriter &) = delete;
  // Flushes and closes.
  ~TraceWriter();

  // Opens (truncates) path; on failure fills error and returns false.
  bool open(const std::string &path, std::string &error);
  // Writes to an already open stream (not closed by the writer); for tests.
  void attach(FILE *stream);
  // True when rows go somewhere.
  bool is_open() const { return file_ != nullptr; }

  // First line and CSV header.
  void header(const std::string &board, uint32_t f_cpu_hz, const std::string &clock_ppm,
              unsigned motors, int64_t travel_steps);
  // "# text" line.
  void comment(const std::string &text);
  // step,m,RISE_CYCLE,DIR_LEVEL,POSITION_AFTER,HIGH_CYCLES (written at the falling edge).
  void step(unsigned motor, uint64_t rise_cycle, bool dir_level, int64_t position_steps,
            uint64_t high_cycles);
  // dir,m,CYCLE,LEVEL,POSITION,
  void dir(unsigned motor, uint64_t cycle, bool level, int64_t position_steps);
  // endstop,m,CYCLE,PRESSED,POSITION,
  void endstop(unsigned motor, uint64_t cycle, bool pressed, int64_t position_steps);
  // bounce,m,CYCLE,PINLEVEL,POSITION,
  void bounce(unsigned motor, uint64_t cycle, bool pin_level, int64_t position_steps);
  // enable,m,CYCLE,LEVEL,,
  void enable(unsigned motor, uint64_t cycle, bool level);
  // sleep,m,CYCLE,LEVEL,, : the driver's SLEEP input (low = asleep).
  void sleep(unsigned motor, uint64_t cycle, bool level);
  // reset,m,CYCLE,LEVEL,, : the driver's RESET input (low = in reset).
  void reset(unsigned motor, uint64_t cycle, bool level);
  // frame,0,CYCLE,0,,SPAN : a host frame's delimiter reached the UART at CYCLE, its first byte
  // SPAN cycles before.
  void frame_end(uint64_t cycle, uint64_t span_cycles);
  // reply,0,CYCLE,0,BYTES, : the USB bridge passed BYTES of the board's to the host.
  void reply(uint64_t cycle, uint64_t bytes);
  // mcu_reset,0,CYCLE,0,, : the host's open reset the MCU (DTR), or its reset button (SIGUSR1).
  void mcu_reset(uint64_t cycle);

  // Rows written so far.
  uint64_t rows() const { return rows_; }
  // Writes the buffer out.
  void flush();
  // Flushes and closes the file.
  void close();

 private:
  // Writes "name,motor,cycle,level,," (enable, sleep, reset).
  void level_row(const char *name, unsigned motor, uint64_t cycle, bool level);
  // Appends "name,motor,cycle,value," (the common row prefix).
  void row_prefix(const char *name, unsigned motor, uint64_t cycle, bool value);
  // Appends a string.
  void put(const char *text);
  // Appends one character.
  void put_char(char c) { buffer_.push_back(c); }
  // Appends an unsigned decimal number.
  void put_u64(uint64_t value);
  // Appends a signed decimal number.
  void put_i64(int64_t value);
  // Ends a row and flushes when the buffer is large.
  void end_row();

  static constexpr size_t kFlushBytes = 256 * 1024;
  FILE *file_ = nullptr;
  bool owns_file_ = false;
  std::vector<char> buffer_;
  uint64_t rows_ = 0;
};

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_TRACE_WRITER_H
