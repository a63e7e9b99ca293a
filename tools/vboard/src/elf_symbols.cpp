// elf_symbols.cpp: reads code symbols from an AVR ELF with libelf/gelf.
#include "elf_symbols.h"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace vboard {

namespace {
// avr-gcc links data at 0x800000 and EEPROM at 0x810000; flash is below.
constexpr uint64_t kDataSpaceBytes = 0x800000;
}  // namespace

// Parses "__vector_N"; returns -1 for other names.
int vector_number_of(const std::string &name) {
  static const char kPrefix[] = "__vector_";
  const size_t prefix_len = sizeof(kPrefix) - 1;
  if (name.size() <= prefix_len || name.compare(0, prefix_len, kPrefix) != 0) return -1;
  int number = 0;
  for (size_t i = prefix_len; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9' || number > 1000) return -1;
    number = number * 10 + (name[i] - '0');
  }
  return number;
}

// Reads the symbol table of path.
bool CodeSymbols::load(const std::string &path, std::string &error) {
  symbols_.clear();
  if (elf_version(EV_CURRENT) == EV_NONE) {
    error = "libelf initialisation failed";
    return false;
  }
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) {
    error = "cannot open " + path + ": " + std::strerror(errno);
    return false;
  }
  Elf *elf = elf_begin(fd, ELF_C_READ, nullptr);
  if (!elf) {
    error = "not an ELF file: " + path;
    ::close(fd);
    return false;
  }
  Elf_Scn *section = nullptr;
  while ((section = elf_nextscn(elf, section)) != nullptr) {
    GElf_Shdr header;
    if (!gelf_getshdr(section, &header) || header.sh_type != SHT_SYMTAB) continue;
    Elf_Data *data = elf_getdata(section, nullptr);
    if (!data || header.sh_entsize == 0) continue;
    const size_t count = header.sh_size / header.sh_entsize;
    for (size_t i = 0; i < count; ++i) {
      GElf_Sym sym;
      if (!gelf_getsym(data, static_cast<int>(i), &sym)) continue;
      const int type = GELF_ST_TYPE(sym.st_info);
      if (type != STT_FUNC && type != STT_NOTYPE) continue;
      if (sym.st_shndx == SHN_UNDEF || sym.st_shndx == SHN_ABS) continue;
      if (sym.st_value >= kDataSpaceBytes) continue;
      const char *name = elf_strptr(elf, header.sh_link, sym.st_name);
      if (!name || !*name || name[0] == '.') continue;
      symbols_.push_back({static_cast<uint32_t>(sym.st_value), static_cast<uint32_t>(sym.st_size), name});
    }
  }
  elf_end(elf);
  ::close(fd);
  std::sort(symbols_.begin(), symbols_.end(), [](const CodeSymbol &a, const CodeSymbol &b) {
    return a.address_bytes != b.address_bytes ? a.address_bytes < b.address_bytes
                                              : a.size_bytes > b.size_bytes;
  });
  return true;
}

// End (exclusive) of symbol i: its size, or the next higher symbol's address.
uint32_t CodeSymbols::end_of(size_t i) const {
  const CodeSymbol &sym = symbols_[i];
  if (sym.size_bytes != 0) return sym.address_bytes + sym.size_bytes;
  for (size_t j = i + 1; j < symbols_.size(); ++j)
    if (symbols_[j].address_bytes > sym.address_bytes) return symbols_[j].address_bytes;
  return sym.address_bytes + 2;
}

// Code ranges of the __vector_N functions the program defines.
std::vector<IsrRange> CodeSymbols::isr_ranges() const {
  uint32_t bad_interrupt_bytes = UINT32_MAX;
  for (const CodeSymbol &sym : symbols_)
    if (sym.name == "__bad_interrupt") bad_interrupt_bytes = sym.address_bytes;
  std::vector<IsrRange> ranges;
  for (size_t i = 0; i < symbols_.size(); ++i) {
    const int vector = vector_number_of(symbols_[i].name);
    if (vector <= 0 || symbols_[i].address_bytes == bad_interrupt_bytes) continue;
    ranges.push_back({static_cast<unsigned>(vector), symbols_[i].address_bytes, end_of(i)});
  }
  return ranges;
}

// "name+0xoff" for the symbol holding pc_bytes.
std::string CodeSymbols::describe(uint32_t pc_bytes) const {
  const CodeSymbol *best = nullptr;
  for (size_t i = 0; i < symbols_.size(); ++i) {
    if (symbols_[i].address_bytes > pc_bytes) break;
    if (pc_bytes < end_of(i)) best = &symbols_[i];  // later (higher) start wins: innermost
  }
  char text[160];
  if (!best) {
    std::snprintf(text, sizeof text, "0x%05x", pc_bytes);
  } else {
    std::snprintf(text, sizeof text, "%s+0x%x", best->name.c_str(), pc_bytes - best->address_bytes);
  }
  return text;
}

}  // namespace vboard
