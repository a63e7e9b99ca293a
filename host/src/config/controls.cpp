// controls.cpp: the rig file's [[controls]] tables (learned controllers, live/stage.h): reading
// them, and saving a newly learned one into the file (see config.h).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "config/config.h"
#include "config/toml_read.h"

namespace stepchoir {
namespace toml_read {
namespace {

// Called from: read_controls for each table, and save_control for the tables already in a file.
ControlSettings read_control(const std::string &source, const toml::node &node) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "controls: expected [[controls]] tables");
  known_keys(source, *t, {"action", "cc", "channel", "motor"}, "[[controls]]");
  ControlSettings c;
  c.where = where(source, node);
  const toml::node *action = t->get("action");
  if (!action) fail(source, node, "a control needs action = \"...\" (transpose_up, preset_next, panic, ...)");
  const auto parsed = parse_action(get_string(source, *t, "action", ""));
  if (!parsed) {
    std::string names;
    for (size_t i = 0; i < kActionCount; ++i) names += std::string(i ? ", " : "") + action_name(static_cast<Action>(i));
    fail(source, *action, "action: expected one of " + names);
  }
  if (!t->get("cc")) fail(source, node, "a control needs cc = 0 to 119 (its controller number)");
  c.binding.action = *parsed;
  c.binding.cc = static_cast<uint8_t>(get_int(source, *t, "cc", 0, 119, 0));
  c.binding.channel = static_cast<int8_t>(get_int(source, *t, "channel", 1, 16, 0) - 1);
  if (*parsed == Action::kMuteMotor && !t->get("motor")) fail(source, node, "mute_motor needs motor = N (0-31)");
  if (*parsed != Action::kMuteMotor && t->get("motor")) fail(source, *t->get("motor"), "motor: only mute_motor takes one");
  c.binding.motor = static_cast<uint8_t>(get_int(source, *t, "motor", 0, AllocatorConfig::kMaxMotors - 1, 0));
  return c;
}

}  // namespace

std::vector<ControlSettings> read_controls(const std::string &source, const toml::node &node) {
  const toml::array *a = node.as_array();
  if (!a) fail(source, node, "controls: expected [[controls]] tables");
  std::vector<ControlSettings> controls;
  for (const toml::node &e : *a) {
    if (controls.size() == ControlMap::kMaxBindings) fail(source, e, "at most 64 controls");
    controls.push_back(read_control(source, e));
  }
  return controls;
}

}  // namespace toml_read

std::vector<Binding> live_controls(const LiveConfig &config, size_t motor_count) {
  std::vector<Binding> out;
  for (const ControlSettings &c : config.controls) {
    if (c.binding.action == Action::kMuteMotor && c.binding.motor >= motor_count)
      throw std::runtime_error(c.where + ": motor " + std::to_string(c.binding.motor) + ": the boards have " +
                               std::to_string(motor_count) + " motors (0-" + std::to_string(motor_count - 1) + ")");
    out.push_back(c.binding);
  }
  return out;
}

std::string control_text(const Binding &b) {
  std::string text = "[[controls]]\naction = \"" + std::string(action_name(b.action)) + "\"\n";
  text += "cc = " + std::to_string(b.cc) + "\n";
  if (b.channel >= 0) text += "channel = " + std::to_string(b.channel + 1) + "\n";
  if (b.action == Action::kMuteMotor) text += "motor = " + std::to_string(b.motor) + "\n";
  return text;
}

namespace {

// Whether a header line opens a table: "[name]" or "[[name]]", spaces and a comment allowed.
bool is_header(const std::string &line, std::string *name) {
  const size_t open = line.find_first_not_of(" \t");
  if (open == std::string::npos || line[open] != '[') return false;
  const size_t close = line.find(']', open);
  if (close == std::string::npos) return false;
  std::string inner = line.substr(open, close - open);
  while (!inner.empty() && (inner.front() == '[' || inner.front() == ' ')) inner.erase(0, 1);
  while (!inner.empty() && inner.back() == ' ') inner.pop_back();
  *name = inner;
  return true;
}

// Whether two bindings clash: the same controller and channel, or the same action (and motor).
bool clashes(const Binding &a, const Binding &b) {
  if (a.cc == b.cc && a.channel == b.channel) return true;
  return a.action == b.action && (a.action != Action::kMuteMotor || a.motor == b.motor);
}

}  // namespace

void save_control(const std::string &path, const Binding &b) {
  std::string text;
  if (std::ifstream in(path); in) {
    std::stringstream s;
    s << in.rdbuf();
    text = s.str();
  }
  // The file, less every [[controls]] table b replaces: a table runs from its header to the next.
  std::istringstream lines(text);
  std::string line, kept, block, name;
  bool in_control = false;
  auto end_block = [&] {
    if (!in_control) return;
    const toml::table parsed = toml::parse(block, path);
    const ControlSettings old = toml_read::read_control(path, *parsed.get("controls")->as_array()->get(0));
    if (!clashes(old.binding, b)) kept += block;
    block.clear();
    in_control = false;
  };
  while (std::getline(lines, line)) {
    if (is_header(line, &name)) {
      end_block();
      in_control = name == "controls";
    }
    (in_control ? block : kept) += line + "\n";
  }
  end_block();
  if (!kept.empty() && kept.back() != '\n') kept += "\n";
  if (!kept.empty() && kept.size() > 1 && kept.substr(kept.size() - 2) != "\n\n") kept += "\n";
  if (kept.empty()) kept = "# stepchoir rig file (stepchoir config --print-default shows every setting)\n\n";
  kept += control_text(b);
  parse_config(kept, path);  // the file must still load
  const std::filesystem::path target(path);
  if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path());
  const std::string temporary = path + ".learn-" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::trunc);
    out << kept;
    if (!out.flush()) throw std::runtime_error(path + ": cannot write the learned control (" + temporary + ")");
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    std::remove(temporary.c_str());
    throw std::runtime_error(path + ": cannot replace it with the learned control");
  }
}

}  // namespace stepchoir
