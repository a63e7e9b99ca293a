// setlist_runner.cpp: live's setlist (see setlist_runner.h).
#include "cli/setlist_runner.h"

#include <chrono>
#include <cstdio>
#include <stdexcept>

#include "cli/jam_link.h"
#include "config/board_memory.h"
#include "config/rig.h"
#include "song/song.h"

namespace stepchoir {

SetlistRunner::SetlistRunner(std::vector<SetlistItem> items, std::vector<SetlistBoard> boards, double a4_hz)
    : items_(std::move(items)), boards_(std::move(boards)), plans_(items_.size()), a4_hz_(a4_hz) {
  size_t pool = 0;
  for (const SetlistBoard &b : boards_) pool += b.caps.motor_count;
  for (size_t i = 0; i < items_.size(); ++i) {
    const SetlistItem &item = items_[i];
    if (item.song.empty()) continue;
    SongPlan &sp = plans_[i];
    sp.events.resize(boards_.size());
    sp.song_ids.resize(boards_.size());
    for (uint8_t m : item.song_motors) {
      if (m >= pool)
        throw std::runtime_error(item.where + ": song motor " + std::to_string(m) + ": the boards have motors 0-" +
                                 std::to_string(pool - 1));
      sp.pool_motors |= 1u << m;
    }
    // The song's motors in pool order; plan motor k is owner[k] = (board, index in its song_ids).
    std::vector<uint8_t> ids;
    std::vector<MotorConfig> music;
    std::vector<std::pair<size_t, uint8_t>> owner;
    for (size_t b = 0, first = 0; b < boards_.size(); first += boards_[b].caps.motor_count, ++b) {
      for (uint8_t m = 0; m < boards_[b].caps.motor_count; ++m)
        if (sp.pool_motors >> (first + m) & 1) sp.song_ids[b].push_back(m);
      const auto mm = motor_music(boards_[b].settings, boards_[b].caps.f_cpu_hz, sp.song_ids[b]);
      for (size_t k = 0; k < mm.size(); ++k) {
        ids.push_back(static_cast<uint8_t>(ids.size()));
        music.push_back(mm[k]);
        owner.push_back({b, static_cast<uint8_t>(k)});
      }
    }
    Song song;
    try {
      song = read_song_file(item.song);
    } catch (const std::exception &e) {
      throw std::runtime_error(item.where + ": " + e.what());
    }
    PlanOptions po;
    po.tempo_scale = item.tempo;
    po.transpose = item.transpose;
    po.motors = music;
    const Plan plan = plan_song(song, po);
    sp.duration_s = plan.duration_s;
    for (PlanEvent e : plan_events(plan)) {
      const auto [b, k] = owner[e.motor];
      e.motor = k;
      sp.events[b].push_back(e);
    }
  }
}

SetlistRunner::~SetlistRunner() {
  stop_song_.store(true);
  for (std::thread &t : threads_) t.join();
}

bool SetlistRunner::has_songs() const {
  for (const SetlistItem &item : items_)
    if (!item.song.empty()) return true;
  return false;
}

void SetlistRunner::poll(LiveSession &session) {
  if (!started_) {
    started_ = true;
    enter(0, session);
    return;
  }
  const int steps = session.take_setlist_steps();
  if (steps != 0) {
    const long next = static_cast<long>(position_) + steps;
    const size_t clamped = next < 0 ? 0 : next >= static_cast<long>(items_.size()) ? items_.size() - 1 : size_t(next);
    if (clamped != position_) {
      enter(clamped, session);
      return;
    }
  }
  if (song_playing() && finished_.load() == threads_.size()) {
    // A player that could not go on (its board lost for good, or not answering) says why.
    std::string failed;
    for (size_t k = 0; k < players_.size(); ++k)
      if (!board_ok_[player_boards_[k]] && !players_[k]->error().empty())
        failed += (failed.empty() ? "" : "; ") + players_[k]->error();
    end_song(session);
    say_("setlist " + std::to_string(position_ + 1) + "/" + std::to_string(items_.size()) + " " + item().name +
         (failed.empty() ? ": the song ended" : ": the song stopped: " + failed));
  }
}

void SetlistRunner::stop(LiveSession &session) { end_song(session); }

void SetlistRunner::end_song(LiveSession &session) {
  if (threads_.empty()) return;
  stop_song_.store(true);
  for (std::thread &t : threads_) t.join();
  threads_.clear();
  for (size_t k = 0; k < players_.size(); ++k) {
    SetlistBoard &sb = boards_[player_boards_[k]];
    const ClockSync &clock = players_[k]->clock();
    if (!board_ok_[player_boards_[k]] || !clock.has_rate()) continue;
    sb.known = BoardRecord{sb.caps.board_name, clock.ppm(), clock.rate_sigma_ppm()};
    if (!sb.id) continue;
    try {
      remember_board(*sb.id, *sb.known);
    } catch (const std::exception &e) {
      say_(sb.path + ": " + e.what() + " (the board's crystal is not remembered)");
    }
  }
  players_.clear();  // each left its motors silent
  player_boards_.clear();
  gate_.reset();
  for (size_t b = 0; b < boards_.size(); ++b) session.set_song_motors(b, 0);
  session.set_song_pool(0);
}

void SetlistRunner::enter(size_t index, LiveSession &session) {
  end_song(session);
  position_ = index;
  const SetlistItem &it = items_[index];
  if (it.preset >= 0) session.select_preset(static_cast<size_t>(it.preset));
  const SongPlan &sp = plans_[index];
  std::string motors;
  for (size_t m = 0; m < 32; ++m)
    if (sp.pool_motors >> m & 1) motors += (motors.empty() ? "" : ",") + std::to_string(m);
  const std::string song = it.song.empty() ? "" : ": the song on motors " + motors;
  say_("setlist " + std::to_string(index + 1) + "/" + std::to_string(items_.size()) + " " + it.name + song);
  if (it.song.empty()) return;
  // The keyboard lets go of the song's motors (their notes silenced) before the song has them.
  session.set_song_pool(sp.pool_motors);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (!session.stage_settled() && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  stop_song_.store(false);
  finished_.store(0);
  size_t playing = 0;
  for (const auto &ids : sp.song_ids) playing += !ids.empty();
  gate_ = std::make_unique<StartGate>(boards_.size());
  board_ok_.assign(boards_.size(), 0);
  for (size_t b = 0; b < boards_.size(); ++b) {
    if (sp.song_ids[b].empty()) {
      gate_->leave(b);
      continue;
    }
    uint8_t mask = 0;
    for (uint8_t m : sp.song_ids[b]) mask = static_cast<uint8_t>(mask | (1u << m));
    session.set_song_motors(b, mask);
    uint8_t stale[256];  // what the board said while no song listened
    while (session.read_board_bytes(b, stale, sizeof stale, 0) > 0) {
    }
    PlayerOptions po;
    po.motors = sp.song_ids[b];
    po.exclusive = false;
    po.refine_rate = false;  // the song starts at the pedal, a second of sync after it
    if (boards_[b].known) {  // ... in tune from its first note on a board met before
      po.crystal_ppm = boards_[b].known->clock_ppm;
      po.crystal_sigma_ppm = boards_[b].known->sigma_ppm;
    }
    po.a4_hz = a4_hz_;
    // A board that restarted mid-song (its reset button) is configured again from the rig file,
    // by live's link keeper or else by the song's player.
    if (const BoardSettings *settings = boards_[b].settings)
      po.on_reopen = configure_unless_kept(session, b, *settings, boards_[b].path);
    if (playing > 1) po.start_gate = [gate = gate_.get(), b](uint64_t now_us) { return gate->ready(b, now_us); };
    auto board = std::make_unique<Board>(std::make_unique<JamLink>(session, b, boards_[b].path));
    players_.push_back(std::make_unique<Player>(std::move(board), boards_[b].caps, sp.events[b], sp.duration_s, po));
    player_boards_.push_back(b);
    Player *player = players_.back().get();
    threads_.emplace_back([this, player, b] {
      board_ok_[b] = player->run(stop_song_, pause_, {});
      gate_->leave(b);
      finished_.fetch_add(1);
    });
  }
}

}  // namespace stepchoir
