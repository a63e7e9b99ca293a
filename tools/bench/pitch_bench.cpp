// pitch_bench.cpp: stepchoir-bench-pitch: pitch, jitter and ISR timing of MIDI 24-108 on the virtual board, as Markdown.
#include <CLI/CLI.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis.h"
#include "e2e_util.h"  // e2e::board_ticks, e2e::at_payload, and VboardProcess (vboard_process.h)
#include "trace.h"

namespace tr = sc::trace;
using stepchoir::Board;
using stepchoir::BoardError;
using stepchoir::Caps;
using stepchoir::Status;

namespace {

using Clock = std::chrono::steady_clock;

// Lowest and highest MIDI note played by default (32.7 Hz to 4186 Hz).
constexpr int kFirstNote = 24;
constexpr int kLastNote = 108;
// Edges in the first 20 ms of each round are skipped: the change-over from the previous note (a
// sounding motor takes the new period at its first step after the round's start).
constexpr double kSettleSeconds = 0.02;
// A note further off than this (half a semitone) is a different note: the board did not play
// what was scheduled (a lost or late `at` frame); its jitter against the grid means nothing.
constexpr double kWrongNoteCents = 50;
// Notes listed under "Worst edges", per pass.
constexpr size_t kWorstEdgesListed = 10;
// Board time from the clock reply to the first round: room to queue the first rounds.
constexpr double kLeadSeconds = 0.2;
// Board time kept running after the last round's silence, so its last edges are in the trace.
constexpr double kTailSeconds = 0.05;
// Light traffic: one heartbeat per this interval, a clock request every kClockEveryBeats beats,
// a status request every kStatusEveryBeats beats (the host follows the board clock with it).
constexpr int kHeartbeatIntervalMs = 20;
constexpr int kClockEveryBeats = 5;
constexpr int kStatusEveryBeats = 50;
// Full-speed traffic: heartbeats per burst (then one status and one clock request).
constexpr int kFloodHeartbeatsPerBurst = 64;
// Full-speed traffic: bytes written ahead of what the line has carried (40 ms at 1 Mbaud): keeps
// the wire busy between host wake-ups, and the schedule frames queue behind little.
constexpr size_t kFloodBacklogBytes = 4000;
// After the traffic: how long to wait for a clock reply showing the board past the music.
constexpr int kConfirmTimeoutSeconds = 10;
// Safety cap on a vboard run beyond the planned music (the bench stops it itself at the end).
constexpr double kRunCapExtraSeconds = 30.0;
constexpr double kMicrosPerSecond = 1e6;
constexpr double kBitsPerByte = 10;  // 8N1: start + 8 data + stop

// The step ISRs, one timer compare channel per motor (firmware/stepchoir/scheduler.cpp): Timer1
// A/B and Timer2 A/B on the Uno, Timer1 A/B/C and Timer3 A/B on the Mega.
bool is_step_isr_vector(const std::string &board_name, int v) {
  return board_name == "mega" ? (v >= 17 && v <= 19) || v == 32 || v == 33 : v == 7 || v == 8 || v == 11 || v == 12;
}
std::string step_isr_vectors(const std::string &board_name) {
  return board_name == "mega" ? "17-19, 32, 33 (Timer1 A/B/C, Timer3 A/B)" : "7, 8, 11, 12 (Timer2 A/B, Timer1 A/B)";
}

// MCU name per board, for the report heading.
std::string mcu_name(const std::string &board_name) { return board_name == "mega" ? "ATmega2560" : "ATmega328P"; }

// How the host talks to the board while the music plays.
enum class Traffic { kLight, kFlood };

// Command-line settings.
struct Options {
  std::string board_name;
  std::string out_dir = "bench/results";
  double round_seconds = 0.5;
  std::vector<int> notes;  // empty: kFirstNote..kLastNote
  std::string elf_path;    // empty: the build's firmware for the board
  std::string command_line;
  // The firmware ELF the virtual board runs.
  std::string firmware_elf() const {
    return elf_path.empty() ? std::string(STEPCHOIR_FIRMWARE_DIR) + "/stepchoir-" + board_name + ".elf" : elf_path;
  }
};

// What the board is told to play: notes per round and motor, and when each round starts.
struct Plan {
  std::vector<std::vector<int>> notes_by_round;  // [round][motor] = MIDI note
  uint64_t t0_ticks = 0;                         // board time of round 0
  uint64_t round_ticks = 0;                      // length of a round in ticks
  // Board time at which round r starts.
  uint64_t round_start_ticks(size_t r) const { return t0_ticks + r * round_ticks; }
  // Board time at which the final silence starts (end of the music).
  uint64_t music_end_ticks() const { return round_start_ticks(notes_by_round.size()); }
};

// One note played by one motor in one round, measured.
struct NoteResult {
  int note = 0;
  size_t round = 0;
  size_t motor = 0;
  size_t edge_count = 0;
  bool measured = false;      // false when the window held fewer than 2 edges
  double target_hz = 0;       // equal temperament, A4 = 440 Hz
  double measured_hz = 0;     // board time
  double cents = 0;           // measured vs target
  double jitter_p99_us = 0;   // grid residuals (fit_edges)
  double jitter_max_us = 0;
  std::vector<double> residuals_us;  // |grid residual| of every edge in the window
  double min_pulse_us = 0;    // shortest STEP high time in the window
  uint64_t worst_edge_cycle = 0;   // the edge furthest off the grid (jitter_max_us)
  double worst_edge_us = 0;        // signed: + late, - early
  std::string worst_edge_others;   // other motors' edges near it, "m2 -1234" (cycles before)
};

// One ISR's line of the vboard summary.
struct IsrLine {
  int vector = 0;
  uint64_t entries = 0;
  uint64_t max_cycles = 0;
  uint64_t max_irq_off_cycles = 0;
  double load_fraction = 0;  // inclusive cycles / run cycles
};

// Everything one traffic pass produced.
struct PassResult {
  Traffic traffic = Traffic::kLight;
  std::string failure;  // why the pass produced no measurements ("" when it did)
  std::string trace_path;
  std::vector<NoteResult> notes;
  std::vector<IsrLine> isrs;
  std::optional<IsrLine> step_isr;
  uint64_t irq_off_max_cycles = 0;
  std::string irq_off_max_at;
  uint64_t irq_off_max_cycle = 0;  // when that window started
  uint64_t uart_would_overrun = 0;
  uint64_t uart_xoff = 0;
  uint64_t uart_in_lost = 0;
  double sim_seconds = 0;
  double wall_seconds = 0;
  double music_seconds = 0;
  double connect_seconds = 0;  // board time of the first clock reply (the host's first contact ~ then)
  uint64_t pacing_lag_max_us = 0;
  std::string end_reason;
  double f_cpu_hz = 16e6;
  size_t motor_count = 0;
  size_t rounds = 0;
  size_t frames_sent = 0;
  double line_use_fraction = 0;  // fraction of the line's bit rate the host used while the music played
  std::optional<Status> last_status;
  std::map<std::string, size_t> board_errors;  // error name -> count
};

// Title of a traffic pass.
std::string traffic_title(Traffic t) { return t == Traffic::kLight ? "light traffic" : "full line speed"; }

// Short name of a traffic pass (file names).
std::string traffic_tag(Traffic t) { return t == Traffic::kLight ? "light" : "flood"; }

// What the host sends in a traffic pass, for the report.
std::string traffic_description(Traffic t) {
  if (t == Traffic::kLight)
    return "board paced in real time; a heartbeat every " + std::to_string(kHeartbeatIntervalMs) +
           " ms, a clock request every " + std::to_string(kHeartbeatIntervalMs * kClockEveryBeats) +
           " ms, a status request every " + std::to_string(kHeartbeatIntervalMs * kStatusEveryBeats) +
           " ms, plus the timestamped schedule";
  return "board paced in real time; bursts of " + std::to_string(kFloodHeartbeatsPerBurst) +
         " heartbeats + a status request + a clock request back to back, written as fast as the line carries "
         "them (at most " + std::to_string(kFloodBacklogBytes) + " bytes ahead), the schedule in between";
}

// Note name with octave, MIDI 60 = C4.
std::string note_name(int midi_note) {
  static const char *const kNames[12] = {"C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"};
  return std::string(kNames[((midi_note % 12) + 12) % 12]) + std::to_string(midi_note / 12 - 1);
}

// Fixed-point text.
std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

// Assigns notes to (round, motor): motor m plays notes[(r + m * stride) % n], stride = ceil(n / motors),
// so every note is played, and motors play different notes at once.
std::vector<std::vector<int>> assign_notes(const std::vector<int> &notes, size_t motor_count) {
  const size_t stride = (notes.size() + motor_count - 1) / motor_count;
  std::vector<std::vector<int>> rounds(stride, std::vector<int>(motor_count));
  for (size_t r = 0; r < stride; ++r)
    for (size_t m = 0; m < motor_count; ++m) rounds[r][m] = notes[(r + m * stride) % notes.size()];
  return rounds;
}

// The kMsgAt payloads of a plan, one per round, then one silencing every motor.
std::vector<std::vector<uint8_t>> schedule_payloads(const Plan &plan, const Caps &caps) {
  std::vector<std::vector<uint8_t>> payloads;
  for (size_t r = 0; r <= plan.notes_by_round.size(); ++r) {
    std::vector<sc::PeriodEntry> entries;
    for (uint8_t m = 0; m < caps.motor_count; ++m) {
      const uint32_t period_q8 =
          r < plan.notes_by_round.size()
              ? stepchoir::hz_to_period_q8(stepchoir::note_hz(plan.notes_by_round[r][m]), caps.f_cpu_hz)
              : sc::kPeriodSilent;
      entries.push_back({m, period_q8});
    }
    payloads.push_back(e2e::at_payload(static_cast<uint32_t>(plan.round_start_ticks(r)), entries));
  }
  return payloads;
}

// Host side of a pass: sends traffic and the schedule, follows the board clock, collects replies.
// The board runs paced (real time), so board time = the last clock reply + the wall time since.
class TrafficDriver {
 public:
  // Sets up the driver; rounds_ahead = how many rounds may be queued on the board at once.
  TrafficDriver(Board &board, const Caps &caps, const Plan &plan, size_t rounds_ahead, PassResult *result)
      : board_(board), caps_(caps), plan_(plan), rounds_ahead_(rounds_ahead), result_(result),
        payloads_(schedule_payloads(plan, caps)) {}

  // Seeds the board clock from a clock request made before the traffic started.
  void set_clock(uint64_t ticks) {
    last_clock_ticks_ = ticks;
    last_clock_wall_ = Clock::now();
  }

  // Sends the rounds that may be queued before the music starts.
  void send_initial() {
    while (next_ < payloads_.size() && next_ < rounds_ahead_) send_payload(payloads_[next_++]);
  }

  // Keeps up the pass's traffic until the board time passes stop_ticks (or the board exits),
  // then makes sure, with clock requests, that the board got there.
  void run(Traffic traffic, VboardProcess &vb, uint64_t stop_ticks) {
    const uint64_t start_ticks = board_now_ticks();
    const size_t start_bytes = bytes_written_;
    if (traffic == Traffic::kLight)
      run_light(vb, stop_ticks);
    else
      run_flood(vb, stop_ticks);
    const size_t traffic_bytes = bytes_written_ - start_bytes;
    confirm_board_time(vb, stop_ticks);
    // line use: the confirming clock reply was decoded after every traffic byte had crossed the line
    const double board_s = double(last_clock_ticks_ - start_ticks) / caps_.f_cpu_hz;
    if (board_s > 0) result_->line_use_fraction = traffic_bytes * kBitsPerByte / double(sc::kBaud) / board_s;
  }

 private:
  // Light traffic: a heartbeat every kHeartbeatIntervalMs, clock and status requests now and then.
  void run_light(VboardProcess &vb, uint64_t stop_ticks) {
    const auto hb = stepchoir::frame({sc::kMsgHeartbeat});
    const auto clk = stepchoir::frame({sc::kMsgClockReq, 2});
    const auto st = stepchoir::frame({sc::kMsgStatusReq});
    auto next_beat = Clock::now();
    for (size_t beat = 0; vb.running() && board_now_ticks() < stop_ticks; ++beat) {
      if (!write(hb)) return;
      if (beat % kClockEveryBeats == 0 && !write(clk)) return;
      if (beat % kStatusEveryBeats == 0 && !write(st)) return;
      send_due();
      next_beat += std::chrono::milliseconds(kHeartbeatIntervalMs);
      if (!read_until(next_beat)) return;
    }
  }

  // Full line speed: bursts of heartbeats, a status and a clock request, back to back, written
  // as fast as the line carries them (kBaud in board time) plus a small backlog, so the wire
  // never idles but the schedule frames do not queue behind seconds of traffic.
  void run_flood(VboardProcess &vb, uint64_t stop_ticks) {
    const auto hb = stepchoir::frame({sc::kMsgHeartbeat});
    const auto st = stepchoir::frame({sc::kMsgStatusReq});
    const auto clk = stepchoir::frame({sc::kMsgClockReq, 3});
    std::vector<uint8_t> burst;
    for (int i = 0; i < kFloodHeartbeatsPerBurst; ++i) burst.insert(burst.end(), hb.begin(), hb.end());
    burst.insert(burst.end(), st.begin(), st.end());
    burst.insert(burst.end(), clk.begin(), clk.end());
    const uint64_t start_ticks = board_now_ticks();
    const size_t start_bytes = bytes_written_;
    const double line_bytes_per_tick = sc::kBaud / kBitsPerByte / caps_.f_cpu_hz;
    while (vb.running() && board_now_ticks() < stop_ticks) {
      const double carried_bytes = (board_now_ticks() - start_ticks) * line_bytes_per_tick;
      if (bytes_written_ - start_bytes + burst.size() <= carried_bytes + kFloodBacklogBytes) {
        if (!write(burst)) return;
        result_->frames_sent += kFloodHeartbeatsPerBurst + 1;  // write() counted one
      } else if (read_replies(1) < 0) {
        return;
      }
      if (read_replies(0) < 0) return;
      send_due();
    }
  }

  // Waits (heartbeats and clock requests) until a clock reply shows the board at stop_ticks.
  void confirm_board_time(VboardProcess &vb, uint64_t stop_ticks) {
    const auto hb = stepchoir::frame({sc::kMsgHeartbeat});
    const auto clk = stepchoir::frame({sc::kMsgClockReq, 4});
    const auto st = stepchoir::frame({sc::kMsgStatusReq});
    const auto give_up = Clock::now() + std::chrono::seconds(kConfirmTimeoutSeconds);
    read_until(Clock::now() + std::chrono::milliseconds(kHeartbeatIntervalMs));  // let the line drain
    const size_t replies_before = clock_replies_;
    while (vb.running() && Clock::now() < give_up && (clock_replies_ == replies_before || last_clock_ticks_ < stop_ticks)) {
      if (!write(hb) || !write(clk)) return;
      if (!read_until(Clock::now() + std::chrono::milliseconds(kHeartbeatIntervalMs))) return;
    }
    if (vb.running() && write(st)) read_until(Clock::now() + std::chrono::milliseconds(200));  // final counters
  }

  // Board time now: the last clock reply plus the wall time since (the board runs paced).
  uint64_t board_now_ticks() const {
    const double since_s = std::chrono::duration<double>(Clock::now() - last_clock_wall_).count();
    return last_clock_ticks_ + static_cast<uint64_t>(since_s * caps_.f_cpu_hz);
  }

  // Sends every schedule frame whose round is at most rounds_ahead_ rounds away.
  void send_due() {
    const uint64_t now_ticks = board_now_ticks();
    while (next_ < payloads_.size() && now_ticks + rounds_ahead_ * plan_.round_ticks >= plan_.round_start_ticks(next_))
      send_payload(payloads_[next_++]);
  }

  // Sends one payload as a frame.
  void send_payload(const std::vector<uint8_t> &payload) { write(stepchoir::frame(payload)); }

  // Writes ready frames; false when the port failed (the board exited).
  bool write(const std::vector<uint8_t> &bytes) {
    ++result_->frames_sent;
    bytes_written_ += bytes.size();
    return board_.link().write(bytes.data(), bytes.size());
  }

  // Reads replies until the wall time `until`; false on a failed port.
  bool read_until(Clock::time_point until) {
    for (;;) {
      const auto left_ms = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
      if (left_ms <= 0) return true;
      if (read_replies(static_cast<int>(left_ms)) < 0) return false;
    }
  }

  // Reads and decodes replies, waiting up to timeout_ms for the first bytes; -1 on a failed port.
  long read_replies(int timeout_ms) {
    uint8_t buf[4096];
    long total = 0;
    for (long n; (n = board_.link().read(buf, sizeof buf, timeout_ms)) != 0; timeout_ms = 0) {
      if (n < 0) return -1;
      total += n;
      for (long i = 0; i < n; ++i)
        if (decoder_.push(buf[i]) == sc::kFrameOk) on_reply(decoder_.payload(), decoder_.payload_len());
    }
    return total;
  }

  // Handles one reply: clock, status or error.
  void on_reply(const uint8_t *p, size_t len) {
    if (len < 1) return;
    if (p[0] == sc::kMsgClock && len >= 6) {
      // ticks wrap at 2^32 (268 s at 16 MHz); runs here are shorter, but unwrap anyway
      const uint32_t ticks = sc::get_u32(&p[2]);
      uint64_t unwrapped = (last_clock_ticks_ & ~uint64_t(0xFFFFFFFF)) | ticks;
      if (unwrapped + (uint64_t(1) << 31) < last_clock_ticks_) unwrapped += uint64_t(1) << 32;
      last_clock_ticks_ = unwrapped;
      last_clock_wall_ = Clock::now();
      ++clock_replies_;
    } else if (p[0] == sc::kMsgStatus) {
      try {
        result_->last_status = stepchoir::parse_status(p, len);
      } catch (const std::exception &) {
      }
    } else if (p[0] == sc::kMsgError && len >= 4) {
      ++result_->board_errors[sc::error_name(p[1])];
    }
  }

  Board &board_;
  const Caps &caps_;
  const Plan &plan_;
  size_t rounds_ahead_;
  PassResult *result_;
  std::vector<std::vector<uint8_t>> payloads_;
  size_t next_ = 0;
  sc::FrameDecoder decoder_;
  uint64_t last_clock_ticks_ = 0;
  Clock::time_point last_clock_wall_ = Clock::now();
  size_t clock_replies_ = 0;
  size_t bytes_written_ = 0;
};

// key=value fields of one summary line.
std::map<std::string, std::string> line_fields(const std::string &line) {
  std::istringstream in(line);
  std::map<std::string, std::string> fields;
  for (std::string token; in >> token;) {
    const size_t eq = token.find('=');
    if (eq != std::string::npos) fields[token.substr(0, eq)] = token.substr(eq + 1);
  }
  return fields;
}

// key=value fields of the first summary line holding a field that starts with `marker`.
std::map<std::string, std::string> summary_fields(const tr::Trace &t, const std::string &marker) {
  for (const std::string &line : t.summary_lines) {
    std::istringstream in(line);
    for (std::string token; in >> token;)
      if (token.rfind(marker, 0) == 0) return line_fields(line);
  }
  return {};
}

// A numeric summary field, or 0 when absent.
double field_number(const std::map<std::string, std::string> &fields, const std::string &key) {
  const auto it = fields.find(key);
  return it == fields.end() ? 0.0 : std::strtod(it->second.c_str(), nullptr);
}

// Reads the vboard's summary lines into the pass result.
void read_vboard_summary(const tr::Trace &t, const std::string &board_name, PassResult *r) {
  const auto irq = summary_fields(t, "irq_off_max_cycles=");
  r->irq_off_max_cycles = static_cast<uint64_t>(field_number(irq, "irq_off_max_cycles"));
  r->irq_off_max_at = irq.count("irq_off_max_at") ? irq.at("irq_off_max_at") : "";
  r->irq_off_max_cycle = static_cast<uint64_t>(field_number(irq, "irq_off_max_cycle"));
  const auto uart = summary_fields(t, "uart_would_overrun=");
  r->uart_would_overrun = static_cast<uint64_t>(field_number(uart, "uart_would_overrun"));
  r->uart_xoff = static_cast<uint64_t>(field_number(uart, "uart_xoff"));
  r->uart_in_lost = static_cast<uint64_t>(field_number(uart, "uart_in_lost"));
  const auto run = summary_fields(t, "end=");
  r->end_reason = run.count("end") ? run.at("end") : "?";
  r->sim_seconds = field_number(run, "sim_seconds");
  r->wall_seconds = field_number(run, "wall_seconds");
  r->pacing_lag_max_us = static_cast<uint64_t>(field_number(run, "pacing_lag_max_us"));
  for (const std::string &line : t.summary_lines) {
    const size_t at = line.find("isr=__vector_");
    if (at == std::string::npos) continue;
    const auto fields = line_fields(line);
    IsrLine isr;
    isr.vector = std::atoi(line.c_str() + at + 13);
    isr.entries = static_cast<uint64_t>(field_number(fields, "entries"));
    isr.max_cycles = static_cast<uint64_t>(field_number(fields, "max_cycles"));
    isr.max_irq_off_cycles = static_cast<uint64_t>(field_number(fields, "max_irq_off_cycles"));
    isr.load_fraction = field_number(fields, "load");
    r->isrs.push_back(isr);
    if (!is_step_isr_vector(board_name, isr.vector)) continue;
    // The step ISRs together: entries and loads summed (inclusive: the ISRs nested in each,
    // one another's included, count too: an upper bound), the worst invocation.
    if (!r->step_isr) r->step_isr = IsrLine{};
    IsrLine &all = *r->step_isr;
    all.entries += isr.entries;
    all.load_fraction += isr.load_fraction;
    all.max_cycles = std::max(all.max_cycles, isr.max_cycles);
    all.max_irq_off_cycles = std::max(all.max_irq_off_cycles, isr.max_irq_off_cycles);
  }
}

// Other motors' edges this close before a late edge (cycles) are listed with it: the bursts the
// step ISR played or planned just before (its compare leads an edge by 1,000 ticks).
constexpr uint64_t kNeighbourCycles = 3000;

// Fills n's worst edge: the one furthest off the ideal grid (the residual fit_edges' max is
// taken from), when it is, and the other motors' edges from kNeighbourCycles before it to 100
// after: the configuration that made it late.
void note_worst_edge(const tr::Trace &t, size_t motor, const std::vector<uint64_t> &edges, double period_cycles,
                     NoteResult *n) {
  const std::vector<double> residual = tr::grid_residuals_cycles(edges, period_cycles);
  if (residual.empty()) return;
  size_t worst = 0;
  for (size_t k = 1; k < residual.size(); ++k)
    if (std::abs(residual[k]) > std::abs(residual[worst])) worst = k;
  n->worst_edge_cycle = edges[worst];
  n->worst_edge_us = residual[worst] / t.f_cpu_hz * kMicrosPerSecond;
  const uint64_t edge = edges[worst];
  std::ostringstream others;
  for (size_t m = 0; m < t.motor.size(); ++m) {
    if (m == motor) continue;
    const auto &steps = t.motor[m].steps;
    const tr::IndexRange near = tr::steps_in_window(steps, edge > kNeighbourCycles ? edge - kNeighbourCycles : 0, edge + 101);
    for (size_t i = near.begin; i < near.end; ++i)
      others << (others.tellp() > 0 ? ", " : "") << "m" << m << " " << std::showpos
             << (int64_t(steps[i].rise_cycle) - int64_t(edge)) << std::noshowpos;
  }
  n->worst_edge_others = others.str();
}

// Measures every (round, motor) window of the trace against its note.
std::vector<NoteResult> measure_notes(const tr::Trace &t, const Plan &plan) {
  std::vector<NoteResult> out;
  const uint64_t settle_ticks = static_cast<uint64_t>(kSettleSeconds * t.f_cpu_hz);
  for (size_t r = 0; r < plan.notes_by_round.size(); ++r) {
    for (size_t m = 0; m < plan.notes_by_round[r].size() && m < t.motor.size(); ++m) {
      NoteResult n;
      n.note = plan.notes_by_round[r][m];
      n.round = r;
      n.motor = m;
      n.target_hz = stepchoir::note_hz(n.note);
      const uint64_t from = plan.round_start_ticks(r) + settle_ticks;
      const uint64_t to = plan.round_start_ticks(r + 1);
      const auto &steps = t.motor[m].steps;
      const tr::IndexRange range = tr::steps_in_window(steps, from, to);
      n.edge_count = range.size();
      if (n.edge_count >= 2) {
        const uint32_t period_q8 = stepchoir::hz_to_period_q8(n.target_hz, static_cast<uint32_t>(t.f_cpu_hz));
        const std::vector<uint64_t> edges = tr::rise_cycles_in_window(steps, from, to);
        const tr::PitchFit fit = tr::fit_edges(edges, period_q8 / 256.0, t.f_cpu_hz);
        const std::vector<tr::Step> window(steps.begin() + range.begin, steps.begin() + range.end);
        n.measured = true;
        n.measured_hz = fit.measured_hz;
        n.cents = stepchoir::cents(fit.measured_hz, n.target_hz);
        n.jitter_p99_us = fit.residual_p99_us;
        n.jitter_max_us = fit.residual_max_us;
        for (double c : tr::grid_residuals_cycles(edges, period_q8 / 256.0))
          n.residuals_us.push_back(std::abs(c) / t.f_cpu_hz * kMicrosPerSecond);
        note_worst_edge(t, m, edges, period_q8 / 256.0, &n);
        n.min_pulse_us = *tr::min_pulse_width_cycles(window) / t.f_cpu_hz * kMicrosPerSecond;
      }
      out.push_back(n);
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const NoteResult &a, const NoteResult &b) {
    return a.note != b.note ? a.note < b.note : a.motor < b.motor;
  });
  return out;
}

// Runs one traffic pass on a fresh virtual board and measures it.
PassResult run_pass(const Options &opt, const std::vector<int> &notes, Traffic traffic) {
  PassResult result;
  result.traffic = traffic;
  std::filesystem::create_directories(STEPCHOIR_BENCH_SCRATCH);
  result.trace_path =
      std::string(STEPCHOIR_BENCH_SCRATCH) + "/pitch-" + opt.board_name + "-" + traffic_tag(traffic) + ".csv";
  std::filesystem::remove(result.trace_path);

  // the music length is known once the motor count is; cap the run generously, stop it ourselves
  const size_t max_rounds = notes.size();
  const double cap_seconds = kLeadSeconds + (max_rounds + 1) * opt.round_seconds + kRunCapExtraSeconds;
  std::vector<std::string> args{"--board", opt.board_name, "--seconds", fixed(cap_seconds, 3),
                                "--trace", result.trace_path, "--quiet"};
  if (!opt.elf_path.empty()) args.insert(args.end(), {"--elf", opt.elf_path});
  Plan plan;
  {
    VboardProcess vb(args);
    Board board(stepchoir::open_link(vb.pty()));
    const Caps caps = board.hello();
    result.f_cpu_hz = caps.f_cpu_hz;
    result.motor_count = caps.motor_count;
    plan.notes_by_round = assign_notes(notes, caps.motor_count);
    result.rounds = plan.notes_by_round.size();
    plan.round_ticks = static_cast<uint64_t>(opt.round_seconds * caps.f_cpu_hz);
    const uint64_t now_ticks = e2e::board_ticks(board);
    result.connect_seconds = now_ticks / double(caps.f_cpu_hz);
    plan.t0_ticks = now_ticks + static_cast<uint64_t>(kLeadSeconds * caps.f_cpu_hz);
    result.music_seconds = plan.notes_by_round.size() * opt.round_seconds;
    // rounds queued at once: the queue holds queue_size entries, one per motor per round; keep one
    // round spare for the round still waiting for its first step
    const size_t rounds_ahead = std::max<size_t>(1, caps.queue_size / caps.motor_count - 2);
    for (const BoardError &e : board.errors()) ++result.board_errors[sc::error_name(e.code)];
    TrafficDriver driver(board, caps, plan, rounds_ahead, &result);
    driver.set_clock(now_ticks);
    driver.send_initial();
    const uint64_t stop_ticks = plan.music_end_ticks() + static_cast<uint64_t>(kTailSeconds * caps.f_cpu_hz);
    driver.run(traffic, vb, stop_ticks);
  }  // the board process gets SIGTERM here and writes the end of its trace
  const tr::Trace t = tr::read_trace(result.trace_path);
  if (!t.has_end) throw std::runtime_error(result.trace_path + ": the virtual board did not finish its trace");
  read_vboard_summary(t, opt.board_name, &result);
  if (result.end_reason == "crashed" || result.end_reason == "done")
    throw std::runtime_error("the firmware stopped running on the virtual board (end=" + result.end_reason +
                             ") at cycle " + std::to_string(t.end_cycle) + " = " +
                             fixed(t.board_seconds(t.end_cycle), 3) + " s board time; the music ran from " +
                             fixed(plan.t0_ticks / t.f_cpu_hz, 3) + " s to " +
                             fixed(plan.music_end_ticks() / t.f_cpu_hz, 3) + " s");
  if (t.end_cycle < plan.music_end_ticks())
    throw std::runtime_error("the virtual board stopped at cycle " + std::to_string(t.end_cycle) +
                             ", before the music ended at " + std::to_string(plan.music_end_ticks()));
  result.notes = measure_notes(t, plan);
  return result;
}

// True when a measured note is the scheduled one.
bool played_as_scheduled(const NoteResult &n) { return n.measured && std::abs(n.cents) <= kWrongNoteCents; }

// Worst values over a pass's notes (jitter over the notes played as scheduled).
struct Worst {
  double abs_cents = 0, p99_us = 0, max_us = 0, min_pulse_us = 0;
  double motor_p99_us = 0;  // over each motor's edges (of the notes played as scheduled), the worst motor
  size_t unmeasured = 0;   // fewer than 2 edges in the window
  size_t wrong_notes = 0;  // measured, but off by more than kWrongNoteCents
  size_t note_count = 0;
};

// Computes the worst values of a pass.
Worst worst_of(const PassResult &r) {
  Worst w;
  bool first = true;
  w.note_count = r.notes.size();
  std::vector<std::vector<double>> by_motor;
  for (const NoteResult &n : r.notes) {
    if (!n.measured) {
      ++w.unmeasured;
      continue;
    }
    w.abs_cents = std::max(w.abs_cents, std::abs(n.cents));
    w.min_pulse_us = first ? n.min_pulse_us : std::min(w.min_pulse_us, n.min_pulse_us);
    first = false;
    if (!played_as_scheduled(n)) {
      ++w.wrong_notes;
      continue;
    }
    if (n.edge_count >= tr::kMinEdgesForP99) w.p99_us = std::max(w.p99_us, n.jitter_p99_us);
    w.max_us = std::max(w.max_us, n.jitter_max_us);
    if (by_motor.size() <= n.motor) by_motor.resize(n.motor + 1);
    by_motor[n.motor].insert(by_motor[n.motor].end(), n.residuals_us.begin(), n.residuals_us.end());
  }
  // A motor's p99 as a note's: of fewer than kMinEdgesForP99 edges (most of its notes lost at
  // full line speed) it is their largest, which the max covers.
  for (const auto &v : by_motor)
    if (v.size() >= tr::kMinEdgesForP99)
      w.motor_p99_us = std::max(w.motor_p99_us, tr::percentile_nearest_rank(v, tr::kP99Quantile));
  return w;
}

// Cycles as microseconds on the pass's clock.
double cycles_us(uint64_t cycles, double f_cpu_hz) { return cycles / f_cpu_hz * kMicrosPerSecond; }

// The summary section of one pass.
std::string summary_markdown(const PassResult &r) {
  const Worst w = worst_of(r);
  std::ostringstream o;
  o << "### " << traffic_title(r.traffic) << "\n\n";
  o << "Traffic: " << traffic_description(r.traffic) << ".\n\n";
  if (!r.failure.empty()) {
    o << "**FAILED**: " << r.failure << "\n\nTrace: `" << r.trace_path << "`\n\n";
    return o.str();
  }
  o << "| measure | value |\n|---|---|\n";
  const std::string scope = w.wrong_notes ? " (notes played as scheduled)" : "";
  o << "| worst \\|cents\\| | " << fixed(w.abs_cents, 5) << " |\n";
  o << "| notes not played as scheduled | " << w.wrong_notes + w.unmeasured << " of " << w.note_count;
  if (w.wrong_notes) o << " (" << w.wrong_notes << " off by > " << fixed(kWrongNoteCents, 0) << " cents: a lost or late `at` frame)";
  if (w.unmeasured) o << " (" << w.unmeasured << " with < 2 edges)";
  o << " |\n";
  o << "| worst motor's jitter p99, all its edges" << scope << " | "
    << (w.motor_p99_us > 0 ? fixed(w.motor_p99_us, 3) + " us" : std::string("n/a (no motor of ") + std::to_string(tr::kMinEdgesForP99) + "+ edges)")
    << " |\n";
  o << "| worst note's jitter p99, notes of " << tr::kMinEdgesForP99 << "+ edges" << scope << " | " << fixed(w.p99_us, 3)
    << " us |\n";
  o << "| worst jitter max" << scope << " | " << fixed(w.max_us, 3) << " us |\n";
  o << "| shortest STEP pulse | " << fixed(w.min_pulse_us, 3) << " us |\n";
  o << "| interrupts-off max | " << r.irq_off_max_cycles << " cycles = " << fixed(cycles_us(r.irq_off_max_cycles, r.f_cpu_hz), 2)
    << " us (in " << (r.irq_off_max_at.empty() ? "?" : "`" + r.irq_off_max_at + "`") << ", at "
    << fixed(r.irq_off_max_cycle / r.f_cpu_hz, 3) << " s) |\n";
  if (r.step_isr) {
    o << "| step ISRs worst | " << r.step_isr->max_cycles << " cycles = "
      << fixed(cycles_us(r.step_isr->max_cycles, r.f_cpu_hz), 2) << " us |\n";
    o << "| step ISR CPU load | " << fixed(100 * r.step_isr->load_fraction, 2) << " % of " << fixed(r.sim_seconds, 2)
      << " s simulated (" << fixed(r.music_seconds, 2) << " s of music) |\n";
    o << "| step ISR entries | " << r.step_isr->entries << " |\n";
  } else {
    o << "| step ISR | not found in the vboard summary |\n";
  }
  o << "| UART would-overrun (vboard) | " << r.uart_would_overrun << " |\n";
  o << "| UART xoff / bytes lost (vboard) | " << r.uart_xoff << " / " << r.uart_in_lost << " |\n";
  if (r.last_status) {
    const auto &h = r.last_status->head;
    o << "| board counters (last status) | frames ok " << h.frames_ok << ", bad " << h.frames_bad << ", uart overruns "
      << h.uart_overruns << ", late edges " << h.late_edges << ", last error " << sc::error_name(h.last_error)
      << ((h.flags & sc::kStatusWatchdogTripped) ? ", watchdog tripped" : "") << " |\n";
  } else {
    o << "| board counters | no status reply received |\n";
  }
  std::string errors;
  for (const auto &e : r.board_errors) errors += (errors.empty() ? "" : ", ") + e.first + " x" + std::to_string(e.second);
  o << "| board error replies | " << (errors.empty() ? "none" : errors) << " |\n";
  o << "| frames sent by the host | " << r.frames_sent << " (line use during the music: " << fixed(100 * r.line_use_fraction, 1)
    << " % of " << sc::kBaud / 1000 << " kbaud) |\n";
  o << "| run | " << fixed(r.sim_seconds, 3) << " s simulated in " << fixed(r.wall_seconds, 3)
    << " s wall; host connected at " << fixed(r.connect_seconds, 3) << " s, music from "
    << fixed(r.connect_seconds + kLeadSeconds, 3) << " s";
  if (r.traffic == Traffic::kLight) o << ", pacing lag max " << r.pacing_lag_max_us << " us";
  o << " |\n\n";
  o << "ISRs:";
  for (const IsrLine &i : r.isrs)
    if (i.entries)
      o << " `__vector_" << i.vector << "` " << i.entries << " entries, max " << i.max_cycles << " cycles, I-clear total per invocation max "
        << i.max_irq_off_cycles << ", load " << fixed(100 * i.load_fraction, 2) << " %;";
  o << "\n\nTrace: `" << r.trace_path << "`\n\n";
  return o.str();
}

// The per-note table of one pass.
std::string table_markdown(const PassResult &r) {
  std::ostringstream o;
  if (!r.failure.empty()) return "";
  o << "### Per note, " << traffic_title(r.traffic) << "\n\n";
  o << "| note | name | motor | target Hz | measured Hz | cents | jitter p99 us | jitter max us | min pulse us | edges | remark |\n";
  o << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const NoteResult &n : r.notes) {
    o << "| " << n.note << " | " << note_name(n.note) << " | " << n.motor << " | " << fixed(n.target_hz, 3) << " | ";
    std::string remark;
    if (played_as_scheduled(n))
      o << fixed(n.measured_hz, 4) << " | " << fixed(n.cents, 5) << " | " << fixed(n.jitter_p99_us, 3) << " | "
        << fixed(n.jitter_max_us, 3) << " | " << fixed(n.min_pulse_us, 3);
    else if (n.measured)
      o << fixed(n.measured_hz, 4) << " | " << fixed(n.cents, 2) << " | - | - | " << fixed(n.min_pulse_us, 3),
          remark = "wrong note: MIDI " + fixed(tr::midi_from_hz(n.measured_hz), 1) + " played";
    else
      o << "- | - | - | - | -", remark = "not played";
    o << " | " << n.edge_count << " | " << remark << " |\n";
  }
  o << "\n";
  return o.str();
}

// The pass's worst edges, one per note (those played as scheduled), furthest off first.
std::string worst_edges_markdown(const PassResult &r) {
  if (!r.failure.empty()) return "";
  std::vector<const NoteResult *> notes;
  for (const NoteResult &n : r.notes)
    if (played_as_scheduled(n)) notes.push_back(&n);
  std::stable_sort(notes.begin(), notes.end(), [](const NoteResult *a, const NoteResult *b) {
    return std::abs(a->worst_edge_us) > std::abs(b->worst_edge_us);
  });
  if (notes.size() > kWorstEdgesListed) notes.resize(kWorstEdgesListed);
  std::ostringstream o;
  o << "### Worst edges, " << traffic_title(r.traffic) << "\n\n";
  o << "Each note's edge furthest off its grid (+ late), the " << notes.size()
    << " furthest, with the other motors' edges from " << kNeighbourCycles
    << " cycles before it (cycles from it). Trace one with `STEPCHOIR_VBOARD_PCTRACE_WATCH` "
       "(docs/ARCHITECTURE.md, Debugging aids).\n\n";
  o << "| board s | cycle | note | motor | off us | other motors' edges |\n|---:|---:|---:|---:|---:|---|\n";
  for (const NoteResult *n : notes)
    o << "| " << fixed(static_cast<double>(n->worst_edge_cycle) / r.f_cpu_hz, 6) << " | " << n->worst_edge_cycle
      << " | " << n->note << " | " << n->motor << " | " << fixed(n->worst_edge_us, 3) << " | " << n->worst_edge_others
      << " |\n";
  o << "\n";
  return o.str();
}

// Local date and time, ISO 8601.
std::string now_text() {
  const std::time_t now = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S %Z", std::localtime(&now));
  return text;
}

// Output of a shell command's first line, or "" when it fails.
std::string command_line_output(const std::string &command) {
  FILE *p = popen(command.c_str(), "r");
  if (!p) return "";
  char line[256] = "";
  const bool got = std::fgets(line, sizeof line, p) != nullptr;
  pclose(p);
  std::string s = got ? line : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  return s;
}

// Which firmware ran: ELF path and time, source commit and whether firmware/ had local changes.
std::string firmware_identity(const Options &opt) {
  const std::string elf = opt.firmware_elf();
  std::string text = "`" + elf + "`";
  struct stat st;
  if (stat(elf.c_str(), &st) == 0) {
    char when[64];
    std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", std::localtime(&st.st_mtime));
    text += " (built " + std::string(when) + ")";
  }
  if (!opt.elf_path.empty()) return text;  // built elsewhere: the source tree says nothing about it
  const std::string src = STEPCHOIR_SOURCE_DIR;
  const std::string commit = command_line_output("git -C '" + src + "' rev-parse --short HEAD 2>/dev/null");
  if (!commit.empty()) {
    const std::string dirty =
        command_line_output("git -C '" + src + "' status --porcelain -- firmware protocol 2>/dev/null | head -1");
    text += ", source " + commit + (dirty.empty() ? "" : " + uncommitted changes in firmware/ or protocol/");
  }
  return text;
}

// Writes the report; returns its path.
std::string write_report(const Options &opt, const std::vector<PassResult> &passes) {
  std::filesystem::create_directories(opt.out_dir);
  const std::string path = opt.out_dir + "/pitch-" + opt.board_name + ".md";
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  size_t motor_count = 0, rounds = 0;
  for (const PassResult &r : passes)
    if (r.motor_count) motor_count = r.motor_count, rounds = r.rounds;
  out << "# Pitch benchmark: " << opt.board_name << " (" << mcu_name(opt.board_name) << ", " << motor_count
      << " motors)\n\n";
  out << "Command: `" << opt.command_line << "`\n\n";
  out << "Date: " << now_text() << "\n\n";
  out << "Firmware: " << firmware_identity(opt) << "\n\n";
  out << "Method: " << rounds << " rounds of " << fixed(opt.round_seconds, 3)
      << " s board time, scheduled with timestamped `at` frames on the board clock; in round r motor m plays note "
         "r + m * ceil(notes / motors) of the list (wrapped), so all motors sound different notes at once and every "
         "note is played. Per note: edges from "
      << fixed(kSettleSeconds * 1000, 0)
      << " ms after the round start to its end are fitted to the commanded period (board time); cents = measured vs "
         "equal-tempered target (A4 = 440 Hz, includes the host's q8 rounding, < 0.002 cents); jitter = |edge - ideal "
         "grid|, p99 (nearest rank) and max, shown only for notes within "
      << fixed(kWrongNoteCents, 0) << " cents of the target (others are a different note: the board did not play "
         "what was scheduled); the summary's p99s: each motor's over all its edges (each note's offset removed), "
         "and the worst note's, of the motors and notes with "
      << tr::kMinEdgesForP99
      << " edges or more (of fewer, the p99 is their largest, which the max covers); min pulse = shortest STEP "
         "high time. Step ISRs = vectors "
      << step_isr_vectors(opt.board_name) << ", one a motor; their worst invocation and their load (summed) include the ISRs nested in "
         "them.\n\n";
  out << "## Summary\n\n";
  for (const PassResult &r : passes) out << summary_markdown(r);
  out << "## Worst edges\n\n";
  for (const PassResult &r : passes) out << worst_edges_markdown(r);
  out << "## Per-note results\n\n";
  for (const PassResult &r : passes) out << table_markdown(r);
  return path;
}

// Parses a comma-separated list of MIDI notes.
std::vector<int> parse_notes(const std::string &text) {
  std::vector<int> notes;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    size_t used = 0;
    const int note = std::stoi(item, &used);
    if (used != item.size() || note < 0 || note > 127) throw std::invalid_argument("bad MIDI note '" + item + "'");
    notes.push_back(note);
  }
  if (notes.empty()) throw std::invalid_argument("empty note list");
  return notes;
}

// The command line as typed (arguments quoted when needed).
std::string join_command(int argc, char **argv) {
  std::string s;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a.empty() || a.find_first_of(" \t'\"$\\") != std::string::npos) a = "'" + a + "'";
    s += (i ? " " : "") + a;
  }
  return s;
}

}  // namespace

// Parses the options, runs both traffic passes, writes the report; exits 1 when a pass failed.
int main(int argc, char **argv) {
  Options opt;
  std::string notes_text;
  CLI::App app{"stepchoir-bench-pitch: pitch and timing of every motor across MIDI 24-108 on the virtual board"};
  app.add_option("--board", opt.board_name, "uno or mega")->required()->check(CLI::IsMember({"uno", "mega"}));
  app.add_option("--out", opt.out_dir, "directory for pitch-<board>.md (default bench/results)");
  app.add_option("--round-seconds", opt.round_seconds, "board time per round of notes (default 0.5)")
      ->check(CLI::Range(0.05, 10.0));
  app.add_option("--notes", notes_text, "comma-separated MIDI notes instead of 24-108 (e.g. 60,72)");
  app.add_option("--elf", opt.elf_path, "firmware ELF to run (default: the build's stepchoir-<board>.elf)")
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);
  opt.command_line = join_command(argc, argv);

  std::vector<int> notes;
  try {
    if (notes_text.empty())
      for (int n = kFirstNote; n <= kLastNote; ++n) notes.push_back(n);
    else
      notes = parse_notes(notes_text);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir-bench-pitch: --notes: %s\n", e.what());
    return 2;
  }

  std::vector<PassResult> passes;
  bool failed = false;
  for (Traffic traffic : {Traffic::kLight, Traffic::kFlood}) {
    std::fprintf(stderr, "stepchoir-bench-pitch: %s, %s ...\n", opt.board_name.c_str(), traffic_title(traffic).c_str());
    try {
      passes.push_back(run_pass(opt, notes, traffic));
    } catch (const std::exception &e) {
      std::fprintf(stderr, "stepchoir-bench-pitch: %s, %s: %s\n", opt.board_name.c_str(),
                   traffic_title(traffic).c_str(), e.what());
      PassResult r;
      r.traffic = traffic;
      r.failure = e.what();
      r.trace_path = std::string(STEPCHOIR_BENCH_SCRATCH) + "/pitch-" + opt.board_name + "-" + traffic_tag(traffic) + ".csv";
      passes.push_back(r);
      failed = true;
      continue;
    }
    const PassResult &r = passes.back();
    const Worst w = worst_of(r);
    std::printf("%s %s: not as scheduled %zu of %zu notes; worst |cents| %.5f, jitter p99 %.3f us (motor) %.3f us "
                "(note), max %.3f us; "
                "irq-off max %llu cycles (%.2f us); step ISR max %llu cycles, load %.2f %%; would-overrun %llu\n",
                opt.board_name.c_str(), traffic_tag(traffic).c_str(), w.wrong_notes + w.unmeasured, w.note_count,
                w.abs_cents, w.motor_p99_us, w.p99_us, w.max_us,
                static_cast<unsigned long long>(r.irq_off_max_cycles), cycles_us(r.irq_off_max_cycles, r.f_cpu_hz),
                static_cast<unsigned long long>(r.step_isr ? r.step_isr->max_cycles : 0),
                r.step_isr ? 100 * r.step_isr->load_fraction : 0.0, static_cast<unsigned long long>(r.uart_would_overrun));
  }
  try {
    const std::string path = write_report(opt, passes);
    std::printf("wrote %s%s\n", path.c_str(), failed ? " (with failed passes)" : "");
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir-bench-pitch: %s\n", e.what());
    return 1;
  }
  return failed ? 1 : 0;
}
