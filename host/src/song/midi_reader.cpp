// midi_reader.cpp: Standard MIDI Files (format 0 and 1) -> Song: tempo map, running status,
// PPQ and SMPTE division; strict, errors with the byte offset and chunk; memory bounded by
// the file's size.
#include <algorithm>
#include <cstring>

#include "song/song.h"

namespace stepchoir {

namespace {

constexpr uint32_t kDefaultTempoUsPerQn = 500000;  // 120 bpm until the first Set Tempo
constexpr uint8_t kMetaEndOfTrack = 0x2F;
constexpr uint8_t kMetaSetTempo = 0x51;
constexpr uint8_t kMetaTrackName = 0x03;       // Sequence/Track Name
constexpr uint8_t kMetaInstrumentName = 0x04;
constexpr size_t kMaxTrackNameChars = 64;      // longer names are cut

// A tempo change at a tick, from any track.
struct TempoChange {
  uint64_t tick;
  uint32_t us_per_qn;
};

// A bank select (CC0) or program change on a channel: which of a channel's notes are drum hits
// follows from these, replayed in time order across tracks.
struct BankEvent {
  uint64_t tick;
  uint8_t channel;
  int16_t bank;       // CC0 value, or -1 for a program change
};

// A note with its ends in ticks, before the tempo map turns them into seconds.
struct TickNote {
  uint64_t start_tick, end_tick;
  uint8_t note, velocity, channel;
  uint16_t track;
};

// Reads one file. Used only by read_midi.
class MidiParser {
 public:
  // Called by read_midi.
  MidiParser(const uint8_t *d, size_t n, const std::string &name) : d_(d), n_(n), name_(name) {}

  // Parses the whole file into song. Called by read_midi.
  Song parse() {
    header();
    uint16_t tracks_read = 0;
    uint32_t chunk_index = 1;
    while (pos_ < n_) {
      chunk_start_ = pos_;
      chunk_index_ = chunk_index++;
      chunk_type_.clear();
      if (n_ - pos_ < 8) fail("truncated chunk header (" + std::to_string(n_ - pos_) + " bytes left, 8 needed)");
      char type[5] = {0};
      std::memcpy(type, d_ + pos_, 4);
      chunk_type_ = type;
      for (char &c : chunk_type_)
        if (c < 0x20 || c > 0x7E) c = '?';
      const uint32_t len = u32(pos_ + 4);
      pos_ += 8;
      if (len > n_ - pos_)
        fail("chunk length " + std::to_string(len) + " runs past the end of the file (" + std::to_string(n_ - pos_) +
             " bytes left)");
      if (std::memcmp(type, "MTrk", 4) == 0) {
        track_ = tracks_read;
        names_.emplace_back();
        instruments_.emplace_back();
        if (tracks_read++ == declared_tracks_)
          fail("more MTrk chunks than the " + std::to_string(declared_tracks_) + " the header declares");
        track(pos_ + len);  // leaves pos_ at the chunk's end
      } else {
        ++skipped_chunks_;
        pos_ += len;
      }
    }
    chunk_index_ = 0;
    if (tracks_read != declared_tracks_)
      fail_at(n_, "the header declares " + std::to_string(declared_tracks_) + " tracks but the file has " +
                      std::to_string(tracks_read));
    return build();
  }

 private:
  const uint8_t *d_;
  size_t n_;
  const std::string &name_;
  size_t pos_ = 0;
  size_t chunk_start_ = 0;
  uint32_t chunk_index_ = 0;  // 1-based index of the chunk being read; 0 outside chunks
  std::string chunk_type_;    // its type, printable; empty until its header is read
  uint16_t track_ = 0;
  uint16_t declared_tracks_ = 0;
  uint16_t ppq_ = 0;              // ticks per quarter note, 0 with SMPTE division
  double smpte_s_per_tick_ = 0;   // seconds per tick with SMPTE division
  std::vector<TempoChange> tempos_;
  std::vector<TickNote> notes_;
  std::vector<BankEvent> banks_;
  std::vector<std::string> names_, instruments_;  // per track read so far
  uint64_t end_tick_ = 0;          // latest End of Track
  size_t unmatched_offs_ = 0, unterminated_ = 0, skipped_chunks_ = 0, zero_length_ = 0;
  std::vector<uint32_t> open_[16 * 128];  // per channel and note: indexes into notes_ of sounding notes
  size_t open_head_[16 * 128] = {};       // first still-sounding entry of each open_ list (FIFO)
  std::vector<uint16_t> used_keys_;       // keys with an open_ list this track

  // Throws a SongError at byte offset at. Called by every check.
  [[noreturn]] void fail_at(size_t at, const std::string &what) const {
    std::string where = name_ + ": byte " + std::to_string(at);
    if (chunk_index_ > 0)
      where += " (chunk " + std::to_string(chunk_index_) + (chunk_type_.empty() ? "" : " '" + chunk_type_ + "'") +
               " at byte " + std::to_string(chunk_start_) +
               (chunk_type_ == "MTrk" ? ", track " + std::to_string(track_) : "") + ")";
    throw SongError(where + ": " + what);
  }
  // Throws at the current position. Called by every check.
  [[noreturn]] void fail(const std::string &what) const { fail_at(pos_, what); }

  // Big-endian 32-bit read at an offset the caller has bounds-checked. Called by header and parse.
  uint32_t u32(size_t at) const {
    return uint32_t{d_[at]} << 24 | uint32_t{d_[at + 1]} << 16 | uint32_t{d_[at + 2]} << 8 | d_[at + 3];
  }
  // Big-endian 16-bit read at an offset the caller has bounds-checked. Called by header.
  uint16_t u16(size_t at) const { return static_cast<uint16_t>(d_[at] << 8 | d_[at + 1]); }

  // Parses MThd. Called by parse.
  void header() {
    if (n_ < 14 || std::memcmp(d_, "MThd", 4) != 0) fail("expected a MIDI file: 'MThd' and a 6-byte header");
    const uint32_t len = u32(4);
    pos_ = 4;
    if (len < 6) fail("header length " + std::to_string(len) + ", expected 6");
    if (len > n_ - 8) fail("header length " + std::to_string(len) + " runs past the end of the file");
    const uint16_t format = u16(8);
    declared_tracks_ = u16(10);
    const uint16_t division = u16(12);
    pos_ = 8;
    if (format == 2) fail("format 2 (independent sequences) is not supported; use format 0 or 1");
    if (format > 2) fail("unknown format " + std::to_string(format) + ", expected 0 or 1");
    pos_ = 10;
    if (declared_tracks_ == 0) fail("the header declares no tracks");
    if (format == 0 && declared_tracks_ != 1)
      fail("format 0 has one track, the header declares " + std::to_string(declared_tracks_));
    pos_ = 12;
    if (division & 0x8000) {
      const int fps = -static_cast<int8_t>(division >> 8);
      const int ticks_per_frame = division & 0xFF;
      if (fps != 24 && fps != 25 && fps != 29 && fps != 30)
        fail("SMPTE division with " + std::to_string(fps) + " frames per second, expected 24, 25, 29 or 30");
      if (ticks_per_frame == 0) fail("SMPTE division with 0 ticks per frame");
      smpte_s_per_tick_ = 1.0 / ((fps == 29 ? 30000.0 / 1001.0 : fps) * ticks_per_frame);
    } else {
      if (division == 0) fail("division of 0 ticks per quarter note");
      ppq_ = division;
    }
    pos_ = 8 + len;
  }

  // Reads a variable-length quantity (at most 4 bytes) before end. Called by track.
  uint32_t vlq(size_t end) {
    const size_t start = pos_;
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) {
      if (pos_ >= end) fail_at(start, "variable-length number runs past the end of the track");
      const uint8_t b = d_[pos_++];
      v = v << 7 | (b & 0x7F);
      if (!(b & 0x80)) return v;
    }
    fail_at(start, "variable-length number longer than 4 bytes");
  }

  // Reads one data byte (0-127) before end. Called by track for channel messages.
  uint8_t data_byte(size_t end) {
    if (pos_ >= end) fail("channel message cut off by the end of the track");
    if (d_[pos_] & 0x80) fail("expected a data byte (0-127), got status byte " + hex(d_[pos_]));
    return d_[pos_++];
  }

  // A name from a meta event: printable ASCII, spaces trimmed, at most kMaxTrackNameChars.
  // Called by track.
  static std::string printable(const uint8_t *p, size_t len) {
    std::string out;
    for (size_t i = 0; i < len && out.size() < kMaxTrackNameChars; ++i)
      if (p[i] >= 0x20 && p[i] < 0x7F) out += static_cast<char>(p[i]);
    while (!out.empty() && out.back() == ' ') out.pop_back();
    return out.substr(std::min(out.size(), out.find_first_not_of(' ')));
  }

  // Formats a byte as 0xNN. Called by messages.
  static std::string hex(uint8_t b) {
    static const char *digits = "0123456789ABCDEF";
    return std::string("0x") + digits[b >> 4] + digits[b & 15];
  }

  // Parses the events of one MTrk chunk ending at end. Called by parse.
  void track(size_t end) {
    uint64_t tick = 0;
    uint8_t running = 0;
    for (;;) {
      if (pos_ >= end) fail("track ends without an End of Track event");
      tick += vlq(end);
      if (pos_ >= end) fail("event cut off after its delta time");
      const size_t event_at = pos_;
      uint8_t status = d_[pos_];
      if (status & 0x80) {
        ++pos_;
      } else {
        if (!running) fail("data byte " + hex(status) + " without a running status");
        status = running;
      }
      if (status < 0xF0) {
        running = status;
        const uint8_t type = status & 0xF0, channel = status & 0x0F;
        const uint8_t a = data_byte(end);
        if (type == kMidiProgramChange) banks_.push_back({tick, channel, -1});
        if (type == kMidiProgramChange || type == 0xD0) continue;
        const uint8_t b = data_byte(end);
        if (type == kMidiControlChange && a == kCcBankSelectMsb)
          banks_.push_back({tick, channel, b});
        if (type == 0x90 && b > 0) note_on(tick, channel, a, b);
        else if (type == 0x80 || type == 0x90) note_off(tick, channel, a);
      } else if (status == 0xFF) {
        running = 0;
        if (pos_ >= end) fail("meta event cut off after 0xFF");
        const uint8_t meta = d_[pos_++];
        const uint32_t len = vlq(end);
        if (len > end - pos_) fail("meta event length " + std::to_string(len) + " runs past the end of the track");
        if (meta == kMetaSetTempo) {
          if (len != 3) fail_at(event_at, "Set Tempo with length " + std::to_string(len) + ", expected 3");
          const uint32_t us = uint32_t{d_[pos_]} << 16 | uint32_t{d_[pos_ + 1]} << 8 | d_[pos_ + 2];
          if (us == 0) fail_at(event_at, "Set Tempo of 0 microseconds per quarter note");
          tempos_.push_back({tick, us});
        }
        if (meta == kMetaTrackName || meta == kMetaInstrumentName) {
          std::string &name = meta == kMetaTrackName ? names_.back() : instruments_.back();
          if (name.empty()) name = printable(d_ + pos_, len);
        }
        pos_ += len;
        if (meta == kMetaEndOfTrack) {
          if (len != 0) fail_at(event_at, "End of Track with length " + std::to_string(len) + ", expected 0");
          if (pos_ != end)
            fail(std::to_string(end - pos_) + " bytes after End of Track (the chunk length says the track is longer)");
          end_track(tick);
          return;
        }
      } else if (status == 0xF0 || status == 0xF7) {
        running = 0;
        const uint32_t len = vlq(end);
        if (len > end - pos_) fail("sysex length " + std::to_string(len) + " runs past the end of the track");
        pos_ += len;
      } else {
        fail_at(event_at, "status byte " + hex(status) + " is not allowed in a MIDI file");
      }
    }
  }

  // A note starts. Called by track.
  void note_on(uint64_t tick, uint8_t channel, uint8_t note, uint8_t velocity) {
    const uint16_t key = static_cast<uint16_t>(channel * 128 + note);
    if (open_[key].empty()) used_keys_.push_back(key);
    open_[key].push_back(static_cast<uint32_t>(notes_.size()));
    notes_.push_back({tick, UINT64_MAX, note, velocity, channel, track_});
  }

  // A note ends: the oldest sounding one of that channel and pitch (overlapping same-pitch notes
  // end first in, first out). Called by track.
  void note_off(uint64_t tick, uint8_t channel, uint8_t note) {
    auto &q = open_[channel * 128 + note];
    size_t &head = open_head_[channel * 128 + note];
    if (head == q.size()) {
      ++unmatched_offs_;
      return;
    }
    notes_[q[head++]].end_tick = tick;
  }

  // End of Track: notes still sounding end here. Called by track.
  void end_track(uint64_t tick) {
    for (const uint16_t k : used_keys_) {
      for (size_t i = open_head_[k]; i < open_[k].size(); ++i) {
        notes_[open_[k][i]].end_tick = tick;
        ++unterminated_;
      }
      open_[k].clear();
      open_head_[k] = 0;
    }
    used_keys_.clear();
    end_tick_ = std::max(end_tick_, tick);
  }

  // Seconds from the start at a tick, through the tempo map. Called by build.
  struct TempoMap {
    std::vector<TempoChange> changes;  // sorted by tick, first at tick 0
    std::vector<double> start_s;       // time of each change
    double ppq = 0, smpte_s_per_tick = 0;
    // Called by build for each note end.
    double seconds(uint64_t tick) const {
      if (smpte_s_per_tick > 0) return tick * smpte_s_per_tick;
      auto it = std::upper_bound(changes.begin(), changes.end(), tick,
                                 [](uint64_t t, const TempoChange &c) { return t < c.tick; });
      const size_t i = static_cast<size_t>(it - changes.begin()) - 1;
      return start_s[i] + (tick - changes[i].tick) * (changes[i].us_per_qn * 1e-6 / ppq);
    }
  };

  // Applies the tempo map and makes the Song. Called by parse.
  Song build() {
    TempoMap map;
    map.ppq = ppq_;
    map.smpte_s_per_tick = smpte_s_per_tick_;
    // Stable: of two changes at one tick, the later in the file wins.
    std::stable_sort(tempos_.begin(), tempos_.end(), [](const TempoChange &a, const TempoChange &b) {
      return a.tick < b.tick;
    });
    map.changes.push_back({0, kDefaultTempoUsPerQn});
    for (const auto &t : tempos_) {
      if (t.tick == map.changes.back().tick) map.changes.back() = t;
      else map.changes.push_back(t);
    }
    map.start_s.push_back(0);
    for (size_t i = 1; i < map.changes.size(); ++i)
      map.start_s.push_back(map.start_s[i - 1] + (map.changes[i].tick - map.changes[i - 1].tick) *
                                                     (map.changes[i - 1].us_per_qn * 1e-6 / map.ppq));
    Song song;
    song.track_count = declared_tracks_;
    for (size_t i = 0; i < names_.size(); ++i) song.track_names.push_back(names_[i].empty() ? instruments_[i] : names_[i]);
    // Each channel's drum kit changes, in time order (stable: file order at one tick).
    std::stable_sort(banks_.begin(), banks_.end(), [](const BankEvent &a, const BankEvent &b) { return a.tick < b.tick; });
    std::vector<std::pair<uint64_t, bool>> kits[16];  // per channel: from tick, percussion
    uint8_t bank[16] = {};
    for (const BankEvent &e : banks_) {
      if (e.bank >= 0) bank[e.channel] = static_cast<uint8_t>(e.bank);
      else kits[e.channel].push_back({e.tick, percussion_bank(e.channel, bank[e.channel])});
    }
    auto percussion = [&](uint8_t channel, uint64_t tick) {
      const auto &k = kits[channel];
      auto it = std::upper_bound(k.begin(), k.end(), tick, [](uint64_t t, const std::pair<uint64_t, bool> &c) {
        return t < c.first;
      });
      return it == k.begin() ? channel == kGmDrumChannel : std::prev(it)->second;
    };
    song.notes.reserve(notes_.size());
    for (const auto &t : notes_) {
      if (t.end_tick <= t.start_tick) {
        ++zero_length_;
        continue;
      }
      SongNote n;
      n.onset_s = map.seconds(t.start_tick);
      n.duration_s = map.seconds(t.end_tick) - n.onset_s;
      n.midi_note = t.note;
      n.velocity = t.velocity;
      n.channel = t.channel;
      n.track = t.track;
      n.percussion = percussion(t.channel, t.start_tick);
      song.notes.push_back(n);
    }
    if (song.notes.empty()) throw SongError(name_ + ": no notes in any track");
    auto warn = [&](size_t count, const char *what) {
      if (count) song.warnings.push_back(name_ + ": " + std::to_string(count) + " " + what);
    };
    warn(unterminated_, "notes still sounding at End of Track (ended there)");
    warn(unmatched_offs_, "note-offs without a sounding note (ignored)");
    warn(zero_length_, "notes of zero length (dropped)");
    warn(skipped_chunks_, "chunks of unknown type (skipped)");
    if (map.smpte_s_per_tick == 0)  // (SMPTE time has no beats)
      for (size_t i = 0; i < map.changes.size(); ++i)
        song.tempo.push_back({map.start_s[i], double(map.changes[i].tick) / map.ppq, map.changes[i].us_per_qn * 1e-6});
    finish_song(song, map.seconds(end_tick_));
    return song;
  }
};

}  // namespace

Song read_midi(const uint8_t *data, size_t size, const std::string &name) {
  if (size > kMaxSongFileBytes)
    throw SongError(name + ": larger than " + std::to_string(kMaxSongFileBytes >> 20) + " MiB; not a song file");
  return MidiParser(data, size, name).parse();
}

}  // namespace stepchoir
