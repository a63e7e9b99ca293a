// gcode_command.cpp: the `stepchoir gcode` subcommand: options -> song reader -> planner -> file.
#include "cli/gcode_command.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "player/printer_arrangement.h"
#include "song/gcode.h"
#include "song/song.h"

namespace stepchoir {

namespace {

// The printer the options describe. Called by GcodeCommand::run.
Printer printer_of(const GcodeCommand &c) {
  const bool custom = !c.steps_per_mm.empty() || !c.volume.empty();
  if (custom && !c.printer.empty()) throw GcodeError("give either --printer or --steps-per-mm and --volume, not both");
  if (custom && (c.steps_per_mm.empty() || c.volume.empty()))
    throw GcodeError("--steps-per-mm and --volume go together (a printer needs both)");
  if (custom) {
    if (c.max_feed.empty())
      std::fprintf(stderr, "stepchoir gcode: no --max-feed: feeds are not checked against the printer's limits\n");
    Printer p = make_printer("custom", c.steps_per_mm, c.volume, c.max_feed, "options");
    if (!c.kinematics.empty()) p.kinematics = parse_kinematics(c.kinematics, "--kinematics");
    return p;
  }
  std::vector<Printer> presets;
  if (!c.printer_file.empty()) {
    std::ifstream in(c.printer_file);
    if (!in) throw GcodeError(c.printer_file + ": cannot open");
    std::ostringstream text;
    text << in.rdbuf();
    presets = parse_printers(text.str(), c.printer_file);
  } else {
    presets = builtin_printers();
  }
  std::string name = c.printer;
  if (name.empty()) {
    name = "generic";
    std::fprintf(stderr, "stepchoir gcode: no --printer: using the generic preset (pitch is right only with its steps/mm)\n");
  }
  Printer p = find_printer(presets, name);
  if (!c.kinematics.empty()) p.kinematics = parse_kinematics(c.kinematics, "--kinematics");
  if (!c.max_feed.empty()) {
    const Printer limits = make_printer(p.name, "1,1,1", "0:1,0:1,0:1", c.max_feed, "--max-feed");
    const bool with_e = std::count(c.max_feed.begin(), c.max_feed.end(), ',') == kGcodeAxes - 1;
    for (size_t a = 0; a < (with_e ? kGcodeAxes : kCartesianAxes); ++a)
      p.axes[a].max_feed_mm_s = limits.axes[a].max_feed_mm_s;
  }
  return p;
}

// The --channels list as voice indexes. Called by GcodeCommand::run.
std::vector<size_t> voices_option(const std::string &text) {
  std::vector<size_t> out;
  if (text.empty()) return out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item.empty() || item.size() > 4 || item.find_first_not_of("0123456789") != std::string::npos)
      throw GcodeError("--channels: expected voice numbers such as 0,2,1, got '" + item + "'");
    out.push_back(std::stoul(item));
  }
  return out;
}

}  // namespace

int GcodeCommand::run() const {
  try {
    Song s = read_song_file(song, tab_options(tab));
    for (const auto &w : s.warnings) std::fprintf(stderr, "stepchoir gcode: warning: %s\n", w.c_str());
    // Drum hits are not pitches: a printer does not sing them.
    const size_t notes = s.notes.size();
    s.notes.erase(std::remove_if(s.notes.begin(), s.notes.end(), [](const SongNote &n) { return n.percussion; }),
                  s.notes.end());
    std::vector<std::string> notices;
    if (s.notes.size() != notes) notices.push_back(std::to_string(notes - s.notes.size()) + " drum hits left out");
    const Printer p = printer_of(*this);
    GcodeOptions o;
    o.steps_per_cycle = steps_per_cycle;
    o.home = home;
    o.fold_octaves = fold_octaves;
    o.use_g1 = use_g1;
    o.extruder = extruder;
    o.voice_of_axis = voices_option(channels);
    o.flavor = flavor.empty() ? p.motion.firmware : parse_firmware(flavor, "--flavor");
    o.set_limits = !keep_limits;
    const size_t axes = extruder ? kGcodeAxes : kCartesianAxes, voices = voices_of(s).size();
    if (o.voice_of_axis.empty() && voices > axes) s = arrange_for_printer(s, p, axes, steps_per_cycle, notices);
    GcodePlan plan = plan_gcode(s, p, o);
    plan.warnings.insert(plan.warnings.begin(), notices.begin(), notices.end());
    for (const auto &w : plan.warnings) std::fprintf(stderr, "stepchoir gcode: warning: %s\n", w.c_str());
    const std::string text = write_gcode(plan, p, o, song);
    std::FILE *f = out == "-" ? stdout : std::fopen(out.c_str(), "w");
    if (!f) throw GcodeError(out + ": cannot create");
    const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
    if (f != stdout ? std::fclose(f) != 0 || !ok : std::fflush(f) != 0 || !ok) throw GcodeError(out + ": write failed");
    size_t moves = 0;
    for (const auto &st : plan.steps) moves += !st.dwell;
    std::fprintf(stderr, "stepchoir gcode: %s: %zu moves, %.3f s, printer %s (%s)", out.c_str(), moves,
                 plan.duration_s, p.name.c_str(), kinematics_name(p.kinematics));
    for (size_t a = 0; a < plan.axis_voice.size(); ++a)
      std::fprintf(stderr, ", %c = track %u channel %u", motor_name(p.kinematics, a), plan.axis_voice[a].track,
                   plan.axis_voice[a].channel);
    std::fprintf(stderr, "\n");
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir gcode: %s\n", e.what());
    return 1;
  }
}

std::unique_ptr<GcodeCommand> add_gcode_command(CLI::App &app) {
  auto c = std::make_unique<GcodeCommand>();
  c->app = app.add_subcommand("gcode", "Write a song as G-code that makes a 3D printer's motors sing (X, Y, Z; A, B, "
                                      "Z on CoreXY)");
  CLI::App &g = *c->app;
  g.add_option("song", c->song, "Song file: Standard MIDI File (.mid), music2gcode song (.sng), tab (.tab) or "
                                "MusicXML (.musicxml, .xml, .mxl)")
      ->required();
  add_tab_options(g, c->tab);
  g.add_option("-o,--output", c->out, "G-code file to write ('-': standard output)")->required();
  g.add_option("--printer", c->printer, "Printer preset: ender3, prusa-mk3s, voron24, prusa-core-one, kossel, generic "
                                       "(default generic)");
  g.add_option("--kinematics", c->kinematics,
               "cartesian, corexy or delta (overrides the preset's; default cartesian; delta needs a preset's rod, "
               "radius and printable radius)")
      ->check(CLI::IsMember({"cartesian", "corexy", "delta"}));
  g.add_option("--printer-file", c->printer_file, "Read the presets from this file (format of host/data/printers.conf)");
  g.add_option("--steps-per-mm", c->steps_per_mm, "Own printer: steps per mm as X,Y,Z or X,Y,Z,E (with --volume)");
  g.add_option("--volume", c->volume, "Own printer: travel as XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX in mm");
  g.add_option("--max-feed", c->max_feed, "Max feed per axis as X,Y,Z or X,Y,Z,E in mm/s (overrides the preset's)");
  g.add_option("--channels", c->channels,
               "Voices for X, Y, Z (and E), as numbers in the voice list (e.g. 2,0,1); default: every voice, or the "
               "arranger's choice (melody first, then bass) when there are more voices than axes");
  g.add_option("--steps-per-cycle", c->steps_per_cycle, "Steps per cycle of a note's frequency")
      ->default_val(kDefaultStepsPerCycle);
  g.add_option("--flavor", c->flavor, "Firmware whose commands set the motion limits: marlin, klipper, reprap "
                                     "(default: the preset's)")
      ->check(CLI::IsMember({"marlin", "klipper", "reprap"}));
  g.add_flag("--keep-limits", c->keep_limits,
             "Leave the printer's acceleration and corner speed as they are (default: raise them to the preset's safe "
             "figures for the song, so notes reach their pitch sooner, and put them back at the end)");
  g.add_flag("--home", c->home, "Home (G28) before moving to the start");
  g.add_flag("--fold-octaves", c->fold_octaves, "Play notes too fast for an axis octaves lower (default: warn)");
  g.add_flag("--g1", c->use_g1, "Write G1 moves instead of G0 (firmware that runs G0 at a fixed speed)");
  g.add_flag("--extruder", c->extruder,
             "The extruder sings a fourth voice, back and forth within 5 mm (allows cold extrusion: unload the filament)");
  return c;
}

}  // namespace stepchoir
