// console_model.cpp: the console's snapshot of a live session (see console_model.h).
#include "cli/console_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/pitch.h"
#include "live/event_log.h"
#include "live/midi_in.h"
#include "song/gcode.h"
#include "stepchoir_protocol.h"

namespace stepchoir {
namespace {

// A status reply this recent (us) means the board answers; one comes every kStatusEveryMs.
constexpr uint64_t kAnswerWithinUs = 2500000;
// The last events a model carries (the view shows as many as fit).
constexpr size_t kRecentEvents = 8;

// "ch1" .. "ch16" for a status byte's channel.
std::string channel(uint8_t status) { return "ch" + std::to_string((status & 0x0F) + 1); }

}  // namespace

std::string motor_note_name(int note) { return note < 0 || note > 127 ? "--" : note_name(note); }

void motor_pitch(int note, uint32_t period_q8, const MotorConfig &music, double a4_hz, ConsoleMotor *row) {
  row->note = note;
  row->hz = period_q8 ? period_q8_to_hz(period_q8, music.f_cpu_hz) : 0.0;
  row->cents = 0;
  if (note >= 0 && row->hz > 0) row->cents = cents(row->hz, note_hz(note + music.tuning_cents / 100.0, a4_hz));
}

std::string describe_event(uint8_t status, uint8_t data1, uint8_t data2) {
  const std::string ch = channel(status);
  switch (status & 0xF0) {
    case kMidiNoteOn:
      if (data2 > 0) return "on  " + ch + " " + note_name(data1) + " " + std::to_string(data2);
      [[fallthrough]];
    case kMidiNoteOff: return "off " + ch + " " + note_name(data1);
    case 0xA0:  // polyphonic key pressure
      return "poly " + ch + " " + note_name(data1) + " " + std::to_string(data2);
    case kMidiControlChange: return "cc" + std::to_string(data1) + " " + ch + " = " + std::to_string(data2);
    case kMidiProgramChange: return "prog " + ch + " " + std::to_string(data1 + 1);
    case kMidiChannelPressure: return "pres " + ch + " " + std::to_string(data1);
    case kMidiPitchBend: {
      const int bend = (data2 << 7 | data1) - 8192;
      return "bend " + ch + " " + (bend > 0 ? "+" : "") + std::to_string(bend);
    }
  }
  return "?";
}

ConsoleLink link_row(const BoardStats &st, const std::string &name, bool reconnecting, uint64_t now_us,
                     uint64_t frames_before, double dt_s) {
  ConsoleLink l;
  l.name = name;
  const uint64_t seen = st.last_status_us.load();
  l.health = reconnecting          ? "reconnecting"
             : st.write_failed     ? "WRITE FAILED"
             : st.read_failed      ? "READ FAILED"
             : !(seen && now_us - seen < kAnswerWithinUs) ? "no answer"
             : st.watchdog_tripped ? "watchdog"
                                   : "ok";
  l.healthy = l.health == "ok";
  l.frames_sent = st.frames_sent.load();
  if (dt_s > 0 && l.frames_sent >= frames_before) l.frames_per_s = static_cast<double>(l.frames_sent - frames_before) / dt_s;
  l.board_errors = st.board_errors.load();
  if (l.board_errors) l.last_error = sc::error_name(st.last_error.load());
  l.bad_frames = st.status_frames_bad.load();
  l.reconnects = st.reconnects.load();
  l.reversals = st.reversals.load();
  return l;
}

bool WarningTracker::rose(Counter *c, uint64_t value, uint64_t now_us) {
  if (value > c->value) c->rose_us = now_us;
  c->value = value;
  return c->rose_us && now_us - c->rose_us < static_cast<uint64_t>(kRecentS * 1e6);
}

void WarningTracker::update(ConsoleModel *m, uint64_t midi_dropped, uint64_t now_us) {
  std::vector<std::string> &w = m->warnings;
  w.clear();
  errors_.resize(m->links.size());
  bad_.resize(m->links.size());
  for (const ConsoleLink &l : m->links) {
    if (l.health == "reconnecting")
      w.push_back(l.name + ": link lost; reopening the port (its motors are silent)");
    else if (l.health == "WRITE FAILED" || l.health == "READ FAILED")
      w.push_back(l.name + ": link lost (" + (l.health == "WRITE FAILED" ? "a write" : "a read") + " failed)");
    else if (l.health == "no answer")
      w.push_back(l.name + ": the board does not answer");
    else if (l.health == "watchdog")
      w.push_back(l.name + ": the board's watchdog silenced it: frames came too late");
  }
  if (m->midi_input.empty()) w.push_back("MIDI input gone: every note released; waiting for it to come back");
  for (size_t b = 0; b < m->links.size(); ++b) {
    const ConsoleLink &l = m->links[b];
    if (rose(&errors_[b], l.board_errors, now_us))
      w.push_back(l.name + ": the board reported " + std::to_string(l.board_errors) + " errors (latest: " +
                  l.last_error + ")");
    if (rose(&bad_[b], l.bad_frames, now_us))
      w.push_back(l.name + ": " + std::to_string(l.bad_frames) + " frames the board could not read (line noise?)");
  }
  if (rose(&dropped_, midi_dropped, now_us))
    w.push_back(std::to_string(midi_dropped) + " MIDI events dropped: the engine fell behind");
  for (size_t i = 0; i < m->motors.size(); ++i)
    if (m->motors[i].switch_fault)
      w.push_back("motor " + std::to_string(i) + ": its end switch is stuck; it turns at the soft limits");
}

ConsoleModel ConsoleSampler::sample(const LiveSession &session, const ConsoleSources &src, uint64_t now_us) {
  ConsoleModel m;
  m.command = src.command;
  m.song = src.song;
  const int preset = session.preset();
  const AllocatorConfig &music = preset >= 0 ? session.presets()[static_cast<size_t>(preset)].config : src.music;
  const uint32_t mutes = session.stage_mutes();
  for (size_t i = 0; i < session.motor_count(); ++i) {
    ConsoleMotor row;
    row.number = i < src.motor_numbers.size() ? src.motor_numbers[i] : i;
    motor_pitch(session.motor_note(i), session.motor_period_q8(i), music.motors[i], music.a4_hz, &row);
    row.muted = i < 32 && (mutes >> i & 1u);
    const size_t b = session.motor_board(i);
    const uint8_t bm = session.board_motor(i);
    const BoardStats &st = session.board_stats(b);
    const bool reconnecting = b < src.reconnecting.size() && src.reconnecting[b];
    row.has_position = st.last_status_us.load() != 0 && !reconnecting;
    row.position_steps = st.position_steps[bm].load();
    row.travel_steps = i < src.travel_steps.size() ? src.travel_steps[i] : 0;
    row.switch_fault = st.endstop_fault_mask.load() >> bm & 1u;
    row.reversals = st.motor_reversals[bm].load();
    row.song = i < 32 && (src.song_motors >> i & 1u);
    m.motors.push_back(row);
  }
  const double dt_s = last_us_ && now_us > last_us_ ? (now_us - last_us_) / 1e6 : 0;
  frames_.resize(session.board_count());
  for (size_t b = 0; b < session.board_count(); ++b) {
    const std::string name = b < src.board_names.size() ? src.board_names[b] : "board " + std::to_string(b);
    ConsoleLink l = link_row(session.board_stats(b), name, b < src.reconnecting.size() && src.reconnecting[b], now_us,
                             frames_[b], last_us_ ? dt_s : 0);
    frames_[b] = l.frames_sent;
    if (b < src.clocks.size() && src.clocks[b].has_clock) {
      l.has_clock = true;
      l.clock_ppm = src.clocks[b].clock_ppm;
      l.clock_residual_us = src.clocks[b].clock_residual_us;
    }
    m.links.push_back(l);
  }
  last_us_ = now_us;
  m.latency_p50_us = session.latency().percentile(0.5);
  m.latency_p99_us = session.latency().percentile(0.99);
  m.events = session.events();
  m.midi_input = src.midi_input;
  EventLog::Entry recent[kRecentEvents];
  const size_t n = session.recent_events().latest(recent, kRecentEvents, now_us);
  for (size_t i = 0; i < n; ++i)
    m.recent.push_back({describe_event(recent[i].status, recent[i].data1, recent[i].data2), recent[i].age_ms});
  m.preset = preset;
  m.preset_count = session.presets().size();
  if (preset >= 0) {
    m.preset_program = session.presets()[static_cast<size_t>(preset)].program + 1;
    m.preset_name = session.presets()[static_cast<size_t>(preset)].name;
  }
  m.transpose = session.stage_transpose();
  m.setlist_item = src.setlist_item;
  m.setlist_count = src.setlist_count;
  m.setlist_name = src.setlist_name;
  warnings_.update(&m, src.midi_dropped, now_us);
  return m;
}

std::string status_line(const ConsoleModel &m) {
  std::string line;
  for (const ConsoleMotor &mo : m.motors) line += "m" + std::to_string(mo.number) + " " + motor_note_name(mo.note) + "  ";
  for (const ConsoleLink &l : m.links)
    line += "| " + l.name + " " + l.health + ", " + std::to_string(l.frames_sent) + " frames, " +
            std::to_string(l.bad_frames) + " bad ";
  char lat[96];
  std::snprintf(lat, sizeof lat, "| %llu events, latency p50 %llu us p99 %llu us", static_cast<unsigned long long>(m.events),
                static_cast<unsigned long long>(m.latency_p50_us), static_cast<unsigned long long>(m.latency_p99_us));
  return line + lat;
}

ConsoleModel play_model(const std::vector<std::vector<PlanEvent>> &events, const std::vector<PlayBoard> &boards,
                        double position_s, double a4_hz) {
  ConsoleModel m;
  m.command = "play";
  for (size_t b = 0; b < boards.size(); ++b) {
    const PlayBoard &pb = boards[b];
    // Each motor's latest event at or before the position: from the last such event back.
    std::vector<ConsoleMotor> rows(pb.motors);
    std::vector<bool> found(pb.motors, false);
    size_t left = pb.motors;
    static const std::vector<PlanEvent> kNone;
    const std::vector<PlanEvent> &ev = b < events.size() ? events[b] : kNone;
    auto it = std::upper_bound(ev.begin(), ev.end(), position_s,
                               [](double t, const PlanEvent &e) { return t < e.time_s; });
    while (left > 0 && it != ev.begin()) {
      const PlanEvent &e = *--it;
      if (e.motor >= pb.motors || found[e.motor]) continue;
      found[e.motor] = true;
      --left;
      if (e.silent) continue;
      rows[e.motor].note = static_cast<int>(std::lround(e.pitch));
      rows[e.motor].hz = note_hz(e.pitch, a4_hz);
      rows[e.motor].cents = (e.pitch - rows[e.motor].note) * 100.0;
    }
    const PlayerStats &s = pb.stats;
    for (size_t k = 0; k < rows.size(); ++k) {
      ConsoleMotor &r = rows[k];
      r.number = m.motors.size();
      r.board = pb.name;
      const size_t on_board = k < pb.board_motor.size() ? pb.board_motor[k] : k;
      if (s.has_status && on_board < sc::kMaxMotors) {
        r.has_position = true;
        r.position_steps = s.motor_position[on_board];
        r.reversals = s.motor_reversals[on_board];
        r.switch_fault = (s.motor_flags[on_board] & sc::kMotorEndstopFault) != 0;
      }
      if (k < pb.travel_steps.size()) r.travel_steps = pb.travel_steps[k];
      m.motors.push_back(r);
    }
    ConsoleLink l;
    l.name = pb.name;
    l.health = pb.lost ? "lost" : s.reconnecting ? "reconnecting" : "ok";
    l.healthy = l.health == "ok";
    l.frames_sent = s.frames_sent;
    l.board_errors = s.queue_full + s.other_errors + s.late_reported;
    l.reconnects = static_cast<uint32_t>(s.reconnects);
    l.reversals = s.board_reversals;
    l.has_clock = s.clock_samples > 0;
    l.clock_ppm = s.ppm;
    l.clock_residual_us = s.residual_us;
    m.links.push_back(l);
    if (pb.lost)
      m.warnings.push_back(pb.name + " is lost: its notes are dropped, the other boards play on");
    else if (s.reconnecting)
      m.warnings.push_back(pb.name + ": link lost; reopening the port, the song goes on without it");
    // The board answers `late` once a pass of its loop that took late entries: a count of
    // times, not of notes (a stall's burst is once or a few).
    if (s.late_reported > 0)
      m.warnings.push_back(pb.name + ": notes came late " + std::to_string(s.late_reported) +
                           (s.late_reported == 1 ? " time" : " times") +
                           " (host fell behind: longer --lead-ms)");
  }
  return m;
}

}  // namespace stepchoir
