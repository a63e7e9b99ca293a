// play_report.cpp: the plan's summary, the progress line and the report at the end.
#include "cli/play_report.h"

#include <algorithm>
#include <cstdio>
#include <map>

#include "core/pitch.h"

namespace stepchoir {

std::string clock_text(double s) {
  const int total = static_cast<int>(std::max(0.0, s));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

void report_arrangement(const Song &song, const Plan &plan) {
  struct Counts {
    size_t notes = 0, kept = 0, folded = 0;
    size_t roles[kRoleCount] = {};
    size_t why[kUnplayedCount] = {};
  };
  std::map<std::pair<int, int>, Counts> by_line;
  for (const PlannedNote &n : plan.notes) {
    const SongNote &s = song.notes[n.song_index];
    Counts &c = by_line[{s.track, s.channel}];
    ++c.notes, ++c.kept;
    c.folded += n.octaves != 0;
    ++c.roles[static_cast<size_t>(n.role)];
  }
  for (const UnplayedNote &u : plan.unplayed) {
    const SongNote &s = song.notes[u.song_index];
    Counts &c = by_line[{s.track, s.channel}];
    ++c.notes;
    ++c.why[static_cast<size_t>(u.why)];
  }
  std::printf("arrangement, by track and channel:\n");
  for (const auto &[line, c] : by_line) {
    const std::string &name = static_cast<size_t>(line.first) < song.track_names.size() ? song.track_names[line.first] : "";
    std::printf("  track %d%s%s%s channel %d: %zu notes, kept %zu", line.first, name.empty() ? "" : " \"",
                name.c_str(), name.empty() ? "" : "\"", line.second + 1, c.notes, c.kept);
    std::string roles;
    for (size_t r = 0; r < kRoleCount; ++r)
      if (c.roles[r]) roles += (roles.empty() ? "" : ", ") + std::to_string(c.roles[r]) + " " + role_name(static_cast<Role>(r));
    if (!roles.empty()) std::printf(" (%s)", roles.c_str());
    if (c.folded) std::printf(", folded %zu", c.folded);
    if (c.notes > c.kept) {
      std::printf(", dropped %zu:", c.notes - c.kept);
      const char *sep = " ";
      for (size_t w = 0; w < kUnplayedCount; ++w)
        if (c.why[w]) std::printf("%s%zu %s", sep, c.why[w], unplayed_reason(static_cast<Unplayed>(w))), sep = "; ";
    }
    std::printf("\n");
  }
}

void report_plan(const std::string &cmd, const Song &song, const Plan &plan, size_t motors) {
  size_t why[kUnplayedCount] = {};
  for (const UnplayedNote &u : plan.unplayed) ++why[static_cast<size_t>(u.why)];
  std::printf("%s: %zu notes (%s), %zu played on %zu motors", cmd.c_str(), plan.selected,
              clock_text(plan.duration_s).c_str(), plan.notes.size(), motors);
  if (!plan.unplayed.empty()) {
    std::printf("; not played: %zu (", plan.unplayed.size());
    const char *sep = "";
    for (size_t w = 0; w < kUnplayedCount; ++w)
      if (why[w]) std::printf("%s%s %zu", sep, unplayed_reason(static_cast<Unplayed>(w)), why[w]), sep = ", ";
    std::printf(")");
  }
  if (plan.shortened) std::printf("; %zu cut short for another", plan.shortened);
  std::printf("\n");
  for (size_t i = 0; i < plan.unplayed.size() && i < 5; ++i) {
    const SongNote &n = song.notes[plan.unplayed[i].song_index];
    std::printf("  not played: note %u at %.3f s (track %u, channel %u): %s\n", n.midi_note, n.onset_s, n.track,
                n.channel + 1, unplayed_reason(plan.unplayed[i].why));
  }
  if (plan.unplayed.size() > 5) std::printf("  ... and %zu more\n", plan.unplayed.size() - 5);
  std::fflush(stdout);
}

void print_progress(const PlayerProgress &p) {
  const int width = 30;
  const int done = p.duration_s > 0 ? static_cast<int>(width * p.position_s / p.duration_s) : width;
  std::fprintf(stderr, "\r%s %s / %s [%s%s]%s late %llu%s\033[K", p.paused ? "paused " : "playing",
               clock_text(p.position_s).c_str(), clock_text(p.duration_s).c_str(),
               std::string(static_cast<size_t>(std::min(done, width)), '#').c_str(),
               std::string(static_cast<size_t>(width - std::min(done, width)), '.').c_str(),
               p.loop ? (" loop " + std::to_string(p.loop + 1)).c_str() : "",
               static_cast<unsigned long long>(p.stats->late_reported), p.paused ? " (space resumes)" : "");
}

void report_player(const std::string &who, const PlayerStats &s, bool ok, bool stopped, bool real_time) {
  char clock[160] = "";
  if (real_time)
    std::snprintf(clock, sizeof clock, ", board clock %+.1f ppm (fit error %.0f us, timeline %+.1f ppm)", s.ppm,
                  s.residual_us, s.rate_ppm);
  std::printf("%s: %s; %llu entries in %llu frames, late %llu, queue full %llu, errors %llu, reconnects %llu, "
              "least lead %.1f ms%s\n",
              who.c_str(), ok ? (stopped ? "stopped, every motor silent" : "done, every motor silent") : "board lost",
              static_cast<unsigned long long>(s.entries_sent), static_cast<unsigned long long>(s.frames_sent),
              static_cast<unsigned long long>(s.late_reported), static_cast<unsigned long long>(s.queue_full),
              static_cast<unsigned long long>(s.other_errors), static_cast<unsigned long long>(s.reconnects),
              s.min_lead_ms > 1e8 ? 0.0 : s.min_lead_ms, clock);
  if (s.board_frames_bad >= 0)
    std::printf("%s: the board counted %ld bad frames, %ld UART overruns; last error: %s\n", who.c_str(),
                s.board_frames_bad, s.board_overruns, sc::error_name(s.board_last_error));
  std::fflush(stdout);
}

void recall(const std::string &cmd, const std::string &port, Board &board, std::optional<uint64_t> *id,
            std::optional<BoardRecord> *known) {
  *id = identify_board(board);
  if (!*id) {
    std::printf("%s: %s keeps no board id (older firmware): its crystal is measured afresh\n", cmd.c_str(), port.c_str());
    return;
  }
  try {
    *known = recall_board(**id);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "%s: %s (the board memory is left aside)\n", cmd.c_str(), e.what());
    return;
  }
  if (*known)
    std::printf("%s: %s is board %s, met before: crystal %+.1f ppm\n", cmd.c_str(), port.c_str(),
                board_id_hex(**id).c_str(), (*known)->clock_ppm);
  else
    std::printf("%s: %s is board %s, met for the first time\n", cmd.c_str(), port.c_str(), board_id_hex(**id).c_str());
}

void remember(const std::string &cmd, uint64_t id, const BoardRecord &record) {
  try {
    remember_board(id, record);
    std::printf("%s: board %s: crystal %+.1f ppm (+/- %.1f) remembered in %s\n", cmd.c_str(), board_id_hex(id).c_str(),
                record.clock_ppm, record.sigma_ppm, board_memory_path().c_str());
  } catch (const std::exception &e) {
    std::fprintf(stderr, "%s: %s (the board's crystal is not remembered)\n", cmd.c_str(), e.what());
  }
}

}  // namespace stepchoir
