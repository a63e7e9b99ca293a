// console_view.h: the live console's screen as text: a ConsoleModel laid out for a terminal of
// rows x cols, one styled line a row. Pure (no curses): console.cpp draws the lines, the tests
// read them.
//
// What goes first when the terminal is small: the title and the last line (keys, or the
// learn prompt) always, then the motors, the warnings, the links, latency, the MIDI input and
// its events, the messages, the column heads; a line wider than the terminal is cut, and the
// rail bars shrink first.
#ifndef STEPCHOIR_HOST_CLI_CONSOLE_VIEW_H
#define STEPCHOIR_HOST_CLI_CONSOLE_VIEW_H

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cli/console_model.h"

namespace stepchoir {

enum class LineStyle : uint8_t { kNormal, kTitle, kHeading, kSounding, kMuted, kWarning, kNotice, kKeys };

struct ScreenLine {
  std::string text;  // at most cols characters (ASCII)
  LineStyle style = LineStyle::kNormal;
};

// What the console adds to the model: its own messages and the learn prompt.
struct ConsoleFooter {
  std::vector<std::string> notices;  // the latest messages, oldest first
  bool typing = false;               // the learn prompt takes the keys
  std::string typed;                 // what was typed so far
  std::string learning;              // an action waiting for its control ("" when none)
  std::string keys;                  // the keys' help, the last line while nothing is typed
};

// The rail as a bar of `width` characters: '|' at both ends, '-' along it, ':' at the middle
// and 'o' where the carriage is ('<' or '>' at an end when past it); spaces when the position
// is unknown; "pos N" (cut to width) without soft limits (travel 0). Pure.
std::string rail_bar(const ConsoleMotor &m, size_t width);

// The screen for a terminal rows x cols (rows and cols at least 1). Pure.
std::vector<ScreenLine> console_lines(const ConsoleModel &m, const ConsoleFooter &footer, size_t rows, size_t cols);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_CONSOLE_VIEW_H
