// test_midi_tools.cpp: the MIDI reader against midicsv (Debian midicsv), on files written by
// csvmidi (running status, tempo changes, several tracks, SMPTE division) and abc2midi (two
// voices, a tempo change): both must give the same notes at the same times.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "song/song.h"

using namespace stepchoir;

namespace {

// Runs a shell command; fails the test when it fails. Called by the tests.
void sh(const std::string &cmd) {
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
}

// A scratch path. Called by the tests.
std::string scratch(const std::string &name) { return std::string(STEPCHOIR_SCRATCH) + "/" + name; }

// The notes of a MIDI file as midicsv prints it, timed with a tempo map built from its Tempo
// rows: the oracle, written from the SMF spec independently of the reader. Called by compare.
std::vector<SongNote> notes_by_midicsv(const std::string &mid) {
  const std::string csv = mid + ".csv";
  sh("midicsv " + mid + " " + csv);
  std::ifstream in(csv);
  std::string line;
  int division = 0;
  std::map<long, long> tempo;  // tick -> us per quarter note (the last one at a tick wins)
  struct Event {
    int track;
    long tick;
    int channel, note, velocity;
    bool on;
  };
  std::vector<Event> events;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell.substr(cell.find_first_not_of(' ')));
    if (f.size() < 3) continue;
    const int track = std::stoi(f[0]);
    const long tick = std::stol(f[1]);
    if (f[2] == "Header") division = std::stoi(f[5]);
    if (f[2] == "Tempo") tempo[tick] = std::stol(f[3]);
    if (f[2] == "Note_on_c" || f[2] == "Note_off_c")
      events.push_back({track - 1, tick, std::stoi(f[3]), std::stoi(f[4]), std::stoi(f[5]),
                        f[2] == "Note_on_c" && std::stoi(f[5]) > 0});
  }
  REQUIRE(division != 0);
  auto seconds = [&](long tick) {
    if (division < 0) {  // SMPTE: high byte -frames per second, low byte ticks per frame
      const int fps = -static_cast<int8_t>((division >> 8) & 0xFF);
      const double rate = fps == 29 ? 30000.0 / 1001.0 : fps;
      return tick / (rate * (division & 0xFF));
    }
    double s = 0, us_per_qn = 500000;
    long at = 0;
    for (const auto &[t, us] : tempo) {
      if (t >= tick) break;
      s += (t - at) * us_per_qn * 1e-6 / division;
      at = t;
      us_per_qn = us;
    }
    return s + (tick - at) * us_per_qn * 1e-6 / division;
  };
  std::map<std::tuple<int, int, int>, std::vector<Event>> open;  // first in, first out
  std::vector<SongNote> out;
  for (const auto &e : events) {
    auto &q = open[{e.track, e.channel, e.note}];
    if (e.on) {
      q.push_back(e);
    } else if (!q.empty()) {
      const Event on = q.front();
      q.erase(q.begin());
      if (e.tick == on.tick) continue;
      SongNote n;
      n.onset_s = seconds(on.tick);
      n.duration_s = seconds(e.tick) - n.onset_s;
      n.midi_note = static_cast<uint8_t>(e.note);
      n.velocity = static_cast<uint8_t>(on.velocity);
      n.track = static_cast<uint16_t>(e.track);
      n.channel = static_cast<uint8_t>(e.channel);
      out.push_back(n);
    }
  }
  return out;
}

// Reads mid with the reader and with midicsv and compares note by note. Called by the tests.
void compare(const std::string &mid, size_t min_notes) {
  const Song song = read_song_file(mid);
  std::vector<SongNote> want = notes_by_midicsv(mid);
  auto key = [](const SongNote &n) { return std::make_tuple(n.track, n.channel, n.midi_note, n.onset_s); };
  auto by_key = [&](const SongNote &a, const SongNote &b) { return key(a) < key(b); };
  std::vector<SongNote> got = song.notes;
  std::sort(got.begin(), got.end(), by_key);
  std::sort(want.begin(), want.end(), by_key);
  CHECK(got.size() >= min_notes);
  REQUIRE(got.size() == want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    INFO(mid << " note " << i);
    CHECK(got[i].onset_s == Approx(want[i].onset_s).margin(1e-9));
    CHECK(got[i].duration_s == Approx(want[i].duration_s).margin(1e-9));
    CHECK(int{got[i].midi_note} == int{want[i].midi_note});
    CHECK(int{got[i].velocity} == int{want[i].velocity});
    CHECK(got[i].track == want[i].track);
    CHECK(int{got[i].channel} == int{want[i].channel});
  }
}

// A random CSV song for csvmidi: a tempo track with changes and note tracks on several
// channels, with note-offs of both kinds and overlapping same-pitch notes. Called by the tests.
std::string random_csv(unsigned seed, int division) {
  std::mt19937 rng(seed);
  const int tracks = 4;
  std::ostringstream csv;
  csv << "0, 0, Header, 1, " << tracks << ", " << division << "\n1, 0, Start_track\n";
  long tick = 0;
  for (int k = 0; k < 8; ++k) {
    csv << "1, " << tick << ", Tempo, " << 200000 + rng() % 900000 << "\n";
    tick += 1 + rng() % 2000;
  }
  csv << "1, " << tick << ", End_track\n";
  for (int t = 2; t <= tracks; ++t) {
    csv << t << ", 0, Start_track\n";
    std::vector<std::tuple<long, int, int, int, bool>> ev;  // tick, channel, note, velocity, on
    for (int k = 0; k < 60; ++k) {
      const long start = rng() % 8000, len = 1 + rng() % 700;
      const int ch = static_cast<int>(rng() % 3) + (t - 2) * 3, note = 36 + static_cast<int>(rng() % 48);
      ev.emplace_back(start, ch, note, 1 + static_cast<int>(rng() % 127), true);
      ev.emplace_back(start + len, ch, note, rng() % 2 ? 0 : 64, false);
    }
    std::stable_sort(ev.begin(), ev.end(), [](const auto &a, const auto &b) {
      return std::get<0>(a) < std::get<0>(b) || (std::get<0>(a) == std::get<0>(b) && !std::get<4>(a) && std::get<4>(b));
    });
    long last = 0;
    for (const auto &[at, ch, note, vel, on] : ev) {
      // Offs are written as Note_off_c or as Note_on_c with velocity 0, at random.
      if (on) csv << t << ", " << at << ", Note_on_c, " << ch << ", " << note << ", " << vel << "\n";
      else if (vel == 0) csv << t << ", " << at << ", Note_on_c, " << ch << ", " << note << ", 0\n";
      else csv << t << ", " << at << ", Note_off_c, " << ch << ", " << note << ", " << vel << "\n";
      last = at;
    }
    csv << t << ", " << last << ", End_track\n";
  }
  csv << "0, 0, End_of_file\n";
  return csv.str();
}

}  // namespace

TEST_CASE("midi tools: csvmidi files (running status, tempo map, 4 tracks) read as midicsv reads them") {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const std::string base = scratch("random" + std::to_string(seed));
    std::ofstream(base + ".csv0") << random_csv(seed, seed % 2 ? 480 : 96);
    sh("csvmidi -z " + base + ".csv0 " + base + ".mid");
    compare(base + ".mid", 150);
  }
}

TEST_CASE("midi tools: csvmidi files with SMPTE division (25 fps x 40, 29.97 fps x 80)") {
  for (const int division : {0xE728, 0xE350}) {
    const std::string base = scratch("smpte" + std::to_string(division));
    std::ofstream(base + ".csv0") << random_csv(77, division);
    sh("csvmidi -z " + base + ".csv0 " + base + ".mid");
    compare(base + ".mid", 150);
  }
}

TEST_CASE("midi tools: an abc2midi file with two voices and a tempo change") {
  const std::string base = scratch("tune");
  std::ofstream(base + ".abc") << "X:1\nT:test\nM:4/4\nL:1/8\nQ:1/4=100\nK:D\nV:1\nDEFG ABcd|[Q:1/4=150] e2 d2 c2 B2|"
                                  "[Q:1/4=60] A8|\nV:2\nD,4 A,4|[Q:1/4=150] D,2 F,2 A,2 D2|[Q:1/4=60] [D,A,]8|\n";
  sh("abc2midi " + base + ".abc -o " + base + ".mid -silent > /dev/null");
  compare(base + ".mid", 20);
}
