// pitch_run.cpp: one pitch bench pass: the schedule, the host's traffic to the virtual board, the trace measured.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis.h"
#include "e2e_util.h"  // e2e::board_ticks, e2e::at_payload, and VboardProcess (vboard_process.h)
#include "pitch_bench.h"
#include "trace.h"

namespace pitch_bench {

using stepchoir::Board;
using stepchoir::BoardError;
using stepchoir::Caps;

namespace {

using Clock = std::chrono::steady_clock;

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
constexpr double kBitsPerByte = 10;  // 8N1: start + 8 data + stop

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

}  // namespace

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
  // The ideal link: the firmware's pitch under frames at the UART's full rate, which a USB
  // bridge's 1 ms frames would space out.
  std::vector<std::string> args{"--board", opt.board_name, "--seconds", fixed(cap_seconds, 3), "--trace",
                                result.trace_path, "--quiet", "--link-model", "ideal"};
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

}  // namespace pitch_bench
