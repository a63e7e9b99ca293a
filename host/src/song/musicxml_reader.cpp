// musicxml_reader.cpp: MusicXML scores (.musicxml, .xml, and compressed .mxl), as MuseScore,
// Finale, Sibelius and Dorico export them, into a Song: parts (one track each), voices and
// chords, ties, rests, grace notes left out, backup and forward, tempo from <sound tempo> or a
// metronome mark, transposing instruments at sounding pitch, repeats and voltas played out,
// unpitched percussion as drum hits. XML by pugixml, the .mxl container by libzip.
#include <pugixml.hpp>
#include <zip.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "song/song.h"

namespace stepchoir {

namespace {

constexpr double kDefaultBpm = 120;     // MusicXML's default tempo, quarter notes a minute
constexpr uint8_t kDefaultVelocity = 90;  // dynamics 100 (forte-ish) in MusicXML's scale
// Bounds on what a file may ask for (far above real scores; memory stays bounded whatever the
// file): measures and notes once repeats are played out, times one repeat is taken, the length
// of one note or step in quarter notes, divisions of a quarter note.
constexpr size_t kMaxPlayedMeasures = 100000;
constexpr size_t kMaxNotes = 1000000;
constexpr int kMaxRepeatTimes = 100;
constexpr double kMaxQuarters = 10000;
constexpr double kMaxDivisions = 1e7;

// A tempo from a beat position on (quarter notes from the start, in playing order).
struct Tempo {
  double beat, bpm;
};

// A note on the beat line, before the tempo map.
struct BeatNote {
  double on, length;  // quarter notes
  int key;
  uint8_t velocity;
  uint16_t track;
  uint8_t channel;
  bool percussion;
};

// A part's MIDI settings from <part-list>.
struct PartInfo {
  std::string name;
  int channel = -1;                      // 0-15, or -1 when the file names none
  std::map<std::string, int> unpitched;  // instrument id -> GM percussion key
  bool percussion = false;
};

// Reads one file. Used only by read_musicxml.
class MusicXmlParser {
 public:
  MusicXmlParser(const std::string &name) : name_(name) {}

  // Called by read_musicxml with the XML text.
  Song parse(const char *data, size_t size) {
    pugi::xml_document doc;
    const pugi::xml_parse_result r = doc.load_buffer(data, size);
    if (!r) throw SongError(name_ + ": byte " + std::to_string(r.offset) + ": not well-formed XML: " + r.description());
    const pugi::xml_node score = doc.child("score-partwise");
    if (!score) {
      if (doc.child("score-timewise"))
        throw SongError(name_ + ": a timewise score; export the score partwise (every editor's default)");
      throw SongError(name_ + ": expected a MusicXML score (<score-partwise>)");
    }
    read_part_list(score.child("part-list"));
    uint16_t track = 0;
    for (pugi::xml_node part : score.children("part")) {
      read_part(part, track);
      if (++track == 0) throw SongError(name_ + ": more than 65535 parts");
    }
    if (track == 0) throw SongError(name_ + ": no <part> in the score");
    return build(track);
  }

 private:
  const std::string &name_;
  std::map<std::string, PartInfo> parts_;
  std::vector<std::string> part_order_;
  std::vector<BeatNote> notes_;
  std::vector<Tempo> tempos_;
  std::vector<std::string> track_names_;
  double end_beat_ = 0;

  // "file: part 'P1' measure 4: what". Called by the checks.
  [[noreturn]] void fail(const std::string &where, const std::string &what) const {
    throw SongError(name_ + ": " + where + ": " + what);
  }

  // Called by parse.
  void read_part_list(pugi::xml_node list) {
    for (pugi::xml_node sp : list.children("score-part")) {
      PartInfo info;
      info.name = sp.child_value("part-name");
      for (pugi::xml_node mi : sp.children("midi-instrument")) {
        const int ch = mi.child("midi-channel").text().as_int(0);
        if (ch >= 1 && ch <= 16 && info.channel < 0) info.channel = ch - 1;
        const int key = mi.child("midi-unpitched").text().as_int(0);  // 1-128
        if (key >= 1 && key <= 128) info.unpitched[mi.attribute("id").value()] = key - 1;
      }
      info.percussion = info.channel == kGmDrumChannel;
      parts_[sp.attribute("id").value()] = info;
    }
  }

  // The measures of a part in playing order: repeats and voltas played out. Called by read_part.
  std::vector<pugi::xml_node> playing_order(const std::vector<pugi::xml_node> &measures, const std::string &where) {
    std::vector<pugi::xml_node> out;
    std::map<size_t, int> repeats_done;  // backward repeat measure -> times taken
    size_t start = 0;
    int pass = 1;
    for (size_t i = 0; i < measures.size();) {
      if (out.size() > kMaxPlayedMeasures) fail(where, "repeats play more than 100000 measures");
      const pugi::xml_node m = measures[i];
      // A volta not for this pass: skip to the end of its ending.
      bool skip = false;
      for (pugi::xml_node b : m.children("barline")) {
        const pugi::xml_node e = b.child("ending");
        if (!e || std::strcmp(e.attribute("type").value(), "start") != 0) continue;
        std::string numbers = e.attribute("number").value();
        std::replace(numbers.begin(), numbers.end(), ',', ' ');
        bool ours = false;
        for (size_t p = 0; p < numbers.size();) {
          size_t q = numbers.find(' ', p);
          if (q == std::string::npos) q = numbers.size();
          if (q > p && std::atoi(numbers.substr(p, q - p).c_str()) == pass) ours = true;
          p = q + 1;
        }
        skip = !ours;
      }
      if (skip) {
        size_t j = i;
        for (; j < measures.size(); ++j) {
          bool stops = false;
          for (pugi::xml_node b : measures[j].children("barline")) {
            const pugi::xml_node e = b.child("ending");
            const std::string type = e.attribute("type").value();
            if (e && (type == "stop" || type == "discontinue")) stops = true;
          }
          if (stops) break;
        }
        i = j + 1;
        continue;
      }
      out.push_back(m);
      int times = 0;
      bool ending_ends = false;
      for (pugi::xml_node b : m.children("barline")) {
        const std::string ending = b.child("ending").attribute("type").value();
        ending_ends |= ending == "stop" || ending == "discontinue";
        const pugi::xml_node r = b.child("repeat");
        if (!r) continue;
        if (std::strcmp(r.attribute("direction").value(), "forward") == 0) start = i;
        if (std::strcmp(r.attribute("direction").value(), "backward") == 0) {
          times = r.attribute("times").as_int(2);
          if (times < 1 || times > kMaxRepeatTimes)
            fail(where + " measure " + m.attribute("number").value(),
                 "repeat times " + std::to_string(times) + ": expected 1 to " + std::to_string(kMaxRepeatTimes));
        }
      }
      if (times > 0 && repeats_done[i] < times - 1) {
        ++repeats_done[i];
        ++pass;
        i = start;
        continue;
      }
      // The repeat is done, or the last ending is played: the next section starts here.
      if (times > 0 || ending_ends) pass = 1, start = i + 1;
      ++i;
    }
    return out;
  }

  // Called by parse for each part.
  void read_part(pugi::xml_node part, uint16_t track) {
    const std::string id = part.attribute("id").value();
    const PartInfo info = parts_.count(id) ? parts_[id] : PartInfo{};
    track_names_.push_back(info.name);
    const std::string part_where = "part '" + id + "'";
    std::vector<pugi::xml_node> measures;
    for (pugi::xml_node m : part.children("measure")) measures.push_back(m);
    // A part that names no channel: its own, in order, past the drum channel.
    const int own = track < kGmDrumChannel ? track : std::min(track + 1, 15);
    const uint8_t channel = static_cast<uint8_t>(info.channel >= 0 ? info.channel : own);
    double divisions = 0, measure_start = 0;
    int transpose = 0;
    // Sounding notes tied on: key -> index in notes_.
    std::map<int, size_t> tied;
    for (pugi::xml_node m : playing_order(measures, part_where)) {
      const std::string where = part_where + " measure " + std::string(m.attribute("number").value());
      double cursor = 0, longest = 0, last_on = 0;  // divisions from the measure's start
      for (pugi::xml_node e : m.children()) {
        const std::string tag = e.name();
        if (tag == "attributes") {
          if (e.child("divisions")) {
            divisions = e.child("divisions").text().as_double(0);
            if (!(divisions > 0 && divisions <= kMaxDivisions)) fail(where, "<divisions> must be above 0 (and at most 1e7)");
          }
          if (const pugi::xml_node t = e.child("transpose")) {
            const int chromatic = t.child("chromatic").text().as_int(0), octaves = t.child("octave-change").text().as_int(0);
            if (chromatic < -48 || chromatic > 48 || octaves < -4 || octaves > 4)
              fail(where, "<transpose> beyond 4 octaves either way");
            transpose = chromatic + 12 * octaves;
          }
        } else if (tag == "direction" || tag == "sound") {
          const pugi::xml_node sound = tag == "sound" ? e : e.child("sound");
          double bpm = sound.attribute("tempo").as_double(0);
          if (bpm <= 0) {
            const pugi::xml_node mm = e.child("direction-type").child("metronome");
            const double per_minute = mm.child("per-minute").text().as_double(0);
            const std::string unit = mm.child_value("beat-unit");
            const double quarters = unit == "half" ? 2 : unit == "eighth" ? 0.5 : unit == "whole" ? 4 : 1;
            bpm = per_minute * quarters * (mm.child("beat-unit-dot") ? 1.5 : 1);
          }
          if (bpm > 0 && bpm < 10000 && tempos_.size() < kMaxNotes)
            tempos_.push_back({measure_start + (divisions > 0 ? cursor / divisions : 0), bpm});
        } else if (tag == "backup" || tag == "forward") {
          if (!(divisions > 0)) fail(where, "<" + tag + "> before <divisions>");
          const double d = e.child("duration").text().as_double(-1);
          if (!(d >= 0 && d / divisions <= kMaxQuarters))
            fail(where, "<" + tag + "> without a <duration> of 0 to 10000 quarter notes");
          cursor += tag == "forward" ? d : -d;
          if (cursor < 0) fail(where, "<backup> goes back before the measure's start");
          longest = std::max(longest, cursor);
        } else if (tag == "note") {
          if (e.child("grace")) continue;  // no time of its own
          if (!(divisions > 0)) fail(where, "a note before <divisions>");
          const double d = e.child("duration").text().as_double(-1);
          if (!(d >= 0 && d / divisions <= kMaxQuarters))
            fail(where, "a note without a <duration> of 0 to 10000 quarter notes");
          const bool chord = static_cast<bool>(e.child("chord"));
          const double on = chord ? last_on : cursor;
          if (!chord) last_on = cursor, cursor += d;
          longest = std::max(longest, on + d);
          if (e.child("rest") || e.child("cue") || d == 0) continue;  // a cue note takes its time, silent
          if (notes_.size() >= kMaxNotes) fail(where, "more than 1000000 notes once repeats are played out");
          bool percussion = info.percussion;
          int key = 0;
          if (const pugi::xml_node p = e.child("pitch")) {
            const std::string step = p.child_value("step");
            const auto semi = semitone_of(step);
            if (!semi || step.size() != 1) fail(where, "pitch step '" + step + "': expected A to G");
            const int octave = p.child("octave").text().as_int(-10);
            const double alter = p.child("alter").text().as_double(0);
            if (octave < -1 || octave > 9) fail(where, "pitch octave: expected 0 to 9");
            if (!(alter >= -3 && alter <= 3)) fail(where, "pitch alter: expected -3 to 3 semitones");
            key = 12 * (octave + 1) + *semi + static_cast<int>(std::lround(alter)) + transpose;
          } else if (const pugi::xml_node u = e.child("unpitched")) {
            percussion = true;
            const std::string inst = e.child("instrument").attribute("id").value();
            if (info.unpitched.count(inst)) {
              key = info.unpitched.at(inst);
            } else {
              const auto semi = semitone_of(u.child_value("display-step"));
              const int octave = std::clamp(u.child("display-octave").text().as_int(4), -1, 9);
              key = 12 * (octave + 1) + semi.value_or(0);
            }
          } else {
            fail(where, "a note with neither <pitch>, <unpitched> nor <rest>");
          }
          if (key < 0 || key > 127) fail(where, "note " + std::to_string(key) + " is outside MIDI 0-127");
          const double on_beat = measure_start + on / divisions, length = d / divisions;
          bool tie_stop = false, tie_start = false;
          for (pugi::xml_node t : e.children("tie")) {
            tie_stop |= std::strcmp(t.attribute("type").value(), "stop") == 0;
            tie_start |= std::strcmp(t.attribute("type").value(), "start") == 0;
          }
          auto open = tied.find(key);
          if (tie_stop && open != tied.end()) {
            BeatNote &n = notes_[open->second];
            n.length = on_beat + length - n.on;
            if (!tie_start) tied.erase(open);
            continue;
          }
          const double dynamics = e.attribute("dynamics").as_double(-1);
          const uint8_t velocity =
              dynamics >= 0 ? static_cast<uint8_t>(std::clamp(dynamics * 0.9, 1.0, 127.0)) : kDefaultVelocity;
          if (tie_start) tied[key] = notes_.size();
          notes_.push_back({on_beat, length, key, velocity, track, percussion ? kGmDrumChannel : channel, percussion});
        }
      }
      if (divisions > 0) measure_start += longest / divisions;
    }
    end_beat_ = std::max(end_beat_, measure_start);
  }

  // Seconds of each beat position through the tempo map. Called by parse.
  Song build(uint16_t tracks) {
    std::stable_sort(tempos_.begin(), tempos_.end(), [](const Tempo &a, const Tempo &b) { return a.beat < b.beat; });
    std::vector<Tempo> map{{0, kDefaultBpm}};
    for (const Tempo &t : tempos_) {
      if (t.beat == map.back().beat) map.back() = t;
      else map.push_back(t);
    }
    std::vector<double> at_s{0};
    for (size_t i = 1; i < map.size(); ++i) at_s.push_back(at_s[i - 1] + (map[i].beat - map[i - 1].beat) * 60 / map[i - 1].bpm);
    auto seconds = [&](double beat) {
      auto it = std::upper_bound(map.begin(), map.end(), beat, [](double b, const Tempo &t) { return b < t.beat; });
      const size_t i = static_cast<size_t>(it - map.begin()) - 1;
      return at_s[i] + (beat - map[i].beat) * 60 / map[i].bpm;
    };
    Song song;
    song.track_count = tracks;
    song.track_names = track_names_;
    for (const BeatNote &b : notes_) {
      SongNote n;
      n.onset_s = seconds(b.on);
      n.duration_s = seconds(b.on + b.length) - n.onset_s;
      if (!(n.duration_s > 0)) continue;
      n.midi_note = static_cast<uint8_t>(b.key);
      n.velocity = b.velocity;
      n.track = b.track;
      n.channel = b.channel;
      n.percussion = b.percussion;
      song.notes.push_back(n);
    }
    if (song.notes.empty()) throw SongError(name_ + ": no notes in any part");
    for (size_t i = 0; i < map.size(); ++i) song.tempo.push_back({at_s[i], map[i].beat, 60 / map[i].bpm});
    finish_song(song, seconds(end_beat_));
    return song;
  }
};

// The score inside a compressed MusicXML (.mxl): the rootfile META-INF/container.xml names.
std::string unzip_score(const uint8_t *data, size_t size, const std::string &name) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t *src = zip_source_buffer_create(data, size, 0, &error);
  if (!src) throw SongError(name + ": cannot read the .mxl container: " + zip_error_strerror(&error));
  zip_t *za = zip_open_from_source(src, ZIP_RDONLY, &error);
  if (!za) {
    zip_source_free(src);
    const std::string why = zip_error_strerror(&error);
    zip_error_fini(&error);
    throw SongError(name + ": not a valid .mxl (zip) file: " + why);
  }
  std::unique_ptr<zip_t, int (*)(zip_t *)> archive(za, zip_close);
  auto read_entry = [&](const std::string &entry) {
    zip_stat_t st;
    if (zip_stat(za, entry.c_str(), 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
      throw SongError(name + ": the .mxl has no '" + entry + "'");
    if (st.size > kMaxSongFileBytes) throw SongError(name + ": '" + entry + "' is larger than a song file may be");
    std::string out(st.size, '\0');
    zip_file_t *f = zip_fopen(za, entry.c_str(), 0);
    if (!f) throw SongError(name + ": cannot open '" + entry + "' in the .mxl");
    const zip_int64_t got = zip_fread(f, out.data(), st.size);
    zip_fclose(f);
    if (got < 0 || static_cast<zip_uint64_t>(got) != st.size) throw SongError(name + ": '" + entry + "' is cut short");
    return out;
  };
  const std::string container = read_entry("META-INF/container.xml");
  pugi::xml_document doc;
  if (!doc.load_buffer(container.data(), container.size()))
    throw SongError(name + ": META-INF/container.xml is not well-formed XML");
  const std::string root = doc.child("container").child("rootfiles").child("rootfile").attribute("full-path").value();
  if (root.empty()) throw SongError(name + ": META-INF/container.xml names no rootfile");
  return read_entry(root);
}

}  // namespace

Song read_musicxml(const uint8_t *data, size_t size, const std::string &name) {
  if (size > kMaxSongFileBytes) throw SongError(name + ": larger than a song file may be");
  MusicXmlParser parser(name);
  if (size >= 4 && std::memcmp(data, "PK\x03\x04", 4) == 0) {
    const std::string xml = unzip_score(data, size, name);
    return parser.parse(xml.data(), xml.size());
  }
  return parser.parse(reinterpret_cast<const char *>(data), size);
}

}  // namespace stepchoir
