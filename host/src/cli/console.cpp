// console.cpp: the performer's console on a terminal, with curses (see console.h).
#include "cli/console.h"

#include <unistd.h>

#include <stdexcept>
#include <utility>

#include "cli/learn_prompt.h"

#define NCURSES_NOMACROS  // functions, not macros named erase, clear, move, timeout ...
#include <curses.h>

namespace stepchoir {
namespace {

constexpr int kEscape = 27;
constexpr int kEscapeDelayMs = 50;  // a lone Esc is a panic this soon; an arrow's bytes come closer
constexpr size_t kNoticesKept = 20;

// Colour pairs, by LineStyle (0: the terminal's own colours).
constexpr short kPairOf[] = {0, 0, 0, 1, 0, 2, 3, 0};

// curses attributes for a style: colours where the terminal has them, else bold, dim, reverse.
attr_t attributes(LineStyle s, bool colour) {
  const short pair = kPairOf[static_cast<int>(s)];
  attr_t a = colour && pair ? COLOR_PAIR(pair) : A_NORMAL;
  switch (s) {
    case LineStyle::kTitle:
    case LineStyle::kKeys: return a | A_REVERSE;
    case LineStyle::kHeading: return a | A_UNDERLINE;
    case LineStyle::kSounding:
    case LineStyle::kWarning: return a | A_BOLD;
    case LineStyle::kMuted: return a | A_DIM;
    default: return a;
  }
}

}  // namespace

const char *const kKeysHelp = "Esc:panic p/P:preset s/S:setlist t/T:transp o/O:octave 0-9:mute l:learn q:quit";

KeyCommand command_for_key(int key, const std::vector<size_t> &motor_numbers) {
  auto stage = [](Action a, uint8_t motor = 0) { return KeyCommand{KeyCommand::Kind::kStage, StageAction{a, 127, motor}}; };
  switch (key) {
    case kEscape:
    case ' ': return stage(Action::kPanic);
    case 'p':
    case KEY_RIGHT: return stage(Action::kPresetNext);
    case 'P':
    case KEY_LEFT: return stage(Action::kPresetPrevious);
    case 's': return stage(Action::kSetlistNext);
    case 'S': return stage(Action::kSetlistPrevious);
    case 't':
    case '+':
    case KEY_UP: return stage(Action::kTransposeUp);
    case 'T':
    case '-':
    case KEY_DOWN: return stage(Action::kTransposeDown);
    case 'o':
    case KEY_PPAGE: return stage(Action::kOctaveUp);
    case 'O':
    case KEY_NPAGE: return stage(Action::kOctaveDown);
    case 'l': return KeyCommand{KeyCommand::Kind::kLearn, {}};
    case 'q': return KeyCommand{KeyCommand::Kind::kQuit, {}};
  }
  for (size_t i = 0; key >= '0' && key <= '9' && i < motor_numbers.size(); ++i)
    if (motor_numbers[i] == static_cast<size_t>(key - '0')) return stage(Action::kMuteMotor, static_cast<uint8_t>(i));
  return {};
}

Console::Console(std::string learn_path, std::vector<size_t> motor_numbers)
    : learn_path_(std::move(learn_path)), motor_numbers_(std::move(motor_numbers)) {
  if (!::isatty(0) || !::isatty(1)) throw std::runtime_error("the console needs a terminal");
  SCREEN *screen = newterm(nullptr, stdout, stdin);
  if (!screen) throw std::runtime_error("the console cannot use this terminal (TERM)");
  set_term(screen);
  cbreak();
  noecho();
  nonl();
  keypad(stdscr, TRUE);
  set_escdelay(kEscapeDelayMs);
  curs_set(0);
  if (has_colors()) {
    start_color();
    use_default_colors();
    init_pair(1, COLOR_GREEN, -1);   // a sounding motor
    init_pair(2, COLOR_RED, -1);     // warnings
    init_pair(3, COLOR_CYAN, -1);    // messages
  }
  footer_.keys = kKeysHelp;
  std::fflush(stderr);
  stderr_log_ = std::tmpfile();
  if (stderr_log_) {
    saved_stderr_ = ::dup(2);
    ::dup2(::fileno(stderr_log_), 2);
  }
}

Console::~Console() {
  endwin();
  delscreen(set_term(nullptr));
  if (!stderr_log_) return;
  std::fflush(stderr);
  ::dup2(saved_stderr_, 2);
  ::close(saved_stderr_);
  std::rewind(stderr_log_);
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, stderr_log_)) > 0;) std::fwrite(buf, 1, n, stderr);
  std::fclose(stderr_log_);
}

bool Console::handle_keys(LiveSession &session, int timeout_ms) {
  if (const auto b = session.learned()) {
    notice("learn: " + save_learned(learn_path_, *b));
    footer_.learning.clear();
  }
  wtimeout(stdscr, timeout_ms);
  for (int key = wgetch(stdscr); key != ERR; key = wgetch(stdscr)) {
    apply(session, key);
    wtimeout(stdscr, 0);
  }
  return !quit_;
}

// Called from: handle_keys, for each key.
void Console::apply(LiveSession &session, int key) {
  if (footer_.typing && key != kEscape) {
    if (key == '\r' || key == '\n' || key == KEY_ENTER) {
      submit(session);
    } else if ((key == KEY_BACKSPACE || key == 127 || key == 8) && !footer_.typed.empty()) {
      footer_.typed.pop_back();
    } else if (key >= 32 && key < 127 && footer_.typed.size() < 40) {
      footer_.typed += static_cast<char>(key);
    }
    return;
  }
  footer_.typing = false;  // Esc leaves the prompt, and panics
  const KeyCommand c = command_for_key(key, motor_numbers_);
  switch (c.kind) {
    case KeyCommand::Kind::kNone: return;
    case KeyCommand::Kind::kQuit: quit_ = true; return;
    case KeyCommand::Kind::kLearn:
      if (learn_path_.empty())
        notice("learn: no rig file to save to (give --config FILE, or set HOME)");
      else
        footer_ = ConsoleFooter{footer_.notices, true, "", footer_.learning, footer_.keys};
      return;
    case KeyCommand::Kind::kStage:
      if (!session.perform(c.action)) notice("the stage queue is full: key ignored");
      else if (c.action.action == Action::kPanic) notice("panic: every motor silenced");
      return;
  }
}

// Called from: apply, on Enter in the learn prompt: arms the engine for the typed action.
void Console::submit(LiveSession &session) {
  const std::string typed = footer_.typed;
  footer_.typed.clear();
  if (typed.find_first_not_of(' ') == std::string::npos) {
    footer_.typing = false;  // Enter alone leaves the prompt
    return;
  }
  std::string why;
  const auto r = parse_learn_request(typed, motor_numbers_.size(), &why);
  if (!r) {
    notice("learn: " + why);
    return;
  }
  footer_.typing = false;
  if (!session.learn(r->action, r->motor)) {
    notice("the stage queue is full: learn again");
    return;
  }
  footer_.learning = std::string(action_name(r->action)) +
                     (r->action == Action::kMuteMotor ? " " + std::to_string(r->motor) : "");
}

void Console::notice(const std::string &line) {
  footer_.notices.push_back(line);
  if (footer_.notices.size() > kNoticesKept) footer_.notices.erase(footer_.notices.begin());
}

void Console::draw(const ConsoleModel &m) {
  const int rows = getmaxy(stdscr), cols = getmaxx(stdscr);
  if (rows <= 0 || cols <= 0) return;
  const std::vector<ScreenLine> lines = console_lines(m, footer_, static_cast<size_t>(rows), static_cast<size_t>(cols));
  const bool colour = has_colors();
  werase(stdscr);
  for (size_t i = 0; i < lines.size(); ++i) {
    wattrset(stdscr, static_cast<int>(attributes(lines[i].style, colour)));
    // The bottom right cell stays empty: writing it would scroll some terminals.
    const int room = static_cast<int>(i) == rows - 1 ? cols - 1 : cols;
    mvwaddnstr(stdscr, static_cast<int>(i), 0, lines[i].text.c_str(), room);
  }
  wattrset(stdscr, A_NORMAL);
  wrefresh(stdscr);
}

}  // namespace stepchoir
