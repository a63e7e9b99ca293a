// console.h: the performer's console: a full-screen terminal UI (terminal.h) for `stepchoir live`
// and `stepchoir jam`, drawn from a ConsoleModel (console_model.h, laid out by
// console_view.h), with keys for the stage.
//
// Threads: everything here runs on the main thread, which is the session's stage queue's one
// producer (LiveSession::perform, learn); never on a real-time thread. The caller redraws at
// most kFrameMs apart. Works over ssh (curses sends only what changed) and in any size (the
// view drops what does not fit).
//
// Keys (kKeysHelp): Esc or space panic; p / P (or Right / Left) preset next / previous; s / S
// setlist next / previous; t / T (or Up / Down, + / -) transpose a semitone up / down; o / O
// (or PageUp / PageDown) an octave up / down; 0-9 mute or unmute that motor; l learn (type an
// action, Enter, then move a control: saved to the rig file); q quit.
#ifndef STEPCHOIR_HOST_CLI_CONSOLE_H
#define STEPCHOIR_HOST_CLI_CONSOLE_H

#include <string>
#include <vector>

#include "cli/console_model.h"
#include "cli/console_view.h"
#include "cli/terminal.h"
#include "live/session.h"
#include "live/stage.h"

namespace stepchoir {

// What one key asks for. Pure: console.cpp reads the key, this says what it means.
struct KeyCommand {
  enum class Kind : uint8_t { kNone, kStage, kLearn, kQuit } kind = Kind::kNone;
  StageAction action{};  // kStage
};
// key: a curses key code (a character, KEY_UP, ...); motor_numbers: the rig's number of each
// pool motor (a digit mutes the pool motor of that number, if there is one). Called from:
// Console, tests.
KeyCommand command_for_key(int key, const std::vector<size_t> &motor_numbers);

// The keys' help line.
extern const char *const kKeysHelp;

class Console {
 public:
  static constexpr int kFrameMs = 33;  // at most 30 redraws a second

  // Takes the terminal (terminal.h) until the console ends.
  // learn_path: the rig file learned controls go to ("" : learning says why it cannot);
  // motor_numbers: the rig's number of each pool motor (live: 0, 1, ...; jam: the keyboard's,
  // counted with the song's).
  // Throws std::runtime_error when the terminal cannot (no terminal, unknown TERM).
  // Called from: run_live and jam, on the main thread, once the session runs.
  Console(std::string learn_path, std::vector<size_t> motor_numbers);
  Console(const Console &) = delete;
  Console &operator=(const Console &) = delete;

  // Waits up to timeout_ms for a key, then applies it and every key already typed: stage
  // actions and learn requests to `session`, the learn prompt's typing. False once q was
  // pressed. Saves a control the engine learned meanwhile. Allocates (messages).
  bool handle_keys(LiveSession &session, int timeout_ms);
  // A message for the performer (a preset change, a link lost and back). Keeps the latest.
  void notice(const std::string &line);
  // Draws m now. Called from: the main loop, at most every kFrameMs.
  void draw(const ConsoleModel &m);

 private:
  void apply(LiveSession &session, int key);
  void submit(LiveSession &session);

  std::string learn_path_;
  std::vector<size_t> motor_numbers_;
  ConsoleFooter footer_;
  bool quit_ = false;
  Terminal terminal_;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_CONSOLE_H
