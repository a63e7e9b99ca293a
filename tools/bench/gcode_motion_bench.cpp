// gcode_motion_bench.cpp: how much of each note a printer plays at its pitch, on the firmware
// motion model (song/motion_model.h), with the printer's own limits and with the limits the song
// header sets. Writes bench/results/gcode.md with the command that produced it.
// Usage: stepchoir-bench-gcode RESULTS_DIR SONGS_DIR
#include <cstdio>
#include <string>

#include "song/gcode.h"
#include "song/motion_model.h"
#include "song/song.h"

using namespace stepchoir;

int main(int argc, char **argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s RESULTS_DIR SONGS_DIR\n", argv[0]);
    return 2;
  }
  const std::string out_path = std::string(argv[1]) + "/gcode.md", songs = argv[2];
  std::FILE *out = std::fopen(out_path.c_str(), "w");
  if (!out) {
    std::perror(out_path.c_str());
    return 1;
  }
  std::fprintf(out,
               "# G-code: note time in tune on the firmware motion model\n\n"
               "Command: `tools/bench/run-song-bench.sh` (stepchoir-bench-gcode). Each sample song is written for each\n"
               "preset (`--fold-octaves`, the preset's firmware), then planned by the model of that firmware's motion\n"
               "planner (`host/src/song/motion_model.h`: trapezoids, look-ahead, its junction rule). In tune: within 5\n"
               "cents of the note's speed. *Own*: the G-code written with `--keep-limits`, on the printer's own\n"
               "limits; *header*: as `stepchoir gcode` writes it, with the header's acceleration and corner speed.\n"
               "Moves in tune: moves at least 90 %% of whose time is in tune. Target: at least 95 %% of note time in\n"
               "tune on the Ender-3 and Voron presets.\n\n"
               "| song | printer | firmware | accel own / header (mm/s^2) | in tune, own | in tune, header | moves in tune, own | moves in tune, header | song length, header / written |\n"
               "|---|---|---|---|---|---|---|---|---|\n");
  int worst_ok = 1;
  for (const Printer &p : builtin_printers())
    for (const char *file : {"9th.sng", "canon.sng", "furelise.sng"}) {
      const Song s = read_song_file(songs + "/" + file);
      GcodeOptions o;
      o.fold_octaves = true;
      o.flavor = p.motion.firmware;
      const HeaderEffect e = header_effect(s, p, o);
      const MotionReport &before = e.own, &after = e.header;
      std::fprintf(out, "| %s | %s | %s | %.0f / %.0f | %.1f %% | %.1f %% | %zu of %zu | %zu of %zu | %.4f |\n", file,
                   p.name.c_str(), firmware_name(p.motion.firmware), p.motion.accel_stock, p.motion.accel_safe,
                   100 * before.share(), 100 * after.share(), before.moves_in_tune, before.moves, after.moves_in_tune,
                   after.moves, after.note_s / after.written_s);
      if ((p.name == "ender3" || p.name == "voron24") && after.share() < 0.95) worst_ok = 0;
    }
  std::fprintf(out, "\nTarget met: %s.\n", worst_ok ? "yes" : "no");
  std::fclose(out);
  std::printf("wrote %s\n", out_path.c_str());
  return worst_ok ? 0 : 1;
}
