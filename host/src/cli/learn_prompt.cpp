// learn_prompt.cpp: `stepchoir live --learn` (see learn_prompt.h).
#include "cli/learn_prompt.h"

#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <sstream>

#include "config/config.h"

namespace stepchoir {

std::optional<LearnRequest> parse_learn_request(const std::string &line, size_t motor_count, std::string *why) {
  std::istringstream in(line);
  std::string word;
  in >> word;
  LearnRequest r;
  if (const auto named = parse_action(word)) {
    r.action = *named;
  } else {
    char *end = nullptr;
    const long number = std::strtol(word.c_str(), &end, 10);
    if (word.empty() || *end != '\0' || number < 1 || number > long(kActionCount)) {
      *why = "'" + word + "': type an action's number (1-" + std::to_string(kActionCount) + ") or name";
      return std::nullopt;
    }
    r.action = static_cast<Action>(number - 1);
  }
  if (r.action == Action::kMuteMotor) {
    long motor = -1;
    if (!(in >> motor) || motor < 0 || motor >= long(motor_count)) {
      *why = "mute_motor needs a motor, 0-" + std::to_string(motor_count - 1) + " (\"mute_motor 2\")";
      return std::nullopt;
    }
    r.motor = static_cast<uint8_t>(motor);
  }
  return r;
}

Binding rig_binding(Binding b, const std::vector<size_t> &shown) {
  if (b.action == Action::kMuteMotor && b.motor < shown.size()) b.motor = static_cast<uint8_t>(shown[b.motor]);
  return b;
}

std::string describe_control(const Binding &b) {
  return "CC " + std::to_string(b.cc) +
         (b.channel < 0 ? std::string(" on any channel") : " on channel " + std::to_string(b.channel + 1));
}

std::string save_learned(const std::string &path, const Binding &b) {
  const std::string what = "learned " + describe_control(b) + " -> " + action_name(b.action) +
                           (b.action == Action::kMuteMotor ? " " + std::to_string(b.motor) : "");
  try {
    save_control(path, b);
    return what + ", saved to " + path;
  } catch (const std::exception &e) {
    return what + ", but it is not saved: " + e.what();
  }
}

LearnPrompt::LearnPrompt(std::string path, size_t motor_count) : path_(std::move(path)), motor_count_(motor_count) {
  std::printf("live: learn: type an action (its number or name; mute_motor takes a motor), then move a knob or press a pedal; it is saved to %s\n",
              path_.c_str());
  for (size_t i = 0; i < kActionCount; ++i)
    std::printf("  %2zu %s%s\n", i + 1, action_name(static_cast<Action>(i)),
                action_is_knob(static_cast<Action>(i)) ? " (a knob)" : "");
  std::fflush(stdout);
}

void LearnPrompt::poll(LiveSession &session) {
  if (const auto b = session.learned()) {
    std::printf("live: %s\n", save_learned(path_, *b).c_str());
    std::fflush(stdout);
  }
  while (input_open_) {
    pollfd p{0, POLLIN, 0};
    if (::poll(&p, 1, 0) <= 0) return;
    char buf[256];
    const ssize_t n = ::read(0, buf, sizeof buf);
    if (n <= 0) {
      input_open_ = false;
      return;
    }
    pending_.append(buf, static_cast<size_t>(n));
    for (size_t eol; (eol = pending_.find('\n')) != std::string::npos;) {
      const std::string line = pending_.substr(0, eol);
      pending_.erase(0, eol + 1);
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      std::string why;
      const auto r = parse_learn_request(line, motor_count_, &why);
      if (!r) {
        std::printf("live: learn: %s\n", why.c_str());
      } else if (session.learn(r->action, r->motor)) {
        std::printf("live: learn: move the control for %s\n", action_name(r->action));
      }
      std::fflush(stdout);
    }
  }
}

}  // namespace stepchoir
