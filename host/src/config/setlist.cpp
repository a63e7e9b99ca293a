// setlist.cpp: the rig file's [setlist]: an ordered list of presets and songs that the performer
// steps through on stage (cli/setlist_runner.h plays it). Each item names a preset of the file
// (by name), a song file, or both:
//   [setlist]
//   items = [{ preset = "plain" }, { song = "ode.mid", preset = "duet", song_motors = [0, 1] }]
#include <filesystem>

#include "config/config.h"
#include "config/toml_read.h"

namespace stepchoir::toml_read {
namespace {

// Called from: read_setlist for each item.
SetlistItem read_item(const std::string &source, const toml::node &node, const LiveConfig &top) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "items: expected tables, { preset = \"...\" } or { song = \"...\", ... }");
  known_keys(source, *t, {"name", "preset", "song", "song_motors", "tempo", "transpose"}, "a setlist item");
  SetlistItem item;
  item.where = where(source, node);
  if (const toml::node *p = t->get("preset")) {
    const std::string name = get_string(source, *t, "preset", "");
    for (size_t i = 0; i < top.presets.size() && item.preset < 0; ++i)
      if (top.presets[i].name == name) item.preset = static_cast<int>(i);
    if (item.preset < 0) fail(source, *p, "preset '" + name + "': no [[presets]] table has that name");
  }
  item.song = get_string(source, *t, "song", "");
  if (!item.song.empty() && std::filesystem::path(item.song).is_relative())
    item.song = (std::filesystem::path(source).parent_path() / item.song).lexically_normal().string();
  if (item.preset < 0 && item.song.empty()) fail(source, node, "a setlist item needs a preset, a song or both");
  std::string motors_at;
  item.song_motors = get_motors(source, *t, "song_motors", &motors_at);
  if (item.song.empty() && t->get("song_motors")) fail(source, *t->get("song_motors"), "song_motors: the item has no song");
  if (!item.song.empty() && item.song_motors.empty()) {
    if (item.preset >= 0) item.song_motors = top.presets[static_cast<size_t>(item.preset)].mute_motors;
    if (item.song_motors.empty())
      fail(source, node, "a song item needs song_motors = [...], or a preset whose mute_motors the song plays");
  }
  item.tempo = get_number(source, *t, "tempo", 0.05, 20.0, 1.0);
  item.transpose = static_cast<int>(get_int(source, *t, "transpose", -48, 48, 0));
  item.name = get_string(source, *t, "name", "");
  if (item.name.empty())
    item.name = item.preset >= 0 ? top.presets[static_cast<size_t>(item.preset)].name
                                 : std::filesystem::path(item.song).filename().string();
  return item;
}

}  // namespace

std::vector<SetlistItem> read_setlist(const std::string &source, const toml::node &node, const LiveConfig &top) {
  const toml::table *t = node.as_table();
  if (!t) fail(source, node, "[setlist] must be a table with items = [...]");
  known_keys(source, *t, {"items"}, "[setlist]");
  const toml::node *n = t->get("items");
  if (!n) fail(source, node, "[setlist] needs items = [...]");
  const toml::array *a = n->as_array();
  if (!a || a->empty()) fail(source, *n, "items: expected a list of items");
  std::vector<SetlistItem> items;
  for (const toml::node &e : *a) items.push_back(read_item(source, e, top));
  return items;
}

}  // namespace stepchoir::toml_read
