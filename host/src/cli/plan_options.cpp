// plan_options.cpp: the plan's options from the command line (see plan_options.h).
#include "cli/plan_options.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace stepchoir {

PlanOptions plan_options(const SongSelection &sel, const std::vector<uint8_t> &ids, std::vector<MotorConfig> music) {
  PlanOptions p;
  p.tempo_scale = sel.tempo;
  p.transpose = sel.transpose;
  p.start_s = sel.start_s;
  p.min_note_s = sel.min_note_ms / 1e3;
  p.tracks = sel.tracks;
  p.mute_tracks = sel.mute_tracks;
  for (int c : sel.channels) p.channels.push_back(c - 1);
  for (int c : sel.mute_channels) p.mute_channels.push_back(c - 1);
  p.motors = std::move(music);
  if (sel.drums >= 0) {
    const auto it = std::find(ids.begin(), ids.end(), sel.drums);
    if (it == ids.end())
      throw std::runtime_error("--drums " + std::to_string(sel.drums) + ": not one of the song's motors");
    p.drum_motor = static_cast<int>(it - ids.begin());
  }
  for (const std::string &k : sel.keep) {
    if (k == "melody") p.keep.push_back(Role::kMelody);
    else if (k == "bass") p.keep.push_back(Role::kBass);
    else if (k == "inner") p.keep.push_back(Role::kInner);
    else throw std::runtime_error("--keep: '" + k + "': expected melody, bass or inner");
  }
  for (const std::string &v : sel.voices) {
    LineSelector line;
    size_t used = 0;
    int value = -1;
    try {
      if (v.size() > 1 && (v[0] == 't' || v[0] == 'c')) value = std::stoi(v.substr(1), &used);
    } catch (const std::exception &) {
    }
    line.by_channel = !v.empty() && v[0] == 'c';
    if (value < 0 || used + 1 != v.size() || (line.by_channel && (value < 1 || value > 16)))
      throw std::runtime_error("--voices: '" + v + "': expected tN (track N) or cN (MIDI channel N, 1-16)");
    line.value = line.by_channel ? value - 1 : value;
    p.voices.push_back(line);
  }
  return p;
}

}  // namespace stepchoir
