// drum_bench.cpp: stepchoir-bench-drums: how the drum voice's bursts sound. Reads a song of
// drum hits, the trace and the WAV of `stepchoir render SONG --drums 0`, and writes a table per
// General MIDI key: the burst's note and length as planned, and as heard in the WAV (pitch from
// the step rate, length within 20 dB of the peak, level). Run by tools/bench/run-drum-bench.sh.
//
// Usage: stepchoir-bench-drums OUT.md COMMAND SONG TRACE WAV
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "hit_sound.h"
#include "player/drum_voice.h"
#include "render.h"
#include "song/song.h"
#include "trace.h"

using namespace stepchoir;

namespace {

const char *gm_name(int key) {
  static const std::map<int, const char *> names = {
      {35, "acoustic bass drum"}, {36, "bass drum 1"}, {37, "side stick"},   {38, "acoustic snare"},
      {39, "hand clap"},          {40, "electric snare"}, {41, "low floor tom"}, {42, "closed hi-hat"},
      {43, "high floor tom"},     {44, "pedal hi-hat"}, {45, "low tom"},       {46, "open hi-hat"},
      {47, "low-mid tom"},        {48, "hi-mid tom"},   {49, "crash cymbal 1"}, {50, "high tom"},
      {51, "ride cymbal 1"},      {52, "chinese cymbal"}, {53, "ride bell"},   {55, "splash cymbal"},
      {57, "crash cymbal 2"},     {59, "ride cymbal 2"}};
  auto it = names.find(key);
  return it == names.end() ? "other" : it->second;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: stepchoir-bench-drums OUT.md COMMAND SONG TRACE WAV\n");
    return 2;
  }
  try {
    const Song song = read_song_file(argv[3]);
    const sc::trace::Trace trace = sc::trace::read_trace(argv[4]);
    int rate = 0;
    const std::vector<int16_t> samples = sc::trace::read_wav(argv[5], &rate);
    const std::vector<sc::trace::HitSound> hits = sc::trace::measure_hits(trace, 0, samples, rate);
    std::vector<int> keys;
    for (const SongNote &n : song.notes)
      if (n.percussion) keys.push_back(n.midi_note);
    if (keys.size() != hits.size()) {
      std::fprintf(stderr, "stepchoir-bench-drums: %zu hits in the song, %zu in the trace\n", keys.size(), hits.size());
      return 1;
    }
    // Per key, in the song's order of first appearance.
    std::vector<int> order;
    std::map<int, std::vector<const sc::trace::HitSound *>> by_key;
    for (size_t i = 0; i < keys.size(); ++i) {
      if (by_key[keys[i]].empty()) order.push_back(keys[i]);
      by_key[keys[i]].push_back(&hits[i]);
    }
    std::ofstream out(argv[1]);
    out << "# Drum voice: each burst as heard\n\n"
        << "`" << argv[2] << "`: `stepchoir render " << argv[3]
        << " --drums 0` through the real firmware on the virtual board, measured in the WAV it writes "
           "(`stepchoir-bench-drums`, `tools/trace/hit_sound.h`). Medians over each key's hits. Pitch is the "
           "burst's step rate; heard is how long the sound stays within 20 dB of its peak (the burst plus the "
           "motor's ring); the level is the peak of a 5 ms RMS window, the whole WAV normalised to -1 dBFS.\n\n"
        << "| GM key | Sound | Planned note | Heard note | Hz | Planned ms | Heard ms | Steps | Level dBFS |\n"
        << "|---|---|---|---|---|---|---|---|---|\n";
    for (int key : order) {
      const DrumBurst b = drum_burst(uint8_t(key));
      std::vector<double> note, hz, heard, steps, level;
      for (const sc::trace::HitSound *h : by_key[key]) {
        note.push_back(h->midi_note);
        hz.push_back(h->step_hz);
        heard.push_back(h->heard_s * 1000);
        steps.push_back(double(h->steps));
        level.push_back(h->peak_dbfs);
      }
      char row[256];
      std::snprintf(row, sizeof row, "| %d | %s | %d | %.2f | %.1f | %.0f | %.1f | %.0f | %.1f |\n", key, gm_name(key),
                    b.note, median(note), median(hz), b.length_s * 1000, median(heard), median(steps), median(level));
      out << row;
    }
    out << "\nThe test `render: each drum kind sounds distinct in the WAV` asks that any two kinds differ by 3 "
           "semitones or 1.5 times in heard length, kick under toms under snare, the metal two octaves above.\n";
    if (!out) throw std::runtime_error(std::string(argv[1]) + ": write failed");
    std::printf("wrote %s\n", argv[1]);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir-bench-drums: %s\n", e.what());
    return 1;
  }
  return 0;
}
