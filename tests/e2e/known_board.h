// known_board.h: a board the host has met before, for the end-to-end tests: its id in an EEPROM
// file the virtual board loads (--eeprom), and its crystal's error in the host's memory of boards
// (config/board_memory.h), in a scratch XDG_CACHE_HOME set while this lives (the children read
// it). Such a board syncs in a second, whatever the link, and starts from that crystal.
#ifndef STEPCHOIR_TESTS_E2E_KNOWN_BOARD_H
#define STEPCHOIR_TESTS_E2E_KNOWN_BOARD_H

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "config/board_memory.h"
#include "e2e_util.h"

namespace e2e {

struct KnownBoard {
  std::string eeprom;  // NAME.eeprom in the scratch directory: pass as --eeprom
  KnownBoard(const std::string &name, uint64_t id, double clock_ppm) : eeprom(scratch(name + ".eeprom")) {
    std::string bytes(8, '\0');  // the firmware keeps the id least significant byte first
    for (int i = 0; i < 8; ++i) bytes[size_t(i)] = static_cast<char>(id >> (8 * i));
    std::ofstream(eeprom, std::ios::binary) << bytes;
    const std::string cache = scratch(name + "-cache");
    std::remove((cache + "/stepchoir/boards.toml").c_str());
    stepchoir::remember_board(id, {"", clock_ppm, 5.0}, cache + "/stepchoir/boards.toml");
    ::setenv("XDG_CACHE_HOME", cache.c_str(), 1);
  }
  ~KnownBoard() { ::unsetenv("XDG_CACHE_HOME"); }
  KnownBoard(const KnownBoard &) = delete;
  KnownBoard &operator=(const KnownBoard &) = delete;
};

}  // namespace e2e

#endif  // STEPCHOIR_TESTS_E2E_KNOWN_BOARD_H
