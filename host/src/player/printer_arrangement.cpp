// printer_arrangement.cpp: a song with more voices than a printer's axes, arranged for them.
#include "player/printer_arrangement.h"

#include <algorithm>
#include <cmath>

#include "core/pitch.h"
#include "player/plan.h"

namespace stepchoir {

namespace {

// The highest note a motor at steps_per_mm with max_feed_mm_s (0: unchecked) sings at spc
// steps a cycle. Called by arrange_for_printer.
uint8_t highest_note(const PrinterAxis &ax, double spc) {
  int note = 127;
  if (ax.max_feed_mm_s > 0)
    while (note > 0 && note_hz(note) * spc / ax.steps_per_mm > ax.max_feed_mm_s) --note;
  return static_cast<uint8_t>(note);
}

}  // namespace

Song arrange_for_printer(const Song &song, const Printer &printer, size_t axes, double spc,
                         std::vector<std::string> &warnings) {
  const size_t voices = voices_of(song).size();
  PlanOptions o;
  for (size_t a = 0; a < axes; ++a) {
    MotorConfig mc;
    mc.lowest_note = 0;
    mc.highest_note = highest_note(printer.axes[a], spc);
    o.motors.push_back(mc);
  }
  o.min_note_s = 0;
  const Plan plan = plan_song(song, o);
  Song out;
  out.duration_s = song.duration_s;
  out.track_count = static_cast<uint16_t>(axes);
  size_t roles[kRoleCount] = {};
  for (const PlannedNote &n : plan.notes) {
    SongNote s = song.notes[n.song_index];
    s.onset_s = n.on_s;
    s.duration_s = n.off_s - n.on_s;
    s.midi_note = static_cast<uint8_t>(std::lround(n.pitch));
    s.track = n.motor;
    s.channel = 0;
    if (s.duration_s > 0) out.notes.push_back(s);
    ++roles[static_cast<size_t>(n.role)];
  }
  std::sort(out.notes.begin(), out.notes.end(), [](const SongNote &a, const SongNote &b) {
    return a.onset_s != b.onset_s ? a.onset_s < b.onset_s : a.track < b.track;
  });
  std::string kept;
  for (size_t r = 0; r < kRoleCount; ++r)
    if (roles[r]) kept += (kept.empty() ? "" : ", ") + std::to_string(roles[r]) + " " + role_name(static_cast<Role>(r));
  warnings.push_back("the song has " + std::to_string(voices) + " voices and the printer " + std::to_string(axes) +
                     " axes: arranged, melody first, then bass; " + std::to_string(plan.notes.size()) + " of " +
                     std::to_string(plan.selected) + " notes play (" + kept + "); --channels picks voices instead");
  return out;
}


}  // namespace stepchoir
