// jam_side.cpp: jam's live side (see jam_side.h).
#include "cli/jam_side.h"

#include <algorithm>
#include <cstdio>

#include "config/config.h"

namespace stepchoir {

JamSide start_jam(const std::vector<BoardRun> &boards, const Rig &rig, Policy policy, const std::string &api_name,
                  const std::string &midi_selector, bool midi_clock, const std::vector<TempoPoint> &song_tempo) {
  JamSide side;
  std::unique_ptr<LiveSession> &session = side.session;
  std::unique_ptr<MidiIn> &midi_in = side.midi_in;
  ConsoleSources &console_sources = side.console_sources;
  std::vector<std::unique_ptr<ClockQueue>> &clock_queues = side.clock_queues;
  std::vector<std::unique_ptr<MidiClockTimeline>> &timelines = side.timelines;
  // The live path owns every board's link (its writer sends live notes first); the song goes
  // through it (JamLink). The keyboard plays the other motors of every board, one pool.
  // A board met before: the keyboard's periods at its remembered crystal's rate.
  std::vector<LiveBoard> lbs;
  for (const BoardRun &r : boards)
    lbs.push_back(LiveBoard{&r.board->link(), static_cast<uint8_t>(r.live_ids.size()),
                            crystal_hz(r.caps.f_cpu_hz, r.known), r.live_ids});
  AllocatorConfig alloc = pool_config(lbs, policy);
  for (size_t b = 0, first = 0; b < boards.size(); first += boards[b].live_ids.size(), ++b) {
    const std::vector<MotorConfig> live_music = motor_music(boards[b].settings, lbs[b].f_cpu_hz, boards[b].live_ids);
    std::copy(live_music.begin(), live_music.end(), alloc.motors.begin() + static_cast<long>(first));
    for (size_t k = 0; k < boards[b].live_ids.size(); ++k)
      alloc.mono_channel[first + k] = motor_mono_channel(boards[b].settings, boards[b].live_ids[k]);
  }
  apply_allocation(rig.config, &alloc);
  console_sources.music = alloc;
  // The keyboard's motors by their pool numbers (every board's motors, in board order), as jam
  // prints them, its console shows them and the rig file's presets and controls name them.
  std::string ids_song, ids_live;
  for (size_t b = 0, first = 0; b < boards.size(); first += boards[b].caps.motor_count, ++b) {
    for (uint8_t m : boards[b].song_ids) ids_song += (ids_song.empty() ? "" : ",") + std::to_string(first + m);
    for (uint8_t m : boards[b].live_ids) {
      ids_live += (ids_live.empty() ? "" : ",") + std::to_string(first + m);
      console_sources.motor_numbers.push_back(first + m);
      console_sources.travel_steps.push_back(motor_travel(boards[b].settings, m));
    }
    console_sources.board_names.push_back(boards[b].path);
  }
  std::vector<std::string> left_out;
  const LiveConfig view = keyboard_view(rig.config, console_sources.motor_numbers, &left_out);
  for (const std::string &w : left_out) std::fprintf(stderr, "jam: warning: %s\n", w.c_str());
  std::vector<LivePreset> presets = live_presets(view, alloc);
  const std::vector<Binding> controls = live_controls(view, alloc.motor_count);
  session = std::make_unique<LiveSession>(lbs, alloc);
  session->set_presets(std::move(presets));
  for (const Binding &c : controls) session->bind(c);
  for (size_t b = 0; b < boards.size(); ++b) session->forward_replies(b);
  midi_in = std::make_unique<MidiIn>(parse_midi_api(api_name), midi_selector, session->midi_queue());
  for (size_t b = 0; midi_clock && b < boards.size(); ++b) {
    clock_queues.push_back(std::make_unique<ClockQueue>(4096));
    midi_in->route_clock(*clock_queues.back());
    timelines.push_back(std::make_unique<MidiClockTimeline>(*clock_queues.back(), song_tempo));
  }
  session->start();
  std::printf("jam: the song on motors %s, MIDI %s (%s) on motors %s\n", ids_song.c_str(),
              midi_in->port_name().c_str(), api_name.c_str(), ids_live.c_str());
  if (midi_clock && midi_in->clock_delay_us())
    std::printf("jam: the song follows the MIDI clock (its ticks taken as sent %.2f ms before they come: half "
                "JACK's period): waiting for Start\n", midi_in->clock_delay_us() / 1e3);
  else if (midi_clock)
    std::printf("jam: the song follows the MIDI clock: waiting for Start\n");
  std::fflush(stdout);
  return side;
}

}  // namespace stepchoir
