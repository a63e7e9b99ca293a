// console_view.cpp: a ConsoleModel as lines of text for a terminal's size (see console_view.h).
#include "cli/console_view.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "live/stage.h"

namespace stepchoir {
namespace {

constexpr size_t kBarMax = 40;     // the rail bar's widest (characters)
constexpr size_t kBarMin = 7;      // narrower than this: no bar
constexpr size_t kRowFixed = 34;   // a live motor row's characters before its bar, endstop hits included
constexpr size_t kRowFlags = 6;    // kept free after the bar for " muted"
constexpr size_t kNoticesShown = 3;  // the latest messages shown

// printf into a std::string (lines are short).
std::string format(const char *f, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char *f, ...) {
  char buf[512];
  va_list args;
  va_start(args, f);
  std::vsnprintf(buf, sizeof buf, f, args);
  va_end(args);
  return buf;
}

// A port as a row shows it: under /dev/ its path there ("/dev/ttyACM0" -> "ttyACM0",
// "/dev/pts/3" -> "pts/3": a last part alone would be a bare number), else its last part
// ("/tmp/uno.pty" -> "uno.pty").
std::string short_name(const std::string &path) {
  if (path.rfind("/dev/", 0) == 0) return path.substr(5);
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string title(const ConsoleModel &m) {
  std::string t = "stepchoir " + m.command + (m.song.empty() ? "" : "  " + m.song);
  if (m.command == "play") return t;
  t += "  preset ";
  if (m.preset < 0)
    t += "-";
  else
    t += format("%d/%zu %s (program %d)", m.preset + 1, m.preset_count, m.preset_name.c_str(), m.preset_program);
  t += format("  transpose %+d  setlist ", m.transpose);
  t += m.setlist_count == 0 ? "-" : format("%d/%zu %s", m.setlist_item + 1, m.setlist_count, m.setlist_name.c_str());
  return t;
}

// A motor's row: number, note, Hz, cents, its endstop hits (blank until a status reply came)
// and its rail; play then the board it is on.
ScreenLine motor_line(const ConsoleMotor &mo, size_t cols) {
  const bool sounding = mo.note >= 0;
  std::string line = format("%2zu  %-4s %9s %6s  ", mo.number, motor_note_name(mo.note).c_str(),
                            sounding ? format("%.2f", mo.hz).c_str() : "",
                            sounding ? format("%+.0f", std::fabs(mo.cents) < 0.5 ? 0.0 : mo.cents).c_str() : "");
  line += format("%5s  ", mo.has_position ? std::to_string(mo.reversals).c_str() : "");
  std::string tail;  // after the bar
  if (mo.muted) tail += " muted";
  if (mo.song) tail += " song";
  if (mo.switch_fault) tail += " switch stuck";
  if (!mo.board.empty()) tail += " " + short_name(mo.board);
  // The bar leaves room for " muted" at least, and for all the tail where the row can spare it.
  const size_t spare = cols > kRowFixed + kBarMin ? cols - kRowFixed - kBarMin : 0;
  const size_t after = std::max(kRowFlags, std::min(tail.size(), spare));
  const size_t room = cols > kRowFixed + after ? cols - kRowFixed - after : 0;
  const size_t bar = std::min(room, kBarMax);
  if (bar >= kBarMin) line += rail_bar(mo, bar);
  line += tail;
  return {line, mo.muted ? LineStyle::kMuted : sounding ? LineStyle::kSounding : LineStyle::kNormal};
}

// A board's link: a line, and a second for its song clock where there is one (jam).
void add_link_lines(const ConsoleLink &l, std::vector<ScreenLine> *out) {
  const std::string line = format("%-16s %-12s %4.0f fr/s  err %llu  bad %u  reconn %u  ends %u",
                                  short_name(l.name).c_str(), l.health.c_str(), l.frames_per_s,
                                  static_cast<unsigned long long>(l.board_errors), l.bad_frames, l.reconnects, l.reversals);
  out->push_back({line, l.healthy ? LineStyle::kNormal : LineStyle::kWarning});
  if (l.has_clock)
    out->push_back({format("  song clock %+.1f ppm, fit within %.0f us", l.clock_ppm, l.clock_residual_us)});
}

std::string midi_line(const ConsoleModel &m) {
  std::string line = "MIDI " + (m.midi_input.empty() ? std::string("(gone)") : m.midi_input);
  for (size_t i = 0; i < m.recent.size(); ++i)
    line += (i ? " | " : "  last: ") + m.recent[i].text + format(" %.1fs", m.recent[i].age_ms / 1e3);
  return line;
}

// The actions a learn request may name, a few a line: "1 transpose_up  2 transpose_down ...".
std::vector<ScreenLine> action_lines(size_t cols) {
  std::vector<ScreenLine> out;
  std::string line;
  for (size_t i = 0; i < kActionCount; ++i) {
    const std::string item = format("%zu %s", i + 1, action_name(static_cast<Action>(i)));
    if (!line.empty() && line.size() + 2 + item.size() > cols) {
      out.push_back({line, LineStyle::kNotice});
      line.clear();
    }
    line += (line.empty() ? "" : "  ") + item;
  }
  out.push_back({line, LineStyle::kNotice});
  return out;
}

}  // namespace

std::string rail_bar(const ConsoleMotor &m, size_t width) {
  if (width < 3) return std::string(width, ' ');
  if (m.travel_steps == 0) {
    std::string s = m.has_position ? format("pos %d", m.position_steps) : "";
    s.resize(width, ' ');
    return s;
  }
  std::string bar(width, '-');
  bar.front() = '|';
  bar.back() = '|';
  const size_t inner = width - 2;
  bar[1 + inner / 2] = ':';
  if (!m.has_position) return "|" + std::string(inner, ' ') + "|";
  if (m.position_steps < 0) {
    bar.front() = '<';
  } else if (static_cast<uint32_t>(m.position_steps) > m.travel_steps) {
    bar.back() = '>';
  } else {
    const double at = static_cast<double>(m.position_steps) / m.travel_steps * (inner - 1);
    bar[1 + static_cast<size_t>(std::lround(at))] = 'o';
  }
  return bar;
}

std::vector<ScreenLine> console_lines(const ConsoleModel &m, const ConsoleFooter &f, size_t rows, size_t cols) {
  enum Part { kHeading, kMotors, kLinks, kLatency, kMidi, kWarnings, kLearn, kNotices, kParts };
  std::vector<ScreenLine> part[kParts];
  part[kHeading].push_back({m.command == "play" ? " #  note        Hz  cents   ends  rail, board"
                                                : " #  note        Hz  cents   ends  rail",
                            LineStyle::kHeading});
  for (const ConsoleMotor &mo : m.motors) part[kMotors].push_back(motor_line(mo, cols));
  for (const ConsoleLink &l : m.links) add_link_lines(l, &part[kLinks]);
  const bool live = m.command != "play";  // play: no MIDI input, no latency
  if (live)
    part[kLatency].push_back({format("latency p50 %llu us  p99 %llu us  %llu events",
                                   static_cast<unsigned long long>(m.latency_p50_us),
                                   static_cast<unsigned long long>(m.latency_p99_us),
                                   static_cast<unsigned long long>(m.events))});
  if (live) part[kMidi].push_back({midi_line(m), m.midi_input.empty() ? LineStyle::kWarning : LineStyle::kNormal});
  for (const std::string &w : m.warnings) part[kWarnings].push_back({"! " + w, LineStyle::kWarning});
  if (f.typing) part[kLearn] = action_lines(cols);
  if (!f.learning.empty())
    part[kLearn].push_back({"learn " + f.learning + ": move a knob or press a pedal", LineStyle::kNotice});
  const size_t first_notice = f.notices.size() > kNoticesShown ? f.notices.size() - kNoticesShown : 0;
  for (size_t i = first_notice; i < f.notices.size(); ++i) part[kNotices].push_back({f.notices[i], LineStyle::kNotice});

  // What fits, in order of importance; the title and the last line are always there.
  size_t room = rows >= 2 ? rows - 2 : 0;
  size_t take[kParts] = {};
  for (Part p : {kMotors, kLearn, kWarnings, kLinks, kLatency, kMidi, kNotices, kHeading}) {
    take[p] = std::min(room, part[p].size());
    room -= take[p];
  }
  if (take[kMotors] > 0 && take[kMotors] < part[kMotors].size())
    part[kMotors][take[kMotors] - 1] = {format("    +%zu more motors", part[kMotors].size() - take[kMotors] + 1)};

  std::vector<ScreenLine> out{{title(m), LineStyle::kTitle}};
  for (Part p : {kHeading, kMotors, kLinks, kLatency, kMidi, kWarnings, kLearn, kNotices})
    out.insert(out.end(), part[p].begin(), part[p].begin() + static_cast<long>(take[p]));
  if (rows >= 2) {
    out.resize(rows - 1);
    out.push_back(f.typing ? ScreenLine{"learn> " + f.typed + "_  (action number or name, Enter; Enter alone leaves)",
                                        LineStyle::kKeys}
                           : ScreenLine{f.keys, LineStyle::kKeys});
  }
  out.resize(std::min(out.size(), rows));
  for (ScreenLine &l : out)
    if (l.text.size() > cols) l.text.resize(cols);
  return out;
}

}  // namespace stepchoir
