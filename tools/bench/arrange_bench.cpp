// arrange_bench.cpp: the arranger against the planner it replaced, on General MIDI band
// arrangements (tools/bench/run-arrange-bench.sh picks the files). Per file, for 4 and 5 motors:
// melody and bass coverage, drum hits sung, notes dropped (tests/kit/arrangement_metrics.h).
// Writes a Markdown table to the file given, with the command that made it.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "arrangement_metrics.h"
#include "baseline_plan.h"
#include "player/plan.h"
#include "song/song.h"

namespace {

// The targets the arrangement issue sets, with 4 motors.
constexpr double kMelodyTarget = 0.97, kBassTarget = 0.90;

std::string pct(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", 100 * v);
  return b;
}

// The file's folder and name ("songs/band-blues.mid"): two examples may share a name.
std::string base_name(const std::string &path) {
  const size_t last = path.rfind('/');
  if (last == std::string::npos || last == 0) return path;
  return path.substr(path.rfind('/', last - 1) + 1);
}

}  // namespace

int main(int argc, char **argv) {
  using namespace stepchoir;
  if (argc < 4) {
    std::cerr << "usage: stepchoir-bench-arrange OUT.md COMMAND FILE.mid...\n";
    return 2;
  }
  const std::string out_path = argv[1], command = argv[2];
  std::string rows;
  size_t files = 0, met = 0;
  for (int a = 3; a < argc; ++a) {
    Song song;
    try {
      song = read_song_file(argv[a]);
    } catch (const SongError &e) {
      std::cerr << e.what() << "\n";
      return 1;
    }
    ++files;
    bool file_met = true;
    for (size_t motors : {4, 5}) {
      PlanOptions o;
      o.motors.assign(motors, MotorConfig{});
      const kit::ArrangementFigures now = kit::measure_arrangement(song, plan_song(song, o));
      const kit::ArrangementFigures was = kit::measure_arrangement(song, plan_song_baseline(song, o));
      if (motors == 4)
        file_met = now.melody >= kMelodyTarget && now.bass >= kBassTarget && now.drum_hits_sung == 0;
      rows += "| " + base_name(argv[a]) + " | " + std::to_string(now.notes) + " (" + std::to_string(now.percussion) +
              ") | " + std::to_string(motors) + " | " + pct(now.melody) + " | " + pct(was.melody) + " | " +
              pct(now.bass) + " | " + pct(was.bass) + " | " + std::to_string(now.drum_hits_sung) + " | " +
              std::to_string(was.drum_hits_sung) + " | " + std::to_string(now.dropped - now.percussion) + " | " +
              std::to_string(was.dropped) + " |\n";
      std::printf("%-28s %zu motors: melody %s (was %s), bass %s (was %s), drums sung %zu (was %zu)\n",
                  base_name(argv[a]).c_str(), motors, pct(now.melody).c_str(), pct(was.melody).c_str(),
                  pct(now.bass).c_str(), pct(was.bass).c_str(), now.drum_hits_sung, was.drum_hits_sung);
    }
    met += file_met;
  }
  std::ofstream out(out_path);
  out << "# Arrangement: what a listener hears of a band arrangement on a few motors\n\n"
      << "Command: `" << command << "`\n\n"
      << "Per file and motor count: melody coverage (the share of the time the song's highest sounding "
         "pitched note's pitch class sounds on a motor), bass coverage (the same for the lowest), "
         "percussion notes sung as pitches, and pitched notes left out (merged doublings, notes too short, "
         "notes with every motor busy). \"now\" is `stepchoir play`'s planner (host/src/player/plan.cpp, "
         "arranger.cpp); \"before\" is the planner it replaced (tools/bench/baseline_plan.cpp), whose "
         "dropped count has no percussion to leave out because it sang it. Definitions: "
         "tests/kit/arrangement_metrics.h.\n\n"
      << "Targets with 4 motors: melody >= 97 %, bass >= 90 %, no drum hit sung. Files meeting all three: " << met
      << " of " << files << ".\n\n"
      << "| file | notes (percussion) | motors | melody now | melody before | bass now | bass before | drums sung now | "
         "drums sung before | dropped now | dropped before |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|\n"
      << rows;
  std::printf("files meeting the 4-motor targets: %zu of %zu; table in %s\n", met, files, out_path.c_str());
  return 0;
}
