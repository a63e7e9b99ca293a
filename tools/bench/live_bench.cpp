// live_bench.cpp: latency of the live path, MIDI callback -> frame handed to the OS, over a
// real JACK MIDI connection into the real firmware on the virtual board; plus wire time, and
// key -> first STEP edge of single notes part by part (live_parts.h).
#include <CLI/CLI.hpp>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <algorithm>
#include <vector>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include "bench_date.h"
#include "board/board.h"
#include "board/vboard_child.h"
#include "score.h"
#include "trace.h"
#include "jack_rig.h"
#include "live/jack_period.h"
#include "live/midi_in.h"
#include "live/session.h"
#include "live_parts.h"
#include "vboard_process.h"

using namespace stepchoir;

namespace {

// CPU seconds (user + system) this process used so far. Called from: main.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_utime.tv_usec / 1e6 + u.ru_stime.tv_sec + u.ru_stime.tv_usec / 1e6;
}

// Peak resident memory of this process so far, in MiB. Called from: main.
double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;  // ru_maxrss is in KiB on Linux
}

// Wire time of a payload's frame at the protocol's baud rate, 10 bits a byte (8N1), in us.
double wire_us(uint8_t payload_bytes) { return sc::frame_wire_size(payload_bytes) * 10.0 * 1e6 / sc::kBaud; }

// How far a single note's parts may add up away from its total, us (rounding of the stamps).
constexpr double kPartsSumToleranceUs = 5;
// The share of the key -> first STEP notes a run must find for its figures to be written.
constexpr size_t kMinFoundPercent = 99;

}  // namespace

// Plays N note-on/off events at a fixed rate through JACK into `stepchoir`'s live session
// and writes bench/results/live-latency.md.
int main(int argc, char **argv) {
  int events = 10000, jack_period = 32, jack_rate = 48000;
  bool jack_realtime = false;
  double rate_hz = 1000;
  std::string out_dir = "bench/results", board_name = "uno", name = "live-latency";
  CLI::App app{"stepchoir-bench-live: live path latency, MIDI callback -> frame handed to the OS"};
  app.add_option("--events", events, "note events to send (default 10000)")->check(CLI::Range(10, 2000000));
  app.add_option("--rate", rate_hz, "events per second (default 1000)")->check(CLI::Range(1.0, 20000.0));
  app.add_option("--out", out_dir, "directory for the results (default bench/results)");
  app.add_option("--name", name, "results file name without .md (default live-latency)");
  app.add_option("--jack-period", jack_period, "JACK dummy driver period, frames (default 32)")
      ->check(CLI::Range(8, 4096));
  app.add_option("--jack-rate", jack_rate, "JACK dummy driver sample rate, Hz (default 48000)")
      ->check(CLI::IsMember({44100, 48000, 88200, 96000, 192000}));
  app.add_flag("--jack-realtime", jack_realtime, "run jackd with realtime scheduling (-R)");
  app.add_option("--board", board_name, "virtual board: " + stepchoir::one_of(stepchoir::kBoardKinds))
      ->check(CLI::IsMember(stepchoir::kBoardKinds));
  std::string link_model = "ideal";
  app.add_option("--link-model", link_model, "the virtual board's USB bridge: " + stepchoir::one_of(stepchoir::kLinkModels))
      ->check(CLI::IsMember(stepchoir::kLinkModels));
  int onsets = 200;
  app.add_option("--onsets", onsets, "notes of the key -> first STEP phase, 45-55 ms apart (default 200)")
      ->check(CLI::Range(10, 100000));
  CLI11_PARSE(app, argc, argv);
  std::string command;
  for (int i = 0; i < argc; ++i) command += (i ? " " : "") + std::string(argv[i]);

  JackServer jack(jack_period, jack_realtime, jack_rate);
  Sender keys;
  const std::string trace_file = "/tmp/stepchoir-bench-live-" + std::to_string(::getpid()) + ".csv";
  VboardProcess vb({"--board", board_name, "--quiet", "--no-measure", "--link-model", link_model, "--trace", trace_file,
                    "--trace-frames"});
  Board board(open_link(vb.pty()));
  const Caps caps = board.hello();
  const std::vector<LiveBoard> pool{{&board.link(), caps.motor_count, caps.f_cpu_hz}};
  LiveSession session(pool, pool_config(pool, Policy::kPoly));
  MidiIn midi(stepchoir::MidiApi::kJack, Sender::kPort, session.midi_queue());
  session.start();
  const double period_us = jack_period_us();  // what the server runs at
  const BoardStats &stats = session.board_stats(0);

  // Struck below the default double_at (live/velocity.h), so each note takes one motor.
  constexpr uint8_t kVelocity = 64;
  // Each event changes one motor: even events strike note k, odd ones release note k-1, so a
  // note lasts two events and no event undoes one in the same JACK period.
  const double cpu0 = cpu_seconds();
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < events; ++i) {
    std::this_thread::sleep_until(start + std::chrono::duration<double>(i / rate_hz));
    const int k = i / 2;
    keys.send(i % 2 ? note_off(0, static_cast<uint8_t>(48 + (k + 36) % 37))
                    : note_on(0, static_cast<uint8_t>(48 + k % 37), kVelocity));
  }
  const double send_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  keys.send(note_off(0, static_cast<uint8_t>(48 + (events / 2 - 1) % 37)));  // the last note struck
  for (int i = 0; i < 100 && session.events() < static_cast<uint64_t>(events) + 1; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_s = cpu_seconds() - cpu0;
  // Key -> first STEP edge: single notes 45-55 ms apart, each released after 20 ms, so that
  // each starts a silent motor; the send times and the host's stamps of each note against the
  // trace's frames and edges on the monotonic clock. The gaps vary (a fixed seed) as a
  // player's do: at a fixed 50 ms every fifth note would fall at the same point of the host's
  // 250 ms refresh, on it in some runs and never in others.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::vector<live_parts::NoteStamps> notes;
  std::mt19937 gaps(1);
  std::uniform_int_distribution<int> rest_us(25000, 35000);
  for (int i = 0; i < onsets; ++i) {
    const uint8_t note = static_cast<uint8_t>(60 + i % 12);
    const uint64_t key = monotonic_us();
    keys.send(note_on(0, note, kVelocity));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const uint64_t callback = stats.last_event_us.load(), written = stats.last_written_us.load();
    notes.push_back(callback >= key ? live_parts::NoteStamps{key, callback, written} : live_parts::NoteStamps{key, 0, 0});
    keys.send(note_off(0, note));
    std::this_thread::sleep_for(std::chrono::microseconds(rest_us(gaps)));
  }
  // What the board says once everything was released: a status request goes out each second.
  std::this_thread::sleep_for(std::chrono::milliseconds(2 * kStatusEveryMs + 200));
  const unsigned sounding = stats.sounding_mask.load(), frames_bad = stats.status_frames_bad.load(),
                 overruns = stats.status_overruns.load();
  unsigned held = 0;  // motors the host itself still plays: a note-off lost before the callback
  for (size_t m = 0; m < session.motor_count(); ++m)
    if (session.motor_note(m) >= 0) held |= 1u << m;
  session.stop();
  vb.stop();
  const sc::trace::Trace trace = sc::trace::read_trace(trace_file);
  ::unlink(trace_file.c_str());
  const long slipped_us = sc::trace::pacing_slipped_us(trace);
  const live_parts::Split split = live_parts::split_notes(trace, notes);
  const std::vector<double> &key_to_step_us = split.totals_us;
  auto pct = [&](double q) { return live_parts::percentile(key_to_step_us, q); };
  // A percentile over fewer than 99 % of the notes says nothing of the missing ones (the board
  // starved of the CPU, notes lost inside JACK): such a run writes what it saw, no key -> first
  // STEP figures, and fails.
  const bool found_enough = key_to_step_us.size() * 100 >= static_cast<size_t>(onsets) * kMinFoundPercent;
  std::ostringstream key_row;
  if (found_enough)
    key_row << pct(0.5) << " / " << pct(0.99) << " / " << pct(1.0) << " us";
  else
    key_row << "not measured: fewer than " << kMinFoundPercent << " % of the notes have a STEP edge within "
            << live_parts::kWithinS * 1e3 << " ms of their key";

  const LatencyHistogram &h = session.latency();
  const uint64_t p50 = h.percentile(0.5), p99 = h.percentile(0.99), max = h.max_us();
  const double wire1 = wire_us(sc::kSetPeriodBytes);
  const std::string date = utc_now_text();

  const std::string path = out_dir + "/" + name + ".md";
  std::ofstream out(path);
  out << "# Live path: " << events << " events at " << rate_hz << " per second\n\n"
      << "Command: `" << command << "`\n\n"
      << "Date: " << date << "\n\n"
      << "Method: a private JACK server (`jackd " << (jack_realtime ? "-R" : "-r") << " -d dummy -r " << jack_rate
      << " -p " << jack_period << "`; its period as the server reports it: " << period_us << " us), a sender on a virtual JACK MIDI "
         "output, `stepchoir`'s MidiIn (a JACK client of its own: docs/decisions/026-jack-midi-input.md) on it, a LiveSession (engine and writer threads) and the real "
         "firmware on the virtual board (" << board_name << ", " << int(caps.motor_count) << " motors) on a pty. "
      << events << " note events (on/off alternating, each changes one motor) at " << rate_hz
      << " per second, then the last note's release. Latency per set-period entry: from the timestamp the MIDI callback takes to the "
         "return of the write() on the link (the frame handed to the OS), by the writer thread or by the engine when the link was idle.\n\n"
      << "| measure | value |\n|---|---|\n"
      << "| events sent / reached the MIDI callback / dropped at the callback | " << events << " / "
      << midi.received() + midi.dropped() << " / " << midi.dropped() << " |\n"
      << "| engine and writer threads with SCHED_FIFO | " << session.realtime_threads() << " of 2 |\n"
      << "| latency samples | " << h.count() << " |\n"
      << "| callback -> frame handed to the OS, p50 | " << p50 << " us |\n"
      << "| callback -> frame handed to the OS, p99 | " << p99 << " us |\n"
      << "| callback -> frame handed to the OS, max | " << max << " us |\n"
      << "| of which callback -> engine applied the event, p50 / p99 / max | " << session.engine_latency().percentile(0.5)
      << " / " << session.engine_latency().percentile(0.99) << " / " << session.engine_latency().max_us() << " us |\n"
      << "| wire time of one note (" << int(sc::frame_wire_size(sc::kSetPeriodBytes)) << "-byte frame) at "
      << sc::kBaud << " baud | " << wire1 << " us |\n"
      << "| wire time of a 3-note chord in one frame | " << wire_us(3 * sc::kSetPeriodBytes) << " us |\n"
      << "| host p99 + wire (one note) | " << p99 + wire1 << " us |\n"
      << "| link model (the USB bridge between host and board) | " << link_model << " |\n"
      << "| key -> first STEP edge (" << key_to_step_us.size() << " of " << onsets
      << " single notes found), p50 / p99 / max | " << key_row.str() << " |\n"
      << "| the virtual board fell behind real time meanwhile (given up) | " << slipped_us << " us |\n"
      << "| send phase | " << send_s << " s (" << events / send_s << " events per second) |\n"
      << "| after the last release: motors the board reports sounding (bit mask) | " << sounding << " |\n"
      << "| after the last release: motors the host still plays (bit mask; a note-off lost inside JACK) | " << held
      << " |\n"
      << "| board counters: bad frames / UART overruns | " << frames_bad << " / " << overruns << " |\n"
      << "| host bytes that came before the firmware's UART was on (lost; the first hello's part: a bad frame) | "
      << sc::trace::uart_in_lost(trace) << " |\n"
      << "| updates coalesced by the writer | " << stats.coalesced.load() << " |\n"
      << "| set-period frames the engine wrote itself (no writer wake-up) | " << stats.direct_frames.load() << " |\n"
      << "| frames written / heartbeats | " << session.board_stats(0).frames_sent.load() << " / "
      << session.board_stats(0).heartbeats.load() << " |\n"
      << "| CPU of this process (sender, MidiIn, engine, writer, reader) | " << 100.0 * cpu_s / wall_s
      << " % of one core over " << wall_s << " s |\n"
      << "| peak memory of this process (resident) | " << peak_rss_mib() << " MiB |\n\n"
      << "Key -> first STEP edge: " << onsets << " single notes 45-55 ms apart after the flood, from the sender's "
         "clock just before it hands the note to JACK to the board's first STEP edge, the trace laid on the same "
         "monotonic clock (its wall_start line). Its parts: JACK's period (" << jack_period << " frames at " << jack_rate << " Hz, "
      << period_us << " us at most), the host (callback -> frame handed to the OS, above), the link (ideal: "
         "the virtual board's lead on the wall clock only; 16u2: the next 1 ms USB frame), the wire (above) and the firmware (frame's last byte -> first STEP "
         "edge, measured in bench/results/onset-latency.md), each measured per note in the table below. A note-on on a DIN MIDI cable takes 960 us (3 bytes at "
         "31,250 baud).\n\n"
      << "Events that never reached the callback were lost inside JACK (its xruns on a loaded "
         "machine), before the live path.\n\n"
      << "Machine: 2 shared cores, other engineers' builds and virtual boards running; JACK "
      << (jack_realtime ? "with" : "without") << " realtime scheduling.\n\n"
      << (found_enough ? live_parts::parts_table(split, static_cast<size_t>(onsets), period_us, link_model,
                                                 sc::frame_wire_size(sc::kSetPeriodBytes), sc::kBaud)
                       : "## key -> first STEP edge\n\nNot measured on this run: only " + std::to_string(key_to_step_us.size()) +
                             " of " + std::to_string(onsets) + " notes have a STEP edge within " +
                             std::to_string(static_cast<int>(live_parts::kWithinS * 1e3)) +
                             " ms of their key, and a percentile over fewer than " + std::to_string(kMinFoundPercent) +
                             " % of them says nothing of the others.\n");
  out.close();
  std::printf("key -> first STEP p50 %.0f us, p99 %.0f us (%zu notes, %s link); ", pct(0.5), pct(0.99),
              key_to_step_us.size(), link_model.c_str());
  std::printf("p50 %llu us, p99 %llu us, max %llu us over %llu samples; wire %.0f us; written %s\n",
              static_cast<unsigned long long>(p50), static_cast<unsigned long long>(p99),
              static_cast<unsigned long long>(max), static_cast<unsigned long long>(h.count()), wire1, path.c_str());
  if (!found_enough) {
    std::fprintf(stderr, "only %zu of %d notes have a STEP edge within %.0f ms of their key: no figures\n",
                 key_to_step_us.size(), onsets, live_parts::kWithinS * 1e3);
    return 3;
  }
  // Each note's parts add up to its total: the five spans meet end to end on one clock.
  if (split.worst_sum_error_us > kPartsSumToleranceUs) {
    std::fprintf(stderr, "a note's parts differ from its total by %.1f us (more than %.0f)\n",
                 split.worst_sum_error_us, kPartsSumToleranceUs);
    return 2;
  }
  return sounding == held ? 0 : 1;  // the board plays exactly what the host holds
}
