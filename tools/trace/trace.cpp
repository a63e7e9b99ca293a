// trace.cpp: fast, strict parser for the virtual board's CSV trace (see trace.h).
#include "trace.h"

#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <istream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace sc {
namespace trace {
namespace {

constexpr std::string_view kHeaderPrefix = "# stepchoir-vboard trace v1";
constexpr std::string_view kColumnLine = "event,motor,cycle,value,position,width";
constexpr std::string_view kEndPrefix = "# end ";
constexpr std::string_view kSummaryPrefix = "# summary";
constexpr size_t kFieldCount = 6;
constexpr int kMaxTraceMotors = 256;      // sanity bound on motors= so garbage cannot allocate wildly
constexpr size_t kMaxQuotedChars = 40;    // how much of a bad token an error message repeats

enum Field { kEvent = 0, kMotor, kCycle, kValue, kPosition, kWidth };

// Parser state for one input: where we are, for error messages.
class Parser {
 public:
  // Binds the parser to a source name used in error messages.
  explicit Parser(const std::string& source_name) : source_(source_name) {}

  // Parses the whole text into a Trace.
  Trace run(std::string_view text);

 private:
  // Throws "SOURCE:LINE: message".
  [[noreturn]] void fail(const std::string& message) const {
    std::ostringstream os;
    os << source_ << ':' << line_no_ << ": " << message;
    throw std::runtime_error(os.str());
  }
  // Quotes a token for an error message, shortened and with control bytes replaced.
  static std::string quote(std::string_view token);
  // Parses the "# stepchoir-vboard trace v1 key=value ..." header.
  void parse_header(std::string_view line);
  // Parses one data row.
  void parse_row(std::string_view line);
  // Parses a "# ..." comment line after the header.
  void parse_comment(std::string_view line);
  // Parses an unsigned integer field or fails naming it.
  template <typename T>
  T parse_unsigned(std::string_view token, const char* what) const;
  // Parses a signed integer field or fails naming it.
  int64_t parse_signed(std::string_view token, const char* what) const;
  // Parses a decimal number (header values) or fails naming it.
  double parse_double(std::string_view token, const char* what) const;
  // Parses a 0/1 level or fails naming it.
  uint8_t parse_level(std::string_view token, const char* what) const;
  // Appends a level change after checking the per-motor cycle order.
  void push_level(std::vector<LevelChange>& list, const LevelChange& change, const char* kind,
                  int motor);

  std::string source_;
  size_t line_no_ = 0;
  bool have_header_ = false;
  bool have_columns_ = false;
  uint64_t last_cycle_ = 0;  // largest cycle in any row, the end when "# end" is missing
  Trace trace_;
};

std::string Parser::quote(std::string_view token) {
  std::string out = "'";
  for (size_t i = 0; i < token.size() && i < kMaxQuotedChars; ++i) {
    unsigned char c = static_cast<unsigned char>(token[i]);
    out += (c >= 0x20 && c < 0x7f) ? char(c) : '?';
  }
  if (token.size() > kMaxQuotedChars) out += "...";
  out += "'";
  return out;
}

template <typename T>
T Parser::parse_unsigned(std::string_view token, const char* what) const {
  T value = 0;
  const char* end = token.data() + token.size();
  auto result = std::from_chars(token.data(), end, value);
  if (token.empty() || result.ec != std::errc() || result.ptr != end)
    fail(std::string("bad ") + what + " " + quote(token) + " (expected an unsigned integer)");
  return value;
}

int64_t Parser::parse_signed(std::string_view token, const char* what) const {
  int64_t value = 0;
  const char* end = token.data() + token.size();
  auto result = std::from_chars(token.data(), end, value);
  if (token.empty() || result.ec != std::errc() || result.ptr != end)
    fail(std::string("bad ") + what + " " + quote(token) + " (expected an integer)");
  return value;
}

double Parser::parse_double(std::string_view token, const char* what) const {
  double value = 0;
  const char* end = token.data() + token.size();
  auto result = std::from_chars(token.data(), end, value);
  if (token.empty() || result.ec != std::errc() || result.ptr != end || !std::isfinite(value))
    fail(std::string("bad ") + what + " " + quote(token) + " (expected a number)");
  return value;
}

uint8_t Parser::parse_level(std::string_view token, const char* what) const {
  if (token == "0") return 0;
  if (token == "1") return 1;
  fail(std::string("bad ") + what + " " + quote(token) + " (expected 0 or 1)");
}

void Parser::parse_header(std::string_view line) {
  if (line.substr(0, kHeaderPrefix.size()) != kHeaderPrefix ||
      (line.size() > kHeaderPrefix.size() && line[kHeaderPrefix.size()] != ' '))
    fail("expected header '" + std::string(kHeaderPrefix) + " key=value ...', got " + quote(line));
  bool have_f_cpu = false, have_motors = false;
  std::string_view rest = line.substr(kHeaderPrefix.size());
  while (!rest.empty()) {
    size_t start = rest.find_first_not_of(' ');
    if (start == std::string_view::npos) break;
    rest.remove_prefix(start);
    size_t stop = rest.find(' ');
    std::string_view pair = rest.substr(0, stop);
    rest.remove_prefix(stop == std::string_view::npos ? rest.size() : stop);
    size_t eq = pair.find('=');
    if (eq == std::string_view::npos) fail("bad header item " + quote(pair) + " (expected key=value)");
    std::string_view key = pair.substr(0, eq), value = pair.substr(eq + 1);
    if (key == "board") {
      trace_.board = std::string(value);
    } else if (key == "f_cpu") {
      trace_.f_cpu_hz = parse_double(value, "f_cpu");
      if (!(trace_.f_cpu_hz > 0)) fail("f_cpu must be positive, got " + quote(value));
      have_f_cpu = true;
    } else if (key == "clock_ppm") {
      trace_.clock_ppm = parse_double(value, "clock_ppm");
      if (!(std::fabs(trace_.clock_ppm) < kPpmPerUnit)) fail("clock_ppm out of range: " + quote(value));
    } else if (key == "motors") {
      int64_t motors = parse_signed(value, "motors");
      if (motors < 1 || motors > kMaxTraceMotors)
        fail("motors must be 1.." + std::to_string(kMaxTraceMotors) + ", got " + quote(value));
      trace_.motors = int(motors);
      have_motors = true;
    } else if (key == "travel_steps") {
      trace_.travel_steps = parse_signed(value, "travel_steps");
      if (trace_.travel_steps < 0) fail("travel_steps must not be negative, got " + quote(value));
    }  // unknown keys are allowed: later writers may add some
  }
  if (!have_f_cpu) fail("header lacks f_cpu=");
  if (!have_motors) fail("header lacks motors=");
  trace_.motor.resize(size_t(trace_.motors));
  have_header_ = true;
}

void Parser::parse_comment(std::string_view line) {
  if (line.substr(0, kHeaderPrefix.size()) == kHeaderPrefix) fail("second header line");
  if (line.substr(0, kEndPrefix.size()) == kEndPrefix) {
    std::string_view rest = line.substr(kEndPrefix.size());
    constexpr std::string_view kCycleKey = "cycle=";
    size_t at = rest.find(kCycleKey);
    if (at == std::string_view::npos) fail("'# end' line lacks cycle=");
    std::string_view value = rest.substr(at + kCycleKey.size());
    value = value.substr(0, value.find(' '));
    trace_.end_cycle = parse_unsigned<uint64_t>(value, "end cycle");
    trace_.has_end = true;
    return;
  }
  constexpr std::string_view kWallPrefix = "# wall_start ";
  if (line.substr(0, kWallPrefix.size()) == kWallPrefix) {
    const std::string_view rest = line.substr(kWallPrefix.size());
    const size_t cycle_at = rest.find("cycle="), ns_at = rest.find("monotonic_ns=");
    if (cycle_at == std::string_view::npos || ns_at == std::string_view::npos)
      fail("'# wall_start' line lacks cycle= or monotonic_ns=");
    std::string_view cycle = rest.substr(cycle_at + 6), ns = rest.substr(ns_at + 13);
    trace_.wall_start_cycle = parse_unsigned<uint64_t>(cycle.substr(0, cycle.find(' ')), "wall_start cycle");
    trace_.wall_start_ns = parse_unsigned<uint64_t>(ns.substr(0, ns.find(' ')), "wall_start monotonic_ns");
    trace_.has_wall_start = true;
    return;
  }
  if (line.substr(0, kSummaryPrefix.size()) == kSummaryPrefix &&
      (line.size() == kSummaryPrefix.size() || line[kSummaryPrefix.size()] == ' ')) {
    trace_.summary_lines.emplace_back(line.substr(2));  // drop "# "
  }
  // other comments are ignored
}

void Parser::push_level(std::vector<LevelChange>& list, const LevelChange& change, const char* kind,
                        int motor) {
  if (!list.empty() && change.cycle < list.back().cycle)
    fail(std::string(kind) + " row for motor " + std::to_string(motor) + " at cycle " +
         std::to_string(change.cycle) + " is before the previous one at " +
         std::to_string(list.back().cycle));
  list.push_back(change);
}

void Parser::parse_row(std::string_view line) {
  std::string_view field[kFieldCount];
  size_t count = 0, start = 0;
  for (;;) {
    size_t comma = line.find(',', start);
    std::string_view token = line.substr(start, comma == std::string_view::npos ? comma : comma - start);
    if (count < kFieldCount) field[count] = token;
    ++count;
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (count != kFieldCount)
    fail("expected " + std::to_string(kFieldCount) + " fields, got " + std::to_string(count));

  std::string_view event = field[kEvent];
  // A board-wide row (no motor): its cycle, not before the previous row of its kind.
  auto ordered_cycle = [&](uint64_t previous) {
    const uint64_t cycle = parse_unsigned<uint64_t>(field[kCycle], "cycle");
    if (cycle < previous)
      fail(std::string(event) + " row at cycle " + std::to_string(cycle) + " is before the previous one");
    if (cycle > last_cycle_) last_cycle_ = cycle;
    return cycle;
  };
  if (event == "frame") {
    const uint64_t end = ordered_cycle(trace_.frame_ends.empty() ? 0 : trace_.frame_ends.back());
    const uint64_t span = field[kWidth].empty() ? 0 : parse_unsigned<uint64_t>(field[kWidth], "frame span");
    if (span > end) fail("frame row's first byte comes before cycle 0");
    trace_.frame_ends.push_back(end);
    trace_.frame_starts.push_back(end - span);
    return;
  }
  if (event == "mcu_reset") {
    trace_.mcu_resets.push_back(ordered_cycle(trace_.mcu_resets.empty() ? 0 : trace_.mcu_resets.back()));
    return;
  }
  if (event == "reply") {
    const uint64_t cycle = ordered_cycle(trace_.replies.empty() ? 0 : trace_.replies.back().cycle);
    trace_.replies.push_back({cycle, parse_unsigned<uint64_t>(field[kPosition], "bytes")});
    return;
  }
  uint64_t motor64 = parse_unsigned<uint64_t>(field[kMotor], "motor");
  if (motor64 >= uint64_t(trace_.motors))
    fail("motor " + std::to_string(motor64) + " out of range (motors=" +
         std::to_string(trace_.motors) + ")");
  int motor = int(motor64);
  MotorTrace& m = trace_.motor[size_t(motor)];
  uint64_t cycle = parse_unsigned<uint64_t>(field[kCycle], "cycle");
  if (cycle > last_cycle_) last_cycle_ = cycle;

  if (event == "step") {
    Step s;
    s.rise_cycle = cycle;
    s.dir = parse_level(field[kValue], "step DIR level");
    s.position = parse_signed(field[kPosition], "position");
    s.width_cycles = parse_unsigned<uint32_t>(field[kWidth], "width");
    if (!m.steps.empty() && cycle < m.steps.back().rise_cycle)
      fail("step row for motor " + std::to_string(motor) + " at cycle " + std::to_string(cycle) +
           " is before the previous one at " + std::to_string(m.steps.back().rise_cycle));
    uint64_t fall_cycle = cycle + s.width_cycles;
    if (fall_cycle > last_cycle_) last_cycle_ = fall_cycle;
    m.steps.push_back(s);
    return;
  }
  LevelChange c;
  c.cycle = cycle;
  c.value = parse_level(field[kValue], "level");
  if (!field[kPosition].empty()) {
    c.has_position = true;
    c.position = parse_signed(field[kPosition], "position");
  }
  if (event == "dir") push_level(m.dir_changes, c, "dir", motor);
  else if (event == "endstop") push_level(m.endstop_changes, c, "endstop", motor);
  else if (event == "bounce") push_level(m.bounces, c, "bounce", motor);
  else if (event == "enable") push_level(m.enables, c, "enable", motor);
  else if (event == "sleep") push_level(m.sleeps, c, "sleep", motor);
  else if (event == "reset") push_level(m.resets, c, "reset", motor);
  else fail("unknown event " + quote(event) + " (expected step, dir, endstop, bounce, enable, sleep, reset, frame, reply or mcu_reset)");
}

Trace Parser::run(std::string_view text) {
  size_t pos = 0;
  while (pos < text.size()) {
    const char* base = text.data() + pos;
    const void* nl = std::memchr(base, '\n', text.size() - pos);
    size_t len = nl ? size_t(static_cast<const char*>(nl) - base) : text.size() - pos;
    std::string_view line(base, len);
    pos += len + 1;
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (!have_header_) {
      parse_header(line);
      continue;
    }
    if (line[0] == '#') {
      parse_comment(line);
    } else if (!have_columns_ && line == kColumnLine) {
      have_columns_ = true;
    } else if (line.substr(0, 6) == "event,") {
      fail("unexpected column line " + quote(line) + " (expected '" + std::string(kColumnLine) + "')");
    } else {
      parse_row(line);
    }
  }
  if (!have_header_) {
    line_no_ = line_no_ == 0 ? 1 : line_no_;
    fail("empty trace (no header line)");
  }
  if (!trace_.has_end) trace_.end_cycle = last_cycle_;
  return std::move(trace_);
}

}  // namespace

Trace parse_trace(const std::string& text, const std::string& source_name) {
  return Parser(source_name).run(text);
}

Trace read_trace(std::istream& in, const std::string& source_name) {
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw std::runtime_error(source_name + ": read error");
  return parse_trace(text, source_name);
}

Trace read_trace(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  in.seekg(0, std::ios::end);
  std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  std::string text;
  if (size > 0) {
    text.resize(size_t(size));
    in.read(&text[0], size);
    if (in.gcount() != size) throw std::runtime_error(path + ": read error");
  }
  return parse_trace(text, path);
}

}  // namespace trace
}  // namespace sc
