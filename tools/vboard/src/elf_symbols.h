// elf_symbols.h: flash (code) symbols of an AVR ELF, ISR ranges, and PC-to-name lookup (libelf).
#ifndef STEPCHOIR_VBOARD_ELF_SYMBOLS_H
#define STEPCHOIR_VBOARD_ELF_SYMBOLS_H

#include <cstdint>
#include <string>
#include <vector>

#include "cpu_profiler.h"

namespace vboard {

// One symbol in flash (byte addresses).
struct CodeSymbol {
  uint32_t address_bytes;
  uint32_t size_bytes;  // 0 when the ELF gives none
  std::string name;
};

// Code symbols of an ELF, sorted by address.
class CodeSymbols {
 public:
  // Reads the symbol table of path; on failure fills error and returns false.
  bool load(const std::string &path, std::string &error);
  // All symbols, by address.
  const std::vector<CodeSymbol> &symbols() const { return symbols_; }
  // Code ranges of the __vector_N functions the program defines (aliases of __bad_interrupt
  // are skipped). A symbol without a size extends to the next symbol.
  std::vector<IsrRange> isr_ranges() const;
  // "name+0xoff" for the symbol holding pc_bytes, or "0x...." when none does.
  std::string describe(uint32_t pc_bytes) const;

 private:
  // End (exclusive) of symbol index i: its size, or the next symbol's address.
  uint32_t end_of(size_t i) const;

  std::vector<CodeSymbol> symbols_;
};

// Parses "__vector_N"; returns -1 for other names.
int vector_number_of(const std::string &name);

}  // namespace vboard

#endif  // STEPCHOIR_VBOARD_ELF_SYMBOLS_H
