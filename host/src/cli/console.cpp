// console.cpp: the performer's console on a terminal, with curses (see console.h).
#include "cli/console.h"

#include <algorithm>
#include <utility>

#include "cli/learn_prompt.h"
#include "config/config.h"

#define NCURSES_NOMACROS  // functions, not macros named erase, clear, move, timeout ...
#include <curses.h>

namespace stepchoir {
namespace {

constexpr int kEscape = Terminal::kEscape;
constexpr size_t kNoticesKept = 20;

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
  footer_.keys = kKeysHelp;
}

bool Console::handle_keys(LiveSession &session, int timeout_ms) {
  if (const auto b = session.learned()) {
    notice("learn: " + save_learned(learn_path_, rig_binding(*b, motor_numbers_)));
    footer_.learning.clear();
  }
  for (int key = terminal_.key(timeout_ms); key != Terminal::kNoKey; key = terminal_.key(0)) apply(session, key);
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
  // A motor by the number the screen shows (the rig's count), played by its keyboard index.
  std::string why;
  size_t shown_count = 0;
  for (size_t n : motor_numbers_) shown_count = std::max(shown_count, n + 1);
  const auto r = parse_learn_request(typed, shown_count, &why);
  if (!r) {
    notice("learn: " + why);
    return;
  }
  const std::optional<uint8_t> motor =
      r->action == Action::kMuteMotor ? keyboard_motor(motor_numbers_, r->motor) : std::optional<uint8_t>(0);
  if (!motor) {
    notice("learn: motor " + std::to_string(r->motor) + " is not the keyboard's");
    return;
  }
  footer_.typing = false;
  if (!session.learn(r->action, *motor)) {
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
  const size_t rows = terminal_.rows(), cols = terminal_.cols();
  if (rows == 0 || cols == 0) return;
  terminal_.draw(console_lines(m, footer_, rows, cols));
}

}  // namespace stepchoir
