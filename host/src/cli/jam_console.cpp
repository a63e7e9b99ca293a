// jam_console.cpp: the console for `stepchoir jam` (see jam_console.h).
#include "cli/jam_console.h"

#include <utility>

#include "cli/play_report.h"

namespace stepchoir {

JamConsole::JamConsole(ConsoleSources sources, std::string learn_path)
    : sources_(std::move(sources)),
      console_(std::move(learn_path), sources_.motor_numbers),
      ppm_(sources_.board_names.size()),
      residual_us_(sources_.board_names.size()),
      has_clock_(sources_.board_names.size()) {
  sources_.command = "jam";
  sources_.reconnecting.assign(sources_.board_names.size(), false);
  sources_.clocks.resize(sources_.board_names.size());
}

void JamConsole::publish_clock(size_t board, const PlayerStats &s) noexcept {
  if (board >= has_clock_.size()) return;
  ppm_[board].store(s.ppm, std::memory_order_relaxed);
  residual_us_[board].store(s.residual_us, std::memory_order_relaxed);
  has_clock_[board].store(s.clock_samples > 0, std::memory_order_release);
}

bool JamConsole::update(LiveSession &session, const PlayerProgress &p, const MidiIn *midi) {
  publish_clock(0, *p.stats);
  const bool go_on = console_.handle_keys(session, 0);
  for (size_t b = 0; b < sources_.clocks.size(); ++b) {
    sources_.clocks[b].has_clock = has_clock_[b].load(std::memory_order_acquire);
    sources_.clocks[b].clock_ppm = ppm_[b].load(std::memory_order_relaxed);
    sources_.clocks[b].clock_residual_us = residual_us_[b].load(std::memory_order_relaxed);
  }
  sources_.song = std::string(p.paused ? "paused " : "playing ") + clock_text(p.position_s) + " / " +
                  clock_text(p.duration_s);
  sources_.midi_input = midi ? midi->port_name() : "";
  sources_.midi_dropped = midi ? midi->dropped() : 0;
  console_.draw(sampler_.sample(session, sources_, monotonic_us()));
  return go_on;
}

}  // namespace stepchoir
