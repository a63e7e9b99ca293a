// toml_read.cpp: the rig file's checked readers (see toml_read.h).
#include "config/toml_read.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "config/config.h"

namespace stepchoir::toml_read {

std::string where(const std::string &source, const toml::node &node) {
  const auto &begin = node.source().begin;
  return source + ":" + std::to_string(begin.line) + ":" + std::to_string(begin.column);
}

void fail(const std::string &source, const toml::node &node, const std::string &message) {
  throw std::runtime_error(where(source, node) + ": " + message);
}

void known_keys(const std::string &source, const toml::table &table, std::initializer_list<const char *> keys,
                const std::string &where) {
  for (const auto &[key, node] : table) {
    bool known = false;
    for (const char *k : keys) known = known || key.str() == k;
    if (!known) fail(source, node, "unknown key '" + std::string(key.str()) + "' in " + where);
  }
}

int64_t get_int(const std::string &source, const toml::table &t, const char *key, int64_t lo, int64_t hi,
                int64_t fallback) {
  const toml::node *n = t.get(key);
  if (!n) return fallback;
  const auto v = n->value<int64_t>();
  if (!n->is_integer() || !v) fail(source, *n, std::string(key) + ": expected an integer");
  if (*v < lo || *v > hi)
    fail(source, *n, std::string(key) + " = " + std::to_string(*v) + ": must be " + std::to_string(lo) + " to " +
                         std::to_string(hi));
  return *v;
}

double get_number(const std::string &source, const toml::table &t, const char *key, double lo, double hi,
                  double fallback) {
  const toml::node *n = t.get(key);
  if (!n) return fallback;
  const auto v = n->value<double>();
  if (!v || !std::isfinite(*v)) fail(source, *n, std::string(key) + ": expected a number");
  if (*v < lo || *v > hi) {
    char range[64];
    std::snprintf(range, sizeof range, "%g to %g", lo, hi);
    fail(source, *n, std::string(key) + ": must be " + range);
  }
  return *v;
}

std::string get_string(const std::string &source, const toml::table &t, const char *key, const std::string &fallback) {
  const toml::node *n = t.get(key);
  if (!n) return fallback;
  if (!n->is_string()) fail(source, *n, std::string(key) + ": expected a string");
  return *n->value<std::string>();
}

bool get_bool(const std::string &source, const toml::table &t, const char *key, bool fallback) {
  const toml::node *n = t.get(key);
  if (!n) return fallback;
  if (!n->is_boolean()) fail(source, *n, std::string(key) + ": expected true or false");
  return *n->value<bool>();
}

// Called from: the read_* functions below. The node as a table, or a mistake naming it.
static const toml::table &as_table(const std::string &source, const toml::node &node, const std::string &name) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, name + " must be a table");
  return *t;
}

VibratoConfig read_vibrato(const std::string &source, const toml::node &node, VibratoConfig v, const std::string &name) {
  const toml::table &t = as_table(source, node, name);
  known_keys(source, t, {"rate_hz", "depth_cents", "fade_ms", "aftertouch"}, name);
  v.rate_hz = get_number(source, t, "rate_hz", 0.1, 20.0, v.rate_hz);
  v.depth_cents = get_number(source, t, "depth_cents", 0.0, 200.0, v.depth_cents);
  v.fade_ms = get_number(source, t, "fade_ms", 0.0, 5000.0, v.fade_ms);
  v.aftertouch = get_bool(source, t, "aftertouch", v.aftertouch);
  return v;
}

VelocityConfig read_velocity(const std::string &source, const toml::node &node, VelocityConfig v,
                             const std::string &name) {
  const toml::table &t = as_table(source, node, name);
  known_keys(source, t, {"double_at", "triple_at"}, name);
  v.double_at = static_cast<uint8_t>(get_int(source, t, "double_at", 0, 127, v.double_at));
  v.triple_at = static_cast<uint8_t>(get_int(source, t, "triple_at", 0, 127, v.triple_at));
  return v;
}

GlideConfig read_glide(const std::string &source, const toml::node &node, GlideConfig g, const std::string &name) {
  const toml::table &t = as_table(source, node, name);
  known_keys(source, t, {"time_ms", "on"}, name);
  g.time_ms = static_cast<uint16_t>(get_int(source, t, "time_ms", 0, kGlideMaxMs, g.time_ms));
  g.on = get_bool(source, t, "on", g.on);
  return g;
}

MusicSettings read_music(const std::string &source, const toml::table &t) {
  MusicSettings s;
  if (t.get("lowest_note")) s.lowest_note = static_cast<uint8_t>(get_int(source, t, "lowest_note", 0, 127, 0));
  if (t.get("highest_note")) s.highest_note = static_cast<uint8_t>(get_int(source, t, "highest_note", 0, 127, 0));
  if (s.lowest_note && s.highest_note && *s.lowest_note > *s.highest_note)
    fail(source, t, "lowest_note must not be above highest_note");
  if (t.get("transpose")) s.transpose = static_cast<int8_t>(get_int(source, t, "transpose", -48, 48, 0));
  if (t.get("tuning_cents")) s.tuning_cents = get_number(source, t, "tuning_cents", -1200, 1200, 0);
  if (const toml::node *n = t.get("muted")) {
    const toml::array *a = n->as_array();
    if (!a) fail(source, *n, "muted: expected an array of MIDI notes");
    s.muted.emplace();
    for (const toml::node &e : *a) {
      const auto v = e.value<int64_t>();
      if (!e.is_integer() || !v || *v < 0 || *v > 127) fail(source, e, "muted: MIDI notes are 0 to 127");
      s.muted->set(static_cast<size_t>(*v));
    }
  }
  return s;
}

Policy get_policy(const std::string &source, const toml::table &t, Policy fallback) {
  const toml::node *n = t.get("policy");
  if (!n) return fallback;
  try {
    return parse_policy(get_string(source, t, "policy", ""));
  } catch (const std::invalid_argument &e) {
    fail(source, *n, e.what());
  }
}

Priority get_priority(const std::string &source, const toml::table &t, Priority fallback) {
  const toml::node *n = t.get("priority");
  if (!n) return fallback;
  const std::string priority = get_string(source, t, "priority", "");
  if (priority == "oldest") return Priority::kOldest;
  if (priority == "lowest") return Priority::kLowest;
  if (priority == "highest") return Priority::kHighest;
  fail(source, *n, "priority '" + priority + "': expected oldest, lowest or highest");
}

std::vector<uint8_t> get_motors(const std::string &source, const toml::table &t, const char *key, std::string *at) {
  std::vector<uint8_t> motors;
  const toml::node *n = t.get(key);
  if (!n) return motors;
  const toml::array *a = n->as_array();
  if (!a) fail(source, *n, std::string(key) + ": expected an array of motor indexes");
  for (const toml::node &e : *a) {
    const auto v = e.value<int64_t>();
    if (!e.is_integer() || !v || *v < 0 || *v >= int64_t{AllocatorConfig::kMaxMotors})
      fail(source, e, std::string(key) + ": motor indexes are 0 to 31 (motor 0 is the first board's first)");
    motors.push_back(static_cast<uint8_t>(*v));
  }
  *at = where(source, *n);
  return motors;
}

}  // namespace stepchoir::toml_read
