// board_memory.cpp: the boards the host has met (see board_memory.h).
#include "config/board_memory.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <toml++/toml.h>

#include "config/rig.h"

namespace stepchoir {

namespace {

constexpr int kIdTimeoutMs = 500;      // an id reply crosses any bridge in far less
constexpr int kSetIdTimeoutMs = 1000;  // 8 EEPROM bytes take 26.4 ms on the board

// Loads the file's table; an empty table when there is no file.
toml::table load_table(const std::string &path) {
  struct stat st {};
  if (path.empty() || ::stat(path.c_str(), &st) != 0) return {};
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error &e) {
    std::ostringstream m;
    m << path << ":" << e.source().begin.line << ":" << e.source().begin.column << ": " << e.description();
    throw std::runtime_error(m.str());
  }
}

// mkdir -p of path's directory.
void make_parent(const std::string &path) {
  for (size_t at = path.find('/', 1); at != std::string::npos; at = path.find('/', at + 1)) {
    const std::string dir = path.substr(0, at);
    if (::mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST)
      throw std::runtime_error(dir + ": cannot create: " + std::strerror(errno));
  }
}

}  // namespace

std::string board_memory_path() { return xdg_file("XDG_CACHE_HOME", ".cache", "boards.toml"); }

std::string board_id_hex(uint64_t id) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(id));
  return hex;
}

std::optional<BoardRecord> recall_board(uint64_t id, const std::string &path) {
  const toml::table t = load_table(path);
  const toml::node_view<const toml::node> entry = t["boards"][board_id_hex(id)];
  if (!entry) return std::nullopt;
  BoardRecord r;
  const std::optional<double> ppm = entry["clock_ppm"].value<double>();
  const std::optional<double> sigma = entry["sigma_ppm"].value<double>();
  if (!ppm || !sigma || !(*sigma >= 0)) {
    const toml::source_region &at = entry.node()->source();
    std::ostringstream m;
    m << path << ":" << at.begin.line << ":" << at.begin.column << ": board " << board_id_hex(id)
      << ": expected clock_ppm and sigma_ppm (numbers, sigma_ppm >= 0)";
    throw std::runtime_error(m.str());
  }
  r.clock_ppm = *ppm;
  r.sigma_ppm = *sigma;
  r.name = entry["name"].value_or(std::string());
  return r;
}

void remember_board(uint64_t id, const BoardRecord &record, const std::string &path) {
  if (path.empty()) throw std::runtime_error("no place for the board memory: neither XDG_CACHE_HOME nor HOME is set");
  toml::table t = load_table(path);
  if (!t["boards"].is_table()) t.insert_or_assign("boards", toml::table{});
  toml::table entry;
  entry.insert("name", record.name);
  entry.insert("clock_ppm", record.clock_ppm);
  entry.insert("sigma_ppm", record.sigma_ppm);
  t["boards"].as_table()->insert_or_assign(board_id_hex(id), std::move(entry));
  make_parent(path);
  // Written whole to a new file, then renamed: a crash leaves the old file or the new one.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "# Boards stepchoir has met: each one's crystal error as its last song measured it.\n" << t << "\n";
    if (!out) throw std::runtime_error(tmp + ": cannot write");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    ::unlink(tmp.c_str());
    throw std::runtime_error(path + ": cannot write: " + std::strerror(errno));
  }
}

uint32_t crystal_hz(uint32_t f_cpu_hz, const std::optional<BoardRecord> &known) {
  if (!known || !std::isfinite(known->clock_ppm) || std::fabs(known->clock_ppm) > kMaxCrystalPpm) return f_cpu_hz;
  return static_cast<uint32_t>(std::llround(f_cpu_hz * (1.0 + known->clock_ppm / 1e6)));
}

std::optional<uint64_t> identify_board(Board &board) {
  board.send({sc::kMsgIdReq});
  std::optional<std::vector<uint8_t>> reply = board.wait_reply(sc::kMsgId, kIdTimeoutMs);
  if (!reply || reply->size() != 1 + sc::kBoardIdBytes) return std::nullopt;
  uint64_t id = sc::get_board_id(reply->data() + 1);
  if (id != 0) return id;
  std::random_device rd;
  while (id == 0 || id == ~0ull) id = (static_cast<uint64_t>(rd()) << 32) ^ rd();
  std::vector<uint8_t> set(1 + sc::kBoardIdBytes, sc::kMsgSetId);
  sc::put_board_id(set.data() + 1, id);
  board.send(set);
  reply = board.wait_reply(sc::kMsgId, kSetIdTimeoutMs);
  if (!reply || reply->size() != 1 + sc::kBoardIdBytes || sc::get_board_id(reply->data() + 1) != id) return std::nullopt;
  return id;
}

}  // namespace stepchoir
