// learn_prompt.h: `stepchoir live --learn`: MIDI learn from the terminal. The performer types an
// action (its number or name, and a motor for mute_motor), then moves a knob or presses a pedal;
// the engine binds that controller (LiveSession::learn) and the prompt saves it to the rig file
// (save_control) and says so. Lines come from standard input whenever they are there, so the
// keyboard plays on meanwhile.
#ifndef STEPCHOIR_HOST_CLI_LEARN_PROMPT_H
#define STEPCHOIR_HOST_CLI_LEARN_PROMPT_H

#include <optional>
#include <string>
#include <vector>

#include "live/session.h"
#include "live/stage.h"

namespace stepchoir {

// What a typed line asks to learn: "3", "octave_up", "13 2", "mute_motor 2". Nothing (and *why
// says what is wrong) for anything else. motor_count: the pool's motors (mute_motor's range).
// Called from: LearnPrompt, the console.
struct LearnRequest {
  Action action = Action::kPanic;
  uint8_t motor = 0;
};
std::optional<LearnRequest> parse_learn_request(const std::string &line, size_t motor_count, std::string *why);

// jam's keyboard plays some of the rig's motors: shown[i] is keyboard motor i's number as the
// rig counts it (live's: 0, 1, 2, ...), the number the console shows and the rig file keeps. A
// learned binding -> as the rig file keeps it (a typed number -> keyboard index: keyboard_motor,
// config.h). Called from: the console.
Binding rig_binding(Binding b, const std::vector<size_t> &shown);

// "CC 64 on channel 1" / "CC 1 on any channel": a binding's controller, for messages.
std::string describe_control(const Binding &b);

// Saves a binding the engine learned to the rig file at path (save_control) and says what
// happened: "learned CC 67 on channel 1 -> preset_next, saved to PATH", or why it is not
// saved. Called from: LearnPrompt, the console; the main thread.
std::string save_learned(const std::string &path, const Binding &b);

class LearnPrompt {
 public:
  // path: the rig file the bindings go to (created when missing). Prints the menu.
  LearnPrompt(std::string path, size_t motor_count);
  // Reads what standard input has (never waits), arms the engine for a typed action, and saves
  // what the engine learned. Called from: run_live's loop on the main thread, every 100 ms.
  void poll(LiveSession &session);

 private:
  std::string path_;
  size_t motor_count_;
  std::string pending_;  // a partial line read so far
  bool input_open_ = true;
};

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_LEARN_PROMPT_H
