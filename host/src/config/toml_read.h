// toml_read.h: the checked readers the rig file's parsers share (config.cpp, presets.cpp): every
// mistake becomes std::runtime_error "SOURCE:LINE:COLUMN: what is wrong". Internal to config/.
#ifndef STEPCHOIR_HOST_CONFIG_TOML_READ_H
#define STEPCHOIR_HOST_CONFIG_TOML_READ_H

#include <toml++/toml.h>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include "config/config.h"
#include "live/allocator.h"

namespace stepchoir::toml_read {

// "SOURCE:LINE:COLUMN" of a node. Called from: fail, and presets for errors found later.
std::string where(const std::string &source, const toml::node &node);

// Throws "SOURCE:LINE:COLUMN: message" for a node. Called from: every check.
[[noreturn]] void fail(const std::string &source, const toml::node &node, const std::string &message);

// Refuses keys the table does not know (a typo must not be silently ignored); `where` names the
// table in the message.
void known_keys(const std::string &source, const toml::table &table, std::initializer_list<const char *> keys,
                const std::string &where);

// A key's value, or fallback when absent: an integer in [lo, hi]; a finite number (integer or
// float) in [lo, hi]; a string; a boolean.
int64_t get_int(const std::string &source, const toml::table &t, const char *key, int64_t lo, int64_t hi,
                int64_t fallback);
double get_number(const std::string &source, const toml::table &t, const char *key, double lo, double hi,
                  double fallback);
std::string get_string(const std::string &source, const toml::table &t, const char *key, const std::string &fallback);
bool get_bool(const std::string &source, const toml::table &t, const char *key, bool fallback);

// The tables [allocation], [vibrato], [velocity] and [glide] share with [[presets]]: each reads
// node (which must be a table, `name` in messages) over `base`, so a key left out keeps base's value.
VibratoConfig read_vibrato(const std::string &source, const toml::node &node, VibratoConfig base, const std::string &name);
VelocityConfig read_velocity(const std::string &source, const toml::node &node, VelocityConfig base,
                             const std::string &name);
GlideConfig read_glide(const std::string &source, const toml::node &node, GlideConfig base, const std::string &name);
// The musical keys of a motor's table t ([[boards.motors]], [[presets.motors]]): lowest_note and
// highest_note (MIDI notes 0-127), transpose (-48..48), tuning_cents (-1200..1200), muted (an
// array of MIDI notes). Refuses lowest_note above highest_note when t sets both; the range they
// make with the motor's other values is the caller's to check.
MusicSettings read_music(const std::string &source, const toml::table &t);
// policy / priority keys of table t ("poly", "oldest", ...), or fallback when absent.
Policy get_policy(const std::string &source, const toml::table &t, Policy fallback);
Priority get_priority(const std::string &source, const toml::table &t, Priority fallback);

// A key holding an array of pool motor indexes (0-31), and where it is (*at); empty when absent.
// Called from: the [[presets]] and [setlist] readers.
std::vector<uint8_t> get_motors(const std::string &source, const toml::table &t, const char *key, std::string *at);

// [[presets]] (config/presets.cpp): every preset table over the top level `top` already read.
// Called from: parse_config.
std::vector<PresetSettings> read_presets(const std::string &source, const toml::node &node, const LiveConfig &top);

// [setlist] (config/setlist.cpp): its items, over the presets already read into top.
// Called from: parse_config.
std::vector<SetlistItem> read_setlist(const std::string &source, const toml::node &node, const LiveConfig &top);

// [[controls]] (config/controls.cpp): every learned controller. Called from: parse_config.
std::vector<ControlSettings> read_controls(const std::string &source, const toml::node &node);

}  // namespace stepchoir::toml_read

#endif  // STEPCHOIR_HOST_CONFIG_TOML_READ_H
