// play_command.cpp: `stepchoir play` and `stepchoir render`: song -> plan -> Player on a board
// (a real one, or the virtual board started here), with a progress line (jam on a terminal: the
// console) and a report.
#include "cli/play_command.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include "board/board.h"
#include "board/link.h"
#include "board/vboard_child.h"
#include "cli/jam_console.h"
#include "cli/jam_link.h"
#include "cli/jam_side.h"
#include "cli/link_repair.h"
#include "cli/plan_options.h"
#include "cli/play_console.h"
#include "cli/play_report.h"
#include "cli/render_output.h"
#include "config/board_memory.h"
#include "config/config.h"
#include "config/rig.h"
#include "core/pitch.h"
#include "live/midi_in.h"
#include "live/session.h"
#include "player/midi_clock.h"
#include "player/plan.h"
#include "player/player.h"
#include "player/start_gate.h"
#include "song/song.h"


namespace stepchoir {

namespace {

std::atomic<bool> g_pause{false};

// render: the virtual board runs at most this many times real time (this machine simulates
// four sounding motors at about 4x), and the song goes to it this far ahead (board time): a
// host stalled for up to half a second still keeps ahead of it.
constexpr double kRenderSpeed = 3.0;
constexpr double kRenderLeadS = 1.5;

}  // namespace

void toggle_play_pause() { g_pause.store(!g_pause.load()); }

std::unique_ptr<PlayCommand> add_play_commands(CLI::App &app) {
  auto c = std::make_unique<PlayCommand>();
  auto selection = [&c](CLI::App *s) {
    s->add_option("song", c->song, "Song file: Standard MIDI File (.mid), music2gcode song (.sng), tab (.tab) or "
                                   "MusicXML (.musicxml, .xml, .mxl)")
        ->required()->check(CLI::ExistingFile);
    add_tab_options(*s, c->sel.tab);
    s->add_option("--tempo", c->sel.tempo, "Tempo scale (2 = twice as fast)")->check(CLI::Range(0.05, 20.0));
    s->add_option("--transpose", c->sel.transpose, "Semitones up (negative: down)")->check(CLI::Range(-48, 48));
    s->add_option("--start", c->sel.start_s, "Start this many seconds into the song")->check(CLI::NonNegativeNumber);
    s->add_option("--tracks", c->sel.tracks, "Play only these tracks (0 = the file's first)")->delimiter(',');
    s->add_option("--channels", c->sel.channels, "Play only these MIDI channels (1-16)")
        ->delimiter(',')->check(CLI::Range(1, 16));
    s->add_option("--mute-tracks", c->sel.mute_tracks, "Leave these tracks out")->delimiter(',');
    s->add_option("--mute-channels", c->sel.mute_channels, "Leave these MIDI channels out (1-16)")
        ->delimiter(',')->check(CLI::Range(1, 16));
    s->add_option("--drums", c->sel.drums, "Play the percussion on this motor as short bursts (it sings nothing else)")
        ->check(CLI::Range(0, 31));
    s->add_option("--keep", c->sel.keep, "Play only these roles: melody, bass, inner (default: all; --voices lines play)")
        ->delimiter(',');
    s->add_option("--voices", c->sel.voices,
                  "Pitched lines that take motors first, in order: tN (track N), cN (channel 1-16)")->delimiter(',');
    s->add_option("--min-note-ms", c->sel.min_note_ms, "Leave out notes shorter than this")
        ->check(CLI::Range(0.0, 1000.0))->default_val(c->sel.min_note_ms);
    s->add_option("--vboard", c->vboards,
                  "Board the virtual board simulates (without --port); several (uno,mega): one song on all "
                  "(default: the rig file's boards, else uno)")
        ->delimiter(',')->check(CLI::IsMember(stepchoir::kBoardKinds));
    s->add_option("--vboard-link", c->vboard_link,
                  "The virtual board's USB bridge (default 16u2, the Uno's and Mega's; docs/usb-bridges.md)")
        ->check(CLI::IsMember(kLinkModels));
    s->add_option("--config,-c", c->config,
                  "Rig configuration: the board's port and each motor's driver, range, transpose, tuning (default: " +
                      default_config_path() + " if it exists)")
        ->check(CLI::ExistingFile);
  };
  c->play = app.add_subcommand("play", "Play a song file on the motors (space pauses, q or Ctrl-C stops)");
  selection(c->play);
  c->play->add_option("--port,-p", c->ports, "Board (repeat for several: their motors form one pool; none: the "
                                            "configuration's boards, else the virtual board, in real time)");
  c->play->add_option("--vboard-trace", c->vboard_trace, "Without --port: the virtual board's trace (CSV)");
  c->play->add_option("--clock-ppm", c->clock_ppm, "Without --port: the virtual board's crystal error")
      ->check(CLI::Range(-20000.0, 20000.0));
  c->play->add_option("--lead-ms", c->lead_ms, "Send each note this long before it plays")
      ->check(CLI::Range(20.0, 5000.0))->default_str(std::to_string(int(PlayCommand::kLeadMs)));
  c->play->add_option("--sync-s", c->sync_s, "Clock sync before the first note")
      ->check(CLI::Range(0.1, 30.0))->default_val(c->sync_s);
  c->play->add_option("--reconnect-s", c->reconnect_s,
                      "A lost board is opened again this long while the song plays on (0: given up at once)")
      ->check(CLI::Range(0.0, 3600.0))->default_str(std::to_string(int(PlayerOptions{}.reconnect_s)));
  c->play->add_flag("--loop", c->loop, "Start again at the end (Ctrl-C stops)");
  c->play->add_flag("--no-auto-tune", c->no_auto_tune, "Periods from the board's nominal clock, not the measured one");
  c->play->add_flag("--quiet,-q", c->quiet, "No console and no progress line");
  c->play->add_flag("--plain", c->plain, "The progress line, not the console, on a terminal");
  c->play->add_option("--dry-run", c->dry_run_motors, "Print which motor plays what for N motors; play nothing")
      ->check(CLI::Range(1, 32));
  c->jam = app.add_subcommand("jam", "Play a song on some motors and a MIDI keyboard on the others");
  selection(c->jam);
  c->jam->add_option("--midi", c->midi,
                     "MIDI input: index, part of its name, or virtual[:NAME] (default: the rig file's, else virtual)");
  c->jam->add_option("--midi-api", c->midi_api, "MIDI API (default: the rig file's, else alsa)")
      ->check(CLI::IsMember({"alsa", "jack"}));
  c->jam->add_flag("--midi-clock", c->midi_clock,
                   "The song follows the MIDI input's clock: its tempo, Start, Stop, Continue and song position");
  c->jam->add_option("--policy", c->policy, "Note allocation for the keyboard (default: the rig file's, else poly)")
      ->check(CLI::IsMember({"poly", "channel", "mono"}));
  c->jam->add_option("--song-motors", c->song_motors,
                     "The motors that play the song, numbered across the boards in their order (the keyboard plays "
                     "the rest)")
      ->delimiter(',')->default_str("0,1");
  c->jam->add_option("--port,-p", c->ports, "Board (repeat for several: their motors form one pool); none: the "
                                           "configuration's boards, else the virtual board, in real time");
  c->jam->add_option("--vboard-trace", c->vboard_trace, "Without --port: the virtual board's trace (CSV)");
  c->jam->add_option("--clock-ppm", c->clock_ppm, "Without --port: the virtual board's crystal error")
      ->check(CLI::Range(-20000.0, 20000.0));
  c->jam->add_option("--lead-ms", c->lead_ms, "Send each song note this long before it plays")
      ->check(CLI::Range(20.0, 5000.0))
      ->default_str(std::to_string(int(PlayCommand::kLeadMs)) + ", " + std::to_string(int(PlayCommand::kClockLeadMs)) +
                    " with --midi-clock");
  c->jam->add_flag("--loop", c->loop, "Start the song again at the end (Ctrl-C stops)");
  c->jam->add_flag("--quiet,-q", c->quiet, "No console and no progress line");
  c->jam->add_flag("--plain", c->plain, "The progress line, not the console, on a terminal");
  c->render = app.add_subcommand("render", "Play a song through the firmware on the virtual board, as fast as it "
                                           "runs, and write what the motors played");
  selection(c->render);
  c->render->add_option("-o,--out", c->out_wav, "WAV file to write")->required();
  c->render->add_option("--png", c->out_png, "Piano-roll picture to write");
  c->render->add_option("--trace", c->keep_trace, "Keep the virtual board's trace (CSV) here");
  return c;
}

int PlayCommand::run(std::atomic<bool> &stop) const {
  const bool rendering = render && render->parsed();
  const bool jamming = jam && jam->parsed();
  const std::string cmd = rendering ? "render" : jamming ? "jam" : "play";
  try {
    const Rig rig = load_rig(config);
    // jam's keyboard: the command line's, else the rig file's [midi] table (its policy below).
    const std::string midi_selector = midi.empty() ? rig.config.midi_input : midi;
    const std::string api_name = midi_api.empty() ? rig.config.midi_api : midi_api;
    const Song song = read_song_file(this->song, tab_options(sel.tab));
    for (const std::string &w : song.warnings) std::fprintf(stderr, "%s: warning: %s\n", cmd.c_str(), w.c_str());
    if (dry_run_motors > 0) {
      std::vector<uint8_t> ids(static_cast<size_t>(dry_run_motors));
      for (size_t m = 0; m < ids.size(); ++m) ids[m] = static_cast<uint8_t>(m);
      const std::string first = ports.empty() ? "" : ports[0];
      const Plan plan = plan_song(song, plan_options(sel, ids, motor_music(board_settings(rig, first, 0), 16000000, ids)));
      report_plan(cmd, song, plan, ids.size());
      report_arrangement(song, plan);
      for (const PlanEvent &e : plan_events(plan)) {
        if (e.silent)
          std::printf("%10.4f s  motor %u  silent\n", e.time_s, e.motor);
        else
          std::printf("%10.4f s  motor %u  note %.2f (%.3f Hz)\n", e.time_s, e.motor, e.pitch, note_hz(e.pitch));
      }
      return 0;
    }
    // The boards: --port (repeat it: their motors form one pool), else the rig file's unless a
    // virtual board's option was given, else the virtual boards started here (render: always).
    const bool virtual_asked = !vboards.empty() || !vboard_link.empty() || !vboard_trace.empty() || clock_ppm != 0;
    std::vector<std::string> paths = rendering ? std::vector<std::string>{} : rig_ports(rig, ports, virtual_asked);
    // Without a board: the virtual boards of --vboard, else of the rig file's boards (several:
    // one song on all), each with its trace (the first at the path given, the others beside it:
    // T-2.csv, ...).
    std::vector<std::unique_ptr<VirtualBoard>> vbs;
    std::vector<std::string> traces;
    if (paths.empty()) {
      std::string trace = rendering ? keep_trace : vboard_trace;
      if (rendering && trace.empty()) trace = "/tmp/stepchoir-render-" + std::to_string(::getpid()) + ".csv";
      // No per-instruction interrupt accounting: a faster simulation keeps real time on a busy
      // machine and renders sooner.
      std::vector<std::string> extra{"--no-measure"};
      // Render: as fast as the simulation runs, up to kRenderSpeed times real time, so that a
      // host stalled for a moment still keeps ahead of the board.
      if (rendering) extra.insert(extra.end(), {"--speed", std::to_string(kRenderSpeed)});
      if (clock_ppm != 0) extra.insert(extra.end(), {"--clock-ppm", std::to_string(clock_ppm)});
      if (!vboard_link.empty()) extra.insert(extra.end(), {"--link-model", vboard_link});
      const std::vector<std::string> vboards = rig_vboards(rig, this->vboards);
      for (size_t k = 0; k < vboards.size(); ++k) {
        const std::string link_path = vboard_link_path(cmd, k), t = vboard_trace_path(trace, k);
        vbs.push_back(std::make_unique<VirtualBoard>(vboards[k], link_path, t, extra));
        traces.push_back(t);
        if (!rendering)
          std::printf("%s: no --port: playing on the virtual board (%s) at %s\n", cmd.c_str(), vboards[k].c_str(),
                      link_path.c_str());
        paths.push_back(link_path);
      }
    }
    // Each board greeted and configured from the rig file (its virtual stand-in too).
    std::vector<BoardRun> boards;
    size_t pool_first = 0;  // jam: the pool number of this board's motor 0
    for (size_t b = 0; b < paths.size(); ++b) {
      BoardRun r;
      r.path = paths[b];
      r.board = std::make_unique<Board>(open_link(r.path));
      r.caps = vbs.empty() ? r.board->greet() : r.board->hello();  // its own board does not reset
      if (vbs.empty() && !rendering) recall(cmd, r.path, *r.board, &r.id, &r.known);
      r.settings = board_settings(rig, r.path, b);
      if (r.settings) configure_motors(*r.board, r.caps, *r.settings, r.path);
      if (rig.config.home_on_start && !rendering) home_board(*r.board, r.caps, r.settings, r.path, {}, say_line);
      for (uint8_t m = 0; m < r.caps.motor_count; ++m) {
        const int pooled = static_cast<int>(pool_first + m);
        if (!jamming || std::find(song_motors.begin(), song_motors.end(), pooled) != song_motors.end())
          r.song_ids.push_back(m);
        else r.live_ids.push_back(m);
      }
      pool_first += r.caps.motor_count;
      boards.push_back(std::move(r));
    }
    // Jam: the song's motors and the keyboard's, across the boards.
    if (jamming) {
      size_t song_count = 0, live_count = 0;
      for (const BoardRun &r : boards) song_count += r.song_ids.size(), live_count += r.live_ids.size();
      for (int m : song_motors)
        if (m < 0 || static_cast<size_t>(m) >= pool_first)
          throw std::runtime_error("--song-motors: motor " + std::to_string(m) + ": the boards have motors 0-" +
                                   std::to_string(pool_first - 1));
      if (song_count == 0 || live_count == 0)
        throw std::runtime_error("--song-motors: the song and the keyboard need at least one motor each (the boards have " +
                                 std::to_string(pool_first) + ")");
    }
    // The song's motors of every board form one pool, in board order; plan motor k is pool[k].
    std::vector<uint8_t> pool_ids;
    std::vector<MotorConfig> music;
    std::vector<std::pair<size_t, uint8_t>> owner;  // plan motor -> (board, index in its song_ids)
    for (size_t b = 0; b < boards.size(); ++b) {
      const auto m = motor_music(boards[b].settings, boards[b].caps.f_cpu_hz, boards[b].song_ids);
      for (size_t i = 0; i < m.size(); ++i) {
        pool_ids.push_back(static_cast<uint8_t>(pool_ids.size()));
        music.push_back(m[i]);
        owner.push_back({b, static_cast<uint8_t>(i)});
      }
    }
    const Plan plan = plan_song(song, plan_options(sel, pool_ids, music));
    report_plan(cmd, song, plan, pool_ids.size());
    std::vector<std::vector<PlanEvent>> events(boards.size());
    std::vector<double> first_note_s(boards.size(), -1);  // render: each board's first note
    for (PlanEvent e : plan_events(plan)) {
      const auto [b, i] = owner[e.motor];
      e.motor = i;
      if (!e.silent && first_note_s[b] < 0) first_note_s[b] = e.time_s;
      events[b].push_back(e);
    }
    if (jamming && midi_clock && (sel.tempo != 1.0 || sel.start_s != 0))
      throw std::runtime_error("--midi-clock: the clock sets the tempo and the position (no --tempo or --start)");
    JamSide jam_side;  // jam: the live path over every board's keyboard motors
    if (jamming)
      jam_side = start_jam(boards, rig, policy.empty() ? rig.config.policy : parse_policy(policy), api_name, midi_selector,
                           midi_clock, song.tempo);
    std::unique_ptr<LiveSession> &session = jam_side.session;
    std::unique_ptr<MidiIn> &midi_in = jam_side.midi_in;
    ConsoleSources &console_sources = jam_side.console_sources;
    std::vector<std::unique_ptr<MidiClockTimeline>> &timelines = jam_side.timelines;
    // One player a board; with several, they take one start (StartGate) and play on their own
    // clocks; a board lost mid-song drops its notes while the others play on.
    StartGate gate(boards.size());
    std::vector<std::unique_ptr<Player>> players;
    std::unique_ptr<PlayConsole> play_console;  // play on a terminal: the console (its keys: play's)
    if (!jamming && !rendering && !quiet && !plain) {
      std::vector<PlayBoard> pbs;
      for (const BoardRun &r : boards) {
        PlayBoard pb{r.path, r.song_ids.size(), {}, false, r.song_ids, {}};
        for (uint8_t m : r.song_ids) pb.travel_steps.push_back(motor_travel(r.settings, m));
        pbs.push_back(pb);
      }
      play_console = open_play_console(pbs, events, rig.config.a4_hz);
    }
    std::vector<std::unique_ptr<Board>> song_board_for_jam;  // jam: the live session's link stays open
    for (size_t b = 0; b < boards.size(); ++b) {
      PlayerOptions po;
      po.motors = boards[b].song_ids;
      po.exclusive = !jamming;
      po.board_time = rendering;
      po.lead_s = rendering ? kRenderLeadS : (lead_ms > 0 ? lead_ms : midi_clock ? kClockLeadMs : kLeadMs) / 1e3;
      po.sync_s = sync_s;
      if (reconnect_s >= 0) po.reconnect_s = reconnect_s;
      po.loop = loop && !rendering;
      po.auto_tune = !no_auto_tune;
      po.a4_hz = rig.config.a4_hz;
      if (boards[b].known) {
        po.crystal_ppm = boards[b].known->clock_ppm;
        po.crystal_sigma_ppm = boards[b].known->sigma_ppm;
      }
      if (boards.size() > 1) po.start_gate = [&gate, b](uint64_t now_us) { return gate.ready(b, now_us); };
      if (!timelines.empty()) po.song_clock = timelines[b].get();
      LinkOpener opener;
      const std::string path = boards[b].path;
      // A board back after a loss or a reset has its power-up defaults: the rig file's motors
      // are configured again before the song goes on (a TB6600's pulse, travel, soft limits).
      // Jam: the live path reopens the port, or hears a board that restarted with its link up
      // (its unasked capabilities), and configures the board (the link keeper, below: a new
      // link attached); the song finds it again through the session once it is there. The
      // song's player configures a restarted board the keeper did not.
      const BoardSettings *settings = boards[b].settings;
      if (settings && !jamming)
        po.on_reopen = [settings, path](Board &board, const Caps &caps) { configure_motors(board, caps, *settings, path); };
      else if (settings)
        po.on_reopen = configure_unless_kept(*session, b, *settings, path);
      if (!jamming) {
        opener = [path] { return open_link(path); };
      } else {
        po.open_resets = false;
        opener = [s = session.get(), b, path]() -> std::unique_ptr<Link> {
          if (!s->link_attached(b)) throw std::runtime_error("the live path is reconnecting it");
          return std::make_unique<JamLink>(*s, b, path);
        };
      }
      std::unique_ptr<Board> board = std::move(boards[b].board);
      if (jamming) {
        song_board_for_jam.push_back(std::move(board));
        board = std::make_unique<Board>(std::make_unique<JamLink>(*session, b, path));
      }
      players.push_back(std::make_unique<Player>(std::move(board), boards[b].caps, std::move(events[b]),
                                                 plan.duration_s, po, opener));
    }
    // jam on a terminal: the console (its keys: the stage's); else play's keys and progress line.
    std::unique_ptr<JamConsole> console;
    if (jamming && !quiet && !plain && ::isatty(0) && ::isatty(1)) {
      try {
        console = std::make_unique<JamConsole>(console_sources, rig.path.empty() ? default_config_path() : rig.path);
      } catch (const std::exception &e) {
        std::printf("jam: %s: the progress line instead\n", e.what());
      }
    }
    std::optional<Keys> keys;
    if (!console && !play_console) keys.emplace();
    const bool show = !quiet && !rendering && ::isatty(2) && !console && !play_console;
    std::vector<char> ok(players.size(), 1);
    std::vector<std::thread> others;
    // The latest progress of a board other than 0, its stats copied: play's console, keys and
    // progress line go on from it once board 0's player has ended (its board lost for good, or
    // its song over first) while another board plays on.
    std::mutex latest_lock;
    PlayerProgress latest;
    PlayerStats latest_stats;
    size_t latest_board = 0;
    std::atomic<size_t> others_playing{players.size() - 1};
    for (size_t b = 1; b < players.size(); ++b)
      others.emplace_back([&, b] {
        ok[b] = players[b]->run(stop, g_pause, [&, b](const PlayerProgress &p) {
          if (console) console->publish_clock(b, *p.stats);
          if (play_console) play_console->publish(b, *p.stats);
          std::lock_guard<std::mutex> hold(latest_lock);
          latest = p;
          latest_stats = *p.stats;
          latest.stats = &latest_stats;
          latest_board = b;
        });
        if (play_console) play_console->ended(b, ok[b]);
        gate.leave(b);
        --others_playing;
      });
    // The main thread's share of a progress call: board's progress, its stats that board's.
    int preset_shown = -1;  // jam: the keyboard's preset last told
    auto on_main = [&](const PlayerProgress &p, size_t board) {
      if (session && !session->presets().empty() && session->preset() != preset_shown) {
        preset_shown = session->preset();
        const LivePreset &lp = session->presets()[static_cast<size_t>(preset_shown)];
        if (!console) say_line(cmd + ": preset " + std::to_string(lp.program + 1) + " " + lp.name);
      }
      if (console && board == 0 && !console->update(*session, p, midi_in.get())) stop = true;
      if (play_console && !play_console->update(p, board)) stop = true;
      if (keys && keys->poll()) stop = true;
      if (show) print_progress(p);
    };
    // Jam: a board whose link fails is reopened by the live path (as live does), its motors
    // configured again; its song player finds it by its restarted clock.
    std::unique_ptr<LinkKeeper> keeper;
    if (jamming) {
      std::vector<LinkKeeper::Port> ports;
      for (const BoardRun &r : boards) ports.push_back({r.path, r.caps.motor_count, r.settings});
      keeper = std::make_unique<LinkKeeper>(*session, ports, song_board_for_jam, [&console, cmd](const std::string &line) {
        if (!console) say_line(cmd + ": " + line);
      });
    }
    ok[0] = players[0]->run(stop, g_pause, [&](const PlayerProgress &p) { on_main(p, 0); });
    if (play_console) play_console->ended(0, ok[0]);
    gate.leave(0);
    while (!jamming && others_playing.load() > 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      PlayerProgress p;
      PlayerStats st;
      size_t board = 0;
      {
        std::lock_guard<std::mutex> hold(latest_lock);
        if (!latest.stats) continue;
        p = latest;
        st = latest_stats;
        board = latest_board;
      }
      p.stats = &st;
      on_main(p, board);
    }
    for (std::thread &t : others) t.join();
    keeper.reset();
    console.reset();  // the terminal as it was, before the reports
    play_console.reset();
    if (show) std::fprintf(stderr, "\n");
    if (jamming) {
      midi_in.reset();  // no more callbacks
      session->stop();  // the keyboard's motors silent, then stop-all
      if (!timelines.empty())
        std::printf("jam: MIDI clock: %llu ticks, %llu of them lost on the way and put back by their time, "
                    "%llu delivered twice and taken once\n",
                    static_cast<unsigned long long>(timelines[0]->follower().ticks()),
                    static_cast<unsigned long long>(timelines[0]->follower().lost_ticks()),
                    static_cast<unsigned long long>(timelines[0]->follower().twin_ticks()));
      std::printf("jam: %llu MIDI events, latency p50 %llu us, p99 %llu us\n",
                  static_cast<unsigned long long>(session->events()),
                  static_cast<unsigned long long>(session->latency().percentile(0.5)),
                  static_cast<unsigned long long>(session->latency().percentile(0.99)));
    }
    bool all_ok = true;
    for (size_t b = 0; b < players.size(); ++b) {
      report_player(players.size() > 1 ? cmd + ": " + boards[b].path : cmd, players[b]->stats(), ok[b], stop.load(),
                    !rendering);
      if (!ok[b]) std::fprintf(stderr, "%s: %s\n", cmd.c_str(), players[b]->error().c_str());
      const ClockSync &clock = players[b]->clock();
      if (ok[b] && boards[b].id && !no_auto_tune && clock.has_rate())
        remember(cmd, *boards[b].id, {boards[b].caps.board_name, clock.ppm(), clock.rate_sigma_ppm()});
      all_ok = all_ok && ok[b];
    }
    if (!all_ok) return 1;
    if (rendering && !write_render(vbs, traces, first_note_s, out_wav, out_png, !keep_trace.empty())) return 1;
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "stepchoir %s: %s\n", cmd.c_str(), e.what());
    return 1;
  }
}

}  // namespace stepchoir
