// song.cpp: song file loading (format by content), the readers' common last step, word splitting.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <optional>
#include <tuple>

#include "song/song.h"

namespace stepchoir {

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

std::optional<int> semitone_of(std::string_view name) {
  static constexpr int kNatural[7] = {9, 11, 0, 2, 4, 5, 7};  // A B C D E F G
  if (name.empty() || name.size() > 2 || name[0] < 'A' || name[0] > 'G') return std::nullopt;
  int s = kNatural[name[0] - 'A'];
  if (name.size() == 2) {
    if (name[1] == '#') ++s;
    else if (name[1] == 'b') --s;
    else return std::nullopt;
  }
  return s;
}

std::vector<int> parse_tuning(std::string_view text) {
  std::vector<int> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find(',', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view item = text.substr(start, end - start);
    size_t digits = 0;
    while (digits < item.size() && !(item[digits] >= '0' && item[digits] <= '9')) ++digits;
    const auto semi = semitone_of(item.substr(0, digits));
    int octave = 0;
    bool ok = semi && digits + 1 == item.size();
    if (ok) octave = item[digits] - '0';
    if (!ok)
      throw SongError("tuning '" + std::string(text) + "': '" + std::string(item) +
                      "' is not a note such as E2 or F#3 (a name A-G, # or b, an octave 0-9)");
    const int key = 12 * (octave + 1) + *semi;
    if (key < 0 || key > 127) throw SongError("tuning '" + std::string(text) + "': '" + std::string(item) + "' is beyond MIDI 0-127");
    out.push_back(key);
    start = end + 1;
  }
  if (out.size() != 6) throw SongError("tuning '" + std::string(text) + "': 6 strings, low to high, e.g. E2,A2,D3,G3,B3,E4");
  return out;
}

void finish_song(Song &song, double end_s) {
  std::sort(song.notes.begin(), song.notes.end(), [](const SongNote &a, const SongNote &b) {
    return std::tie(a.onset_s, a.track, a.channel, a.midi_note) < std::tie(b.onset_s, b.track, b.channel, b.midi_note);
  });
  song.duration_s = end_s;
  song.track_names.resize(song.track_count);
  for (const auto &n : song.notes) song.duration_s = std::max(song.duration_s, n.onset_s + n.duration_s);
}

double song_beat(const Song &song, double s) {
  if (song.tempo.empty()) return s / 0.5;
  auto it = std::upper_bound(song.tempo.begin(), song.tempo.end(), s,
                             [](double x, const TempoPoint &p) { return x < p.time_s; });
  const TempoPoint &p = it == song.tempo.begin() ? *it : *std::prev(it);
  return p.beat + (s - p.time_s) / p.s_per_beat;
}

double song_seconds(const Song &song, double beat) {
  if (song.tempo.empty()) return beat * 0.5;
  auto it = std::upper_bound(song.tempo.begin(), song.tempo.end(), beat,
                             [](double b, const TempoPoint &p) { return b < p.beat; });
  const TempoPoint &p = it == song.tempo.begin() ? *it : *std::prev(it);
  return p.time_s + (beat - p.beat) * p.s_per_beat;
}

Song read_song_file(const std::string &path, const TabOptions &tab) {
  std::FILE *f = std::fopen(path.c_str(), "rb");
  if (!f) throw SongError(path + ": cannot open: " + std::strerror(errno));
  std::vector<uint8_t> bytes;
  uint8_t buf[65536];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) {
    if (bytes.size() + n > kMaxSongFileBytes) {
      std::fclose(f);
      throw SongError(path + ": larger than " + std::to_string(kMaxSongFileBytes >> 20) + " MiB; not a song file");
    }
    bytes.insert(bytes.end(), buf, buf + n);
  }
  const int read_errno = std::ferror(f) ? errno : 0;
  std::fclose(f);
  if (read_errno) throw SongError(path + ": cannot read: " + std::strerror(read_errno));
  if (bytes.size() >= 4 && std::memcmp(bytes.data(), "MThd", 4) == 0) return read_midi(bytes.data(), bytes.size(), path);
  const auto dot = path.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  if (ext == ".sng" || ext == ".SNG")
    return read_sng(std::string_view(reinterpret_cast<const char *>(bytes.data()), bytes.size()), path);
  if (ext == ".musicxml" || ext == ".xml" || ext == ".mxl" || ext == ".MXL")
    return read_musicxml(bytes.data(), bytes.size(), path);
  if (ext == ".tab" || ext == ".TAB")
    return read_tab(std::string_view(reinterpret_cast<const char *>(bytes.data()), bytes.size()), path, tab);
  if (ext == ".mid" || ext == ".midi" || ext == ".MID")
    throw SongError(path + ": byte 0: expected a MIDI file starting with 'MThd'");
  throw SongError(path + ": unknown song format: expected a Standard MIDI File (starts with 'MThd'), a .sng, .tab, .musicxml or .mxl file");
}

}  // namespace stepchoir
