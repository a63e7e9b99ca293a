// song_bench.cpp: time and peak memory to read a 1 MB MIDI file, and time to plan and write the
// sample songs' G-code; writes bench/results/song-parse.md with the command that produced it.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "smf_builder.h"
#include "song/gcode.h"
#include "song/song.h"

using namespace stepchoir;

namespace {

// A format-1 MIDI file of about target_bytes: a tempo track with a change every beat and 15 note
// tracks using running status. Called by main.
smf::Bytes big_midi(size_t target_bytes) {
  std::mt19937 rng(7);
  std::vector<smf::Track> tracks(16);
  for (int beat = 0; beat < 4000; ++beat) tracks[0].tempo(beat ? 480 : 0, 300000 + rng() % 400000);
  tracks[0].end();
  size_t bytes = tracks[0].bytes.size();
  for (size_t t = 1; t < tracks.size(); ++t) {
    auto &tr = tracks[t];
    tr.ev(0, {static_cast<uint8_t>(0x90 | (t - 1)), 60, 100});
    tr.ev(120, {60, 0});
    while (tr.bytes.size() < (target_bytes - bytes) / (tracks.size() - t)) {
      const uint8_t note = static_cast<uint8_t>(36 + rng() % 48);
      tr.ev(rng() % 60, {note, static_cast<uint8_t>(1 + rng() % 127)}).ev(30 + rng() % 400, {note, 0});
    }
    tr.end();
    bytes += tr.bytes.size();
  }
  return smf::file(1, 480, tracks);
}

// Peak resident memory of a child that runs work, kB. Called by main.
template <typename F>
long child_peak_kb(F work) {
  const pid_t pid = fork();
  if (pid == 0) {
    work();
    _exit(0);
  }
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  return usage.ru_maxrss;
}

// Median wall time of runs of work, seconds. Called by main.
template <typename F>
double median_s(int runs, F work) {
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    const auto start = std::chrono::steady_clock::now();
    work();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

// Called by the shell (tools/bench/run-song-bench.sh).
int main(int argc, char **argv) {
  const std::string out_dir = argc > 1 ? argv[1] : "bench/results";
  const std::string songs_dir = argc > 2 ? argv[2] : "tests/data/songs";
  const std::string mid = out_dir + "/.song-bench.mid";
  const smf::Bytes bytes = big_midi(1 << 20);
  std::ofstream(mid, std::ios::binary).write(reinterpret_cast<const char *>(bytes.data()), static_cast<long>(bytes.size()));
  const Song song = read_song_file(mid);
  const double parse_s = median_s(9, [&] { read_song_file(mid); });
  const long base_kb = child_peak_kb([] {});
  const long read_kb = child_peak_kb([&] {
    std::vector<uint8_t> copy(bytes.size());
    std::ifstream(mid, std::ios::binary).read(reinterpret_cast<char *>(copy.data()), static_cast<long>(copy.size()));
  });
  const long parse_kb = child_peak_kb([&] { read_song_file(mid); });
  std::remove(mid.c_str());

  const std::string md = out_dir + "/song-parse.md";
  std::FILE *f = std::fopen(md.c_str(), "w");
  if (!f) return 1;
  std::fprintf(f, "# Song files: reading and G-code planning\n\nCommand: `tools/bench/run-song-bench.sh` "
                  "(builds `stepchoir-bench-song`, RelWithDebInfo, runs it on this machine: 2 shared cores).\n\n");
  std::fprintf(f, "## Reading a 1 MB Standard MIDI File\n\nFormat 1, 16 tracks (a tempo track with %d tempo changes, "
                  "15 note tracks with running status), %zu bytes, %zu notes, %.1f s of music.\n\n",
               4000, bytes.size(), song.notes.size(), song.duration_s);
  std::fprintf(f, "| what | figure |\n|---|---|\n| read_song_file, median of 9 | %.1f ms |\n", parse_s * 1e3);
  std::fprintf(f, "| peak RSS of a process that reads the file | %ld kB |\n", read_kb);
  std::fprintf(f, "| peak RSS of a process that reads and parses it | %ld kB |\n", parse_kb);
  std::fprintf(f, "| peak RSS of an empty child (baseline: the benchmark's own pages) | %ld kB |\n", base_kb);
  std::fprintf(f, "| so reading and parsing take about | %ld kB (%.1f x the file) |\n\n", parse_kb - base_kb,
               (parse_kb - base_kb) * 1024.0 / static_cast<double>(bytes.size()));
  std::fprintf(f, "## G-code for the sample songs (generic preset, plan and write, median of 9)\n\n"
                  "| song | notes | moves and dwells | G-code bytes | time |\n|---|---|---|---|---|\n");
  for (const char *name : {"9th.sng", "canon.sng", "furelise.sng"}) {
    const Song s = read_song_file(songs_dir + "/" + name);
    const Printer &p = find_printer(builtin_printers(), "generic");
    GcodeOptions o;
    o.fold_octaves = true;
    size_t text_bytes = 0, moves = 0;
    const double t = median_s(9, [&] {
      const GcodePlan plan = plan_gcode(s, p, o);
      text_bytes = write_gcode(plan, p, o, name).size();
      moves = plan.steps.size();
    });
    std::fprintf(f, "| %s | %zu | %zu | %zu | %.2f ms |\n", name, s.notes.size(), moves, text_bytes, t * 1e3);
  }
  std::fclose(f);
  std::printf("wrote %s\n", md.c_str());
  return 0;
}
