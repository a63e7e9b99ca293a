// presets.cpp: the rig file's [[presets]] tables, checked key by key, and each preset's allocator
// configuration over the file's top level (see config.h and live/presets.h).
#include <stdexcept>

#include "config/config.h"
#include "config/toml_read.h"

namespace stepchoir {
namespace toml_read {
namespace {

// Called from: read_preset for each [[presets.zones]] entry.
ZoneSettings read_zone(const std::string &source, const toml::node &node) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "zones: expected [[presets.zones]] tables");
  known_keys(source, *t, {"lowest", "highest", "channel", "motors"}, "[[presets.zones]]");
  ZoneSettings z;
  z.lowest = static_cast<uint8_t>(get_int(source, *t, "lowest", 0, 127, 0));
  z.highest = static_cast<uint8_t>(get_int(source, *t, "highest", 0, 127, 127));
  if (z.lowest > z.highest) fail(source, *t->get("lowest"), "lowest must not be above highest");
  z.channel = static_cast<int8_t>(get_int(source, *t, "channel", 1, 16, 0) - 1);
  z.motors = get_motors(source, *t, "motors", &z.where);
  if (z.motors.empty()) fail(source, t->get("motors") ? *t->get("motors") : node, "a zone needs motors = [...]");
  return z;
}

// Called from: read_preset for each [[presets.motors]] entry: a pool motor and the musical keys
// of [[boards.motors]] (toml_read::read_music), each over the motor's own once the pool is known.
PresetMotorSettings read_preset_motor(const std::string &source, const toml::node &node) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "motors: expected [[presets.motors]] tables");
  known_keys(source, *t, {"motor", "lowest_note", "highest_note", "transpose", "tuning_cents", "muted"},
             "[[presets.motors]]");
  const toml::node *motor = t->get("motor");
  if (!motor) fail(source, node, "a preset's motor entry needs motor = its index (0: the first board's first)");
  PresetMotorSettings pm;
  pm.motor = static_cast<uint8_t>(get_int(source, *t, "motor", 0, AllocatorConfig::kMaxMotors - 1, 0));
  pm.where = where(source, *motor);
  pm.music = read_music(source, *t);
  return pm;
}

// Called from: read_presets for each [[presets]] table; `top`: the file's top level.
PresetSettings read_preset(const std::string &source, const toml::node &node, const LiveConfig &top) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "presets: expected [[presets]] tables");
  known_keys(source, *t,
             {"program", "name", "bank", "policy", "priority", "transpose", "bend_range", "vibrato", "velocity", "glide",
              "mute_motors", "zones", "motors"},
             "[[presets]]");
  PresetSettings p;
  p.where = where(source, node);
  if (!t->get("program")) fail(source, node, "a preset needs program = 1 to 128");
  if (!t->get("name")) fail(source, node, "a preset needs name = \"...\"");
  p.program = static_cast<uint8_t>(get_int(source, *t, "program", 1, 128, 1));
  p.name = get_string(source, *t, "name", "");
  if (p.name.empty()) fail(source, *t->get("name"), "name: must not be empty");
  p.bank = static_cast<int32_t>(get_int(source, *t, "bank", 0, 16383, -1));
  if (t->get("policy")) p.policy = get_policy(source, *t, top.policy);
  p.priority = get_priority(source, *t, top.priority);
  p.transpose = static_cast<int8_t>(get_int(source, *t, "transpose", -48, 48, 0));
  p.bend_range = static_cast<uint8_t>(get_int(source, *t, "bend_range", 0, 24, kDefaultBendSemitones));
  p.vibrato = t->get("vibrato") ? read_vibrato(source, *t->get("vibrato"), top.vibrato, "[presets.vibrato]") : top.vibrato;
  p.velocity =
      t->get("velocity") ? read_velocity(source, *t->get("velocity"), top.velocity, "[presets.velocity]") : top.velocity;
  p.glide = t->get("glide") ? read_glide(source, *t->get("glide"), top.glide, "[presets.glide]") : top.glide;
  p.mute_motors = get_motors(source, *t, "mute_motors", &p.mute_where);
  if (const toml::node *n = t->get("zones")) {
    const toml::array *zones = n->as_array();
    if (!zones) fail(source, *n, "zones: expected [[presets.zones]] tables");
    for (const toml::node &z : *zones) {
      if (p.zones.size() >= AllocatorConfig::kMaxZones) fail(source, z, "a preset has at most 16 zones");
      p.zones.push_back(read_zone(source, z));
    }
    if (p.policy.value_or(top.policy) != Policy::kPoly) fail(source, *n, "zones need policy = \"poly\"");
  }
  if (const toml::node *n = t->get("motors")) {
    const toml::array *motors = n->as_array();
    if (!motors) fail(source, *n, "motors: expected [[presets.motors]] tables");
    for (const toml::node &m : *motors) {
      PresetMotorSettings pm = read_preset_motor(source, m);
      for (const PresetMotorSettings &q : p.motors)
        if (q.motor == pm.motor)
          fail(source, *m.as_table()->get("motor"),
               "motor " + std::to_string(pm.motor) + ": this preset sets it already (" + q.where + ")");
      p.motors.push_back(std::move(pm));
    }
  }
  return p;
}

}  // namespace

std::vector<PresetSettings> read_presets(const std::string &source, const toml::node &node, const LiveConfig &top) {
  const toml::array *presets = node.as_array();
  if (!presets) fail(source, node, "presets: expected [[presets]] tables");
  std::vector<PresetSettings> out;
  for (const toml::node &n : *presets) {
    PresetSettings p = read_preset(source, n, top);
    for (const PresetSettings &q : out)
      if (q.program == p.program && q.bank == p.bank)
        fail(source, *n.as_table()->get("program"),
             "program " + std::to_string(p.program) + (p.bank < 0 ? "" : " in bank " + std::to_string(p.bank)) +
                 ": preset '" + q.name + "' (" + q.where + ") has it already");
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace toml_read

namespace {

// Called from: preset_config. The motors as a bit set, each checked against the pool.
uint32_t motor_bits(const std::vector<uint8_t> &motors, const AllocatorConfig &pool, const std::string &at,
                    const char *key) {
  uint32_t bits = 0;
  for (uint8_t m : motors) {
    if (m >= pool.motor_count)
      throw std::runtime_error(at + ": " + key + ": motor " + std::to_string(m) + ", but the boards have " +
                               std::to_string(pool.motor_count) + " motors (0 to " +
                               std::to_string(pool.motor_count - 1) + ")");
    bits |= uint32_t{1} << m;
  }
  return bits;
}

}  // namespace

AllocatorConfig preset_config(const AllocatorConfig &base, const PresetSettings &p) {
  AllocatorConfig c = base;
  if (p.policy) c.policy = *p.policy;
  c.priority = p.priority;
  c.transpose = p.transpose;
  c.bend_range = p.bend_range;
  c.vibrato = p.vibrato;
  c.velocity = p.velocity;
  c.glide = p.glide;
  c.muted_motors = motor_bits(p.mute_motors, base, p.mute_where, "mute_motors");
  c.zone_count = static_cast<uint8_t>(p.zones.size());
  for (size_t z = 0; z < p.zones.size() && z < AllocatorConfig::kMaxZones; ++z) {
    const ZoneSettings &zs = p.zones[z];
    c.zones[z] = Zone{zs.lowest, zs.highest, zs.channel, motor_bits(zs.motors, base, zs.where, "motors")};
  }
  for (const PresetMotorSettings &pm : p.motors) {
    motor_bits({pm.motor}, base, pm.where, "motor");
    const MotorConfig mc = pm.music.over(base.motors[pm.motor]);
    if (mc.lowest_note > mc.highest_note)
      throw std::runtime_error(pm.where + ": motor " + std::to_string(pm.motor) + ": lowest_note " +
                               std::to_string(mc.lowest_note) + " is above highest_note " +
                               std::to_string(mc.highest_note) + " (a key the entry leaves out is the motor's own)");
    c.motors[pm.motor] = mc;
  }
  if (const char *why = Allocator::validate(c))
    throw std::runtime_error(p.where + ": preset '" + p.name + "': " + why);
  return c;
}

std::vector<LivePreset> live_presets(const LiveConfig &config, const AllocatorConfig &base) {
  std::vector<LivePreset> out;
  for (const PresetSettings &p : config.presets)
    out.push_back(LivePreset{p.name, static_cast<uint8_t>(p.program - 1), p.bank, preset_config(base, p)});
  return out;
}

}  // namespace stepchoir
