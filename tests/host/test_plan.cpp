// test_plan.cpp: the song planner and its arranger: lines kept on motors, stealing, restrikes,
// selection; percussion, melody first, bass second, doublings merged, folding, the user's
// overrides; and the coverage targets on the checked-in General MIDI songs.
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>

#include "arrangement_metrics.h"
#include "player/arranger.h"
#include "player/plan.h"
#include "song/song.h"

using namespace stepchoir;

namespace {

// Song with the given notes (onset, duration, note, track, channel).
Song song_of(std::initializer_list<SongNote> notes) {
  Song s;
  s.notes = notes;
  for (const SongNote &n : s.notes) s.track_count = std::max<uint16_t>(s.track_count, static_cast<uint16_t>(n.track + 1));
  finish_song(s, 0);
  return s;
}

SongNote note(double on, double dur, int midi, int track = 0, int channel = 0) {
  SongNote n;
  n.onset_s = on;
  n.duration_s = dur;
  n.midi_note = static_cast<uint8_t>(midi);
  n.velocity = 100;
  n.track = static_cast<uint16_t>(track);
  n.channel = static_cast<uint8_t>(channel);
  return n;
}

SongNote hit(double on, int gm_key) {
  SongNote n = note(on, 0.005, gm_key, 1, kGmDrumChannel);
  n.percussion = true;
  return n;
}

PlanOptions motors(size_t n) {
  PlanOptions o;
  o.motors.assign(n, MotorConfig{});
  return o;
}

// The planned note of song note index i, or nullptr.
const PlannedNote *planned(const Plan &p, uint32_t i) {
  for (const PlannedNote &n : p.notes)
    if (n.song_index == i) return &n;
  return nullptr;
}

// The reason song note i is not played, or -1 when it is.
int why(const Plan &p, uint32_t i) {
  for (const UnplayedNote &u : p.unplayed)
    if (u.song_index == i) return static_cast<int>(u.why);
  return -1;
}

// The index in s.notes of the note with this onset and key.
uint32_t index_of(const Song &s, double on, int midi) {
  for (uint32_t i = 0; i < s.notes.size(); ++i)
    if (s.notes[i].onset_s == on && s.notes[i].midi_note == midi) return i;
  FAIL("no note " << midi << " at " << on);
  return 0;
}

}  // namespace

TEST_CASE("plan: a melodic line stays on its motor, and another line takes another", "[plan]") {
  // Line A: four notes legato on track 0; line B: two long notes on track 1.
  const Song s = song_of({note(0, 0.5, 60), note(0.5, 0.5, 62), note(1.0, 0.5, 64), note(1.5, 0.5, 65),
                          note(0, 1, 48, 1), note(1, 1, 50, 1)});
  const Plan p = plan_song(s, motors(3));
  REQUIRE(p.notes.size() == 6);
  CHECK(p.unplayed.empty());
  int motor_a = -1, motor_b = -1;
  for (const PlannedNote &n : p.notes) {
    int &want = s.notes[n.song_index].track == 0 ? motor_a : motor_b;
    if (want < 0) want = n.motor;
    CHECK(int{n.motor} == want);
  }
  CHECK(motor_a != motor_b);
  // Legato on one motor: no silence between the notes of a line.
  const auto ev = plan_events(p);
  size_t silences = 0;
  for (const PlanEvent &e : ev) silences += e.silent;
  CHECK(silences == 2);  // each line's end only
}

TEST_CASE("plan: a note of the same rank is not cut short before 70 % of it has sounded", "[plan]") {
  // Both are melody (each the highest for all its time); the second finds the motor busy.
  const Song s = song_of({note(0, 1, 60), note(0.5, 1, 64)});
  const Plan p = plan_song(s, motors(1));
  REQUIRE(p.notes.size() == 1);
  CHECK(p.notes[0].off_s == Approx(1));
  REQUIRE(p.unplayed.size() == 1);
  CHECK(s.notes[p.unplayed[0].song_index].midi_note == 64);
  CHECK(p.unplayed[0].why == Unplayed::kNoMotor);
  CHECK(p.shortened == 0);
}

TEST_CASE("plan: a note nearly done makes way for a new one (cut short, counted)", "[plan]") {
  const Song s = song_of({note(0, 1, 60), note(0.9, 1, 64)});
  const Plan p = plan_song(s, motors(1));
  REQUIRE(p.notes.size() == 2);
  CHECK(p.shortened == 1);
  CHECK(p.notes[0].off_s == Approx(0.9));
  CHECK(p.notes[1].on_s == Approx(0.9));
}

TEST_CASE("plan: the same note again strikes again after a short gap", "[plan]") {
  const Song s = song_of({note(0, 0.5, 60), note(0.5, 0.5, 60)});
  const Plan p = plan_song(s, motors(1));
  REQUIRE(p.notes.size() == 2);
  CHECK(p.notes[0].off_s == Approx(0.5 - kRestrikeGapS));
  const auto ev = plan_events(p);
  REQUIRE(ev.size() == 4);
  CHECK(ev[1].silent);
  CHECK(ev[1].time_s == Approx(0.49));
}

TEST_CASE("plan: selection, tempo, transpose, start position and short notes", "[plan]") {
  const Song s = song_of({note(0, 1, 60, 0, 0), note(1, 1, 62, 0, 0), note(0, 2, 40, 1, 9), note(2, 0.004, 70, 0, 0),
                          note(2.5, 1, 72, 0, 0)});
  PlanOptions o = motors(4);
  o.mute_channels = {9};
  o.tempo_scale = 2;
  o.transpose = 12;
  o.start_s = 0.5;
  const Plan p = plan_song(s, o);
  REQUIRE(p.notes.size() == 3);
  CHECK(p.selected == 4);  // the muted channel's note is not selected
  CHECK(p.notes[0].on_s == Approx(0));      // cut at the start position
  CHECK(p.notes[0].off_s == Approx(0.25));  // (1 - 0.5) / 2
  CHECK(p.notes[0].pitch == Approx(72));
  CHECK(p.notes[1].on_s == Approx(0.25));
  CHECK(p.notes[2].on_s == Approx(1.0));    // (2.5 - 0.5) / 2
  REQUIRE(p.unplayed.size() == 1);
  CHECK(p.unplayed[0].why == Unplayed::kTooShort);
  CHECK(p.duration_s == Approx((3.5 - 0.5) / 2));
  o = motors(4);
  o.tracks = {1};
  CHECK(plan_song(s, o).notes.size() == 1);
  o.tracks = {};
  o.channels = {9};
  CHECK(plan_song(s, o).notes.size() == 1);
}

TEST_CASE("plan: notes outside a motor's range fold into it, and no motor at all is an error", "[plan]") {
  PlanOptions o = motors(1);
  o.motors[0].lowest_note = 48;
  o.motors[0].highest_note = 72;
  const Plan p = plan_song(song_of({note(0, 1, 100)}), o);
  REQUIRE(p.notes.size() == 1);
  CHECK(p.notes[0].pitch == Approx(64));
  CHECK_THROWS_AS(plan_song(song_of({note(0, 1, 60)}), PlanOptions{}), std::invalid_argument);
  o.tempo_scale = 0;
  CHECK_THROWS_AS(plan_song(song_of({note(0, 1, 60)}), o), std::invalid_argument);
}

TEST_CASE("plan: a chord sounds on as many motors, and the events of one time stay together", "[plan]") {
  const Song s = song_of({note(0, 1, 60), note(0, 1, 64), note(0, 1, 67)});
  const Plan p = plan_song(s, motors(5));
  REQUIRE(p.notes.size() == 3);
  const auto ev = plan_events(p);
  REQUIRE(ev.size() == 6);
  for (size_t i = 0; i < 3; ++i) CHECK_FALSE(ev[i].silent);
  CHECK(ev[0].motor != ev[1].motor);
  CHECK(ev[1].motor != ev[2].motor);
}

TEST_CASE("plan: a note's end and the next one's start meet even when their sums round apart", "[plan]") {
  // 0.1 + 0.2 is 0.30000000000000004 in doubles: still legato, no silence between.
  SongNote a = note(0.1, 0.2, 60), b = note(0.3, 0.5, 62);
  const Plan p = plan_song(song_of({a, b}), motors(1));
  const auto ev = plan_events(p);
  REQUIRE(ev.size() == 3);
  CHECK_FALSE(ev[0].silent);
  CHECK_FALSE(ev[1].silent);
  CHECK(ev[2].silent);
}

TEST_CASE("arranger: percussion is never sung, and --drums plays it as bursts on its own motor", "[plan]") {
  // A kick, a closed hat and a snare under a melody note.
  const Song s = song_of({note(0, 1, 72), hit(0, 36), hit(0, 42), hit(0.25, 38), hit(0.5, 42)});
  const Plan p = plan_song(s, motors(4));
  REQUIRE(p.notes.size() == 1);
  CHECK(s.notes[p.notes[0].song_index].midi_note == 72);
  CHECK(std::count_if(p.unplayed.begin(), p.unplayed.end(),
                      [](const UnplayedNote &u) { return u.why == Unplayed::kPercussion; }) == 4);
  PlanOptions o = motors(2);
  o.drum_motor = 1;
  const Plan d = plan_song(s, o);
  // The kick and the hat at one time: the kick plays (it matters most), the hat is left out.
  const PlannedNote *kick = planned(d, index_of(s, 0, 36));
  REQUIRE(kick != nullptr);
  CHECK(kick->motor == 1);
  CHECK(kick->role == Role::kPercussion);
  CHECK(kick->off_s - kick->on_s == Approx(0.08));  // a burst, not the file's 5 ms
  CHECK(why(d, index_of(s, 0, 42)) == static_cast<int>(Unplayed::kDrumTogether));
  const PlannedNote *snare = planned(d, index_of(s, 0.25, 38));
  const PlannedNote *hat = planned(d, index_of(s, 0.5, 42));
  REQUIRE(snare != nullptr);
  REQUIRE(hat != nullptr);
  // Low kick, mid snare, high hat.
  CHECK(kick->pitch < snare->pitch);
  CHECK(snare->pitch < hat->pitch);
  // The melody keeps the other motor; the drum motor sings nothing else.
  const PlannedNote *melody = planned(d, index_of(s, 0, 72));
  REQUIRE(melody != nullptr);
  CHECK(melody->motor == 0);
  o.drum_motor = 2;
  CHECK_THROWS_AS(plan_song(s, o), std::invalid_argument);
}

TEST_CASE("arranger: the melody takes a motor before accompaniment that started first", "[plan]") {
  // A three-note chord held for 2 s on three motors; the tune enters above it at 0.5 s.
  const Song s = song_of({note(0, 2, 48, 1), note(0, 2, 55, 1), note(0, 2, 64, 1), note(0.5, 0.5, 72),
                          note(1.0, 0.5, 74), note(1.5, 0.5, 76)});
  const Plan p = plan_song(s, motors(3));
  for (double on : {0.5, 1.0, 1.5}) {
    const PlannedNote *m = planned(p, index_of(s, on, on == 0.5 ? 72 : on == 1.0 ? 74 : 76));
    REQUIRE(m != nullptr);
    CHECK(m->role == Role::kMelody);
    CHECK(m->on_s == on);  // never waits for a motor
  }
  // The bass stays too, and the chord's top (the highest note until the tune enters); the
  // inner chord note gives way.
  CHECK(planned(p, index_of(s, 0, 64)) != nullptr);
  CHECK(planned(p, index_of(s, 0, 48)) != nullptr);
  CHECK(planned(p, index_of(s, 0, 48))->role == Role::kBass);
  CHECK(planned(p, index_of(s, 0, 55)) == nullptr);
  CHECK(why(p, index_of(s, 0, 55)) == static_cast<int>(Unplayed::kNoMotor));
}

TEST_CASE("arranger: with two motors the melody and the bass play, the inner voices give way", "[plan]") {
  // Four lines in four tracks, each note 1 s: soprano, alto, tenor, bass.
  std::initializer_list<SongNote> notes = {note(0, 1, 72, 0), note(0, 1, 67, 1), note(0, 1, 64, 2), note(0, 1, 48, 3),
                                           note(1, 1, 74, 0), note(1, 1, 65, 1), note(1, 1, 62, 2), note(1, 1, 43, 3)};
  const Song s = song_of(notes);
  const Plan p = plan_song(s, motors(2));
  REQUIRE(p.notes.size() == 4);
  for (const PlannedNote &n : p.notes) {
    const int track = s.notes[n.song_index].track;
    CHECK((track == 0 || track == 3));
    CHECK(n.role == (track == 0 ? Role::kMelody : Role::kBass));
  }
  // Each line on its own motor throughout.
  CHECK(planned(p, index_of(s, 0, 72))->motor == planned(p, index_of(s, 1, 74))->motor);
  CHECK(planned(p, index_of(s, 0, 48))->motor == planned(p, index_of(s, 1, 43))->motor);
  const kit::ArrangementFigures f = kit::measure_arrangement(s, p);
  CHECK(f.melody == Approx(1));
  CHECK(f.bass == Approx(1));
  // --keep: the user's choice of roles; --voices: the user's lines first.
  PlanOptions o = motors(2);
  o.keep = {Role::kMelody};
  CHECK(plan_song(s, o).notes.size() == 2);
  o = motors(2);
  o.voices = {LineSelector{false, 1}, LineSelector{false, 2}};  // alto and tenor
  const Plan v = plan_song(s, o);
  REQUIRE(v.notes.size() == 4);
  for (const PlannedNote &n : v.notes) CHECK((s.notes[n.song_index].track == 1 || s.notes[n.song_index].track == 2));
}

TEST_CASE("arranger: with motors short, a unison or octave doubling across tracks takes none", "[plan]") {
  // Track 1 doubles the tune in unison, track 2 an octave below (10 ms late); track 3 is the bass.
  const Song s = song_of({note(0, 1, 72, 0), note(0, 1, 72, 1), note(0.01, 0.99, 60, 2), note(0, 1, 41, 3),
                          note(1, 1, 74, 0), note(1, 1, 74, 1), note(1, 1, 62, 2), note(1, 1, 43, 3)});
  const Plan p = plan_song(s, motors(2));
  size_t doubled = 0;
  for (const UnplayedNote &u : p.unplayed) {
    CHECK(u.why == Unplayed::kDoubled);
    CHECK((s.notes[u.song_index].track == 1 || s.notes[u.song_index].track == 2));
    ++doubled;
  }
  CHECK(doubled == 4);
  CHECK(p.notes.size() == 4);  // the tune and the bass, twice
  // With motors to spare the doublings sound too (a unison is louder).
  CHECK(plan_song(s, motors(4)).notes.size() == 8);
  // A note that goes on after its double ends holds that note on when no motor is free...
  const Song t = song_of({note(0, 1, 67, 0), note(0.5, 0.7, 55, 1), note(0, 2, 48, 2)});
  CHECK(plan_song(t, motors(3)).notes.size() == 3);  // ...and takes a free one if there is
  const Plan q = plan_song(t, motors(2));
  REQUIRE(q.notes.size() == 2);
  CHECK(planned(q, index_of(t, 0, 67))->off_s == Approx(1.2));
  CHECK(why(q, index_of(t, 0.5, 55)) == static_cast<int>(Unplayed::kDoubled));
  // The same note again in one line is struck again, not merged.
  const Song r = song_of({note(0, 0.5, 60), note(0.5, 0.5, 60)});
  CHECK(plan_song(r, motors(2)).notes.size() == 2);
}

TEST_CASE("arranger: a note out of every motor's range folds by octaves, keeping its role", "[plan]") {
  PlanOptions o = motors(2);
  for (MotorConfig &m : o.motors) m.lowest_note = 48, m.highest_note = 72;
  const Song s = song_of({note(0, 1, 96), note(0, 1, 24, 1)});
  const Plan p = plan_song(s, o);
  REQUIRE(p.notes.size() == 2);
  const PlannedNote *top = planned(p, index_of(s, 0, 96));
  const PlannedNote *low = planned(p, index_of(s, 0, 24));
  CHECK(top->pitch == Approx(72));
  CHECK(top->octaves == -2);
  CHECK(top->role == Role::kMelody);
  CHECK(low->pitch == Approx(48));
  CHECK(low->octaves == 2);
  CHECK(low->role == Role::kBass);
}

TEST_CASE("arranger: the highest line of the one track named as lead is melody too", "[plan]") {
  Song s = song_of({note(0, 1, 60, 0), note(0, 1, 64, 0), note(0, 1, 67, 1), note(0, 1, 40, 2)});
  s.track_names = {"Lead Vocal", "Strings", "Bass"};
  Plan p = plan_song(s, motors(3));
  // The lead's own highest note, the texture's top and its bottom play; the lead's lower note
  // gives way.
  REQUIRE(planned(p, index_of(s, 0, 64)) != nullptr);
  CHECK(planned(p, index_of(s, 0, 64))->role == Role::kMelody);
  CHECK(planned(p, index_of(s, 0, 67)) != nullptr);
  CHECK(planned(p, index_of(s, 0, 40)) != nullptr);
  CHECK(why(p, index_of(s, 0, 60)) == static_cast<int>(Unplayed::kNoMotor));
  // Two tracks so named are parts: the texture alone decides.
  s.track_names = {"Solo-1", "Solo-2", "Bass"};
  p = plan_song(s, motors(4));
  REQUIRE(planned(p, index_of(s, 0, 64)) != nullptr);
  CHECK(planned(p, index_of(s, 0, 64))->role == Role::kInner);
  CHECK(lead_track_name("MELODY"));
  CHECK_FALSE(lead_track_name("Chord-Piano"));
}

TEST_CASE("arranger: the checked-in General MIDI songs meet the coverage targets on 4 motors", "[plan]") {
  for (const char *file : {"band-blues.mid", "band-waltz.mid"}) {
    const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/" + file);
    size_t drums = 0;
    for (const SongNote &n : s.notes) drums += n.percussion;
    REQUIRE(drums > 50);  // a band arrangement: the drums are there to be left out
    const kit::ArrangementFigures f = kit::measure_arrangement(s, plan_song(s, motors(4)));
    INFO(file << ": melody " << f.melody << ", bass " << f.bass << ", drum hits sung " << f.drum_hits_sung);
    CHECK(f.melody >= 0.97);
    CHECK(f.bass >= 0.90);
    CHECK(f.drum_hits_sung == 0);
  }
}
