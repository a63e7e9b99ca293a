// song.cpp: song file loading (format by content), the readers' common last step, word splitting.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
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

void finish_song(Song &song, double end_s) {
  std::sort(song.notes.begin(), song.notes.end(), [](const SongNote &a, const SongNote &b) {
    return std::tie(a.onset_s, a.track, a.channel, a.midi_note) < std::tie(b.onset_s, b.track, b.channel, b.midi_note);
  });
  song.duration_s = end_s;
  for (const auto &n : song.notes) song.duration_s = std::max(song.duration_s, n.onset_s + n.duration_s);
}

Song read_song_file(const std::string &path) {
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
  if (ext == ".mid" || ext == ".midi" || ext == ".MID")
    throw SongError(path + ": byte 0: expected a MIDI file starting with 'MThd'");
  throw SongError(path + ": unknown song format: expected a Standard MIDI File (starts with 'MThd') or a .sng file");
}

}  // namespace stepchoir
