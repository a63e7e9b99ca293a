// trace_writer.cpp: hand-formatted, buffered CSV rows for the pin-event trace.
#include "trace_writer.h"

#include <cerrno>
#include <cstring>

namespace vboard {

// Flushes and closes.
TraceWriter::~TraceWriter() { close(); }

// Opens (truncates) path.
bool TraceWriter::open(const std::string &path, std::string &error) {
  close();
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) {
    error = "cannot open trace file " + path + ": " + std::strerror(errno);
    return false;
  }
  owns_file_ = true;
  buffer_.reserve(kFlushBytes + 4096);
  return true;
}

// Writes to an already open stream that the caller keeps ownership of.
void TraceWriter::attach(FILE *stream) {
  close();
  file_ = stream;
  owns_file_ = false;
  buffer_.reserve(kFlushBytes + 4096);
}

// First line and CSV header.
void TraceWriter::header(const std::string &board, uint32_t f_cpu_hz, const std::string &clock_ppm,
                         unsigned motors, int64_t travel_steps) {
  if (!file_) return;
  put("# stepchoir-vboard trace v1 board=");
  put(board.c_str());
  put(" f_cpu=");
  put_u64(f_cpu_hz);
  put(" clock_ppm=");
  put(clock_ppm.c_str());
  put(" motors=");
  put_u64(motors);
  put(" travel_steps=");
  put_i64(travel_steps);
  put("\nevent,motor,cycle,value,position,width\n");
}

// "# text" line.
void TraceWriter::comment(const std::string &text) {
  if (!file_) return;
  put("# ");
  put(text.c_str());
  put_char('\n');
}

// step row, written at the falling edge.
void TraceWriter::step(unsigned motor, uint64_t rise_cycle, bool dir_level, int64_t position_steps,
                       uint64_t high_cycles) {
  if (!file_) return;
  row_prefix("step", motor, rise_cycle, dir_level);
  put_i64(position_steps);
  put_char(',');
  put_u64(high_cycles);
  end_row();
}

// dir row.
void TraceWriter::dir(unsigned motor, uint64_t cycle, bool level, int64_t position_steps) {
  if (!file_) return;
  row_prefix("dir", motor, cycle, level);
  put_i64(position_steps);
  put_char(',');
  end_row();
}

// endstop row (logical switch change).
void TraceWriter::endstop(unsigned motor, uint64_t cycle, bool pressed, int64_t position_steps) {
  if (!file_) return;
  row_prefix("endstop", motor, cycle, pressed);
  put_i64(position_steps);
  put_char(',');
  end_row();
}

// bounce row (one chatter toggle of the pin).
void TraceWriter::bounce(unsigned motor, uint64_t cycle, bool pin_level, int64_t position_steps) {
  if (!file_) return;
  row_prefix("bounce", motor, cycle, pin_level);
  put_i64(position_steps);
  put_char(',');
  end_row();
}

// enable row.
void TraceWriter::enable(unsigned motor, uint64_t cycle, bool level) { level_row("enable", motor, cycle, level); }

// sleep row.
void TraceWriter::sleep(unsigned motor, uint64_t cycle, bool level) { level_row("sleep", motor, cycle, level); }

// reset row.
void TraceWriter::reset(unsigned motor, uint64_t cycle, bool level) { level_row("reset", motor, cycle, level); }

// "name,m,CYCLE,LEVEL,," : a pin level with no position.
void TraceWriter::level_row(const char *name, unsigned motor, uint64_t cycle, bool level) {
  if (!file_) return;
  row_prefix(name, motor, cycle, level);
  put_char(',');
  end_row();
}

void TraceWriter::frame_end(uint64_t cycle, uint64_t span_cycles) {
  if (!file_) return;
  row_prefix("frame", 0, cycle, false);
  put_char(',');
  put_u64(span_cycles);
  end_row();
}

void TraceWriter::mcu_reset(uint64_t cycle) {
  if (!file_) return;
  row_prefix("mcu_reset", 0, cycle, false);
  put_char(',');
  end_row();
}

void TraceWriter::reply(uint64_t cycle, uint64_t bytes) {
  if (!file_) return;
  row_prefix("reply", 0, cycle, false);
  put_u64(bytes);
  put_char(',');
  end_row();
}

// Writes the buffer out.
void TraceWriter::flush() {
  if (!file_) return;
  if (!buffer_.empty()) std::fwrite(buffer_.data(), 1, buffer_.size(), file_);
  buffer_.clear();
  std::fflush(file_);
}

// Flushes and closes the file.
void TraceWriter::close() {
  if (!file_) return;
  flush();
  if (owns_file_) std::fclose(file_);
  file_ = nullptr;
  owns_file_ = false;
}

// Appends "name,motor,cycle,value,".
void TraceWriter::row_prefix(const char *name, unsigned motor, uint64_t cycle, bool value) {
  put(name);
  put_char(',');
  put_u64(motor);
  put_char(',');
  put_u64(cycle);
  put_char(',');
  put_char(value ? '1' : '0');
  put_char(',');
}

// Appends a string.
void TraceWriter::put(const char *text) { buffer_.insert(buffer_.end(), text, text + std::strlen(text)); }

// Appends an unsigned decimal number.
void TraceWriter::put_u64(uint64_t value) {
  char digits[20];
  int count = 0;
  do {
    digits[count++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  while (count > 0) buffer_.push_back(digits[--count]);
}

// Appends a signed decimal number.
void TraceWriter::put_i64(int64_t value) {
  if (value < 0) {
    put_char('-');
    put_u64(static_cast<uint64_t>(-(value + 1)) + 1);
  } else {
    put_u64(static_cast<uint64_t>(value));
  }
}

// Ends a row and flushes when the buffer is large.
void TraceWriter::end_row() {
  buffer_.push_back('\n');
  ++rows_;
  if (buffer_.size() >= kFlushBytes) flush();
}

}  // namespace vboard
