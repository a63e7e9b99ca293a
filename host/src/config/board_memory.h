// board_memory.h: what the host remembers of each board it has met, by the board's id
// (kMsgId, kept in the board's EEPROM): its crystal's error as the last song's clock fit
// measured it, so the next song on that board is in tune from its first note
// (ClockSync::set_prior). One TOML file in the user's cache:
// $XDG_CACHE_HOME/stepchoir/boards.toml, or ~/.cache/stepchoir/boards.toml.
//
//   [boards.0123456789abcdef]
//   name = "uno_cnc_shield_v3"
//   clock_ppm = 2493.7
//   sigma_ppm = 6.1
//
// Called from: the live, play, render and jam commands and `hello`, off every real-time path.
#ifndef STEPCHOIR_HOST_CONFIG_BOARD_MEMORY_H
#define STEPCHOIR_HOST_CONFIG_BOARD_MEMORY_H

#include <cstdint>
#include <optional>
#include <string>

#include "board/board.h"

namespace stepchoir {

struct BoardRecord {
  std::string name;      // the board's name from its capabilities
  double clock_ppm = 0;  // its crystal's error, ppm (+: fast)
  double sigma_ppm = 0;  // the fit's standard error of it, ppm
};

// The file (see the top); "" when neither XDG_CACHE_HOME nor HOME is set.
std::string board_memory_path();

// An id as 16 hex digits, as `hello` prints it.
std::string board_id_hex(uint64_t id);

// The record of board id in the file at path; nullopt when there is none (or no file).
// Throws std::runtime_error "PATH:LINE:COLUMN: ..." for a file that is not TOML, or whose
// entry for this id lacks a number.
std::optional<BoardRecord> recall_board(uint64_t id, const std::string &path = board_memory_path());

// Writes (or replaces) the record of board id, keeping the others; creates the directory.
// Throws std::runtime_error naming the file when it cannot.
void remember_board(uint64_t id, const BoardRecord &record, const std::string &path = board_memory_path());

// The board's clock as a listener hears it (Hz): F_CPU, or for a board met before F_CPU as its
// remembered crystal runs, rounded to the hertz (0.06 ppm). The keyboard's periods come from it,
// so its notes are in tune on a board whose crystal is off. Called from: live, jam.
// A remembered error beyond kMaxCrystalPpm (a hand-edited file) is left aside: F_CPU.
constexpr double kMaxCrystalPpm = 20000;
uint32_t crystal_hz(uint32_t f_cpu_hz, const std::optional<BoardRecord> &known);

// The board's id; a board without one (id 0: a new board) is given a random one first.
// nullopt when its firmware keeps no id (it does not answer). Called after hello or greet.
std::optional<uint64_t> identify_board(Board &board);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CONFIG_BOARD_MEMORY_H
