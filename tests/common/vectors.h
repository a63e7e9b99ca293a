// vectors.h: reads the hex test vectors out of protocol/PROTOCOL.md (the one copy of them).
#ifndef STEPCHOIR_TESTS_VECTORS_H
#define STEPCHOIR_TESTS_VECTORS_H

#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace testvec {

struct Vector {
  std::string kind;                              // first word after "vector"
  std::multimap<std::string, std::string> fields;  // key=value pairs, in order
  std::vector<uint8_t> payload, wire;
  int line = 0;                                  // line of "vector" in PROTOCOL.md

  // The value of a field, as an unsigned number (0x prefix allowed).
  uint64_t num(const std::string &key) const {
    auto it = fields.find(key);
    if (it == fields.end()) throw std::runtime_error("PROTOCOL.md:" + std::to_string(line) + ": no field " + key);
    return std::stoull(it->second, nullptr, 0);
  }
  // All values of a repeated field, as numbers.
  std::vector<uint64_t> nums(const std::string &key) const {
    std::vector<uint64_t> out;
    auto r = fields.equal_range(key);
    for (auto it = r.first; it != r.second; ++it) out.push_back(std::stoull(it->second, nullptr, 0));
    return out;
  }
  std::string str(const std::string &key) const { return fields.find(key)->second; }
};

// Parses space-separated hex bytes.
inline std::vector<uint8_t> hex_bytes(const std::string &s) {
  std::vector<uint8_t> out;
  std::istringstream in(s);
  std::string h;
  while (in >> h) out.push_back(static_cast<uint8_t>(std::stoul(h, nullptr, 16)));
  return out;
}

// Every vector in the spec; throws if the file is missing or a vector is incomplete.
inline std::vector<Vector> load(const std::string &path = STEPCHOIR_PROTOCOL_MD) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::vector<Vector> out;
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (line.rfind("vector ", 0) == 0) {
      Vector v;
      v.line = n;
      std::istringstream in(line.substr(7));
      in >> v.kind;
      std::string kv;
      while (in >> kv) {
        auto eq = kv.find('=');
        if (eq != std::string::npos) v.fields.emplace(kv.substr(0, eq), kv.substr(eq + 1));
      }
      out.push_back(v);
    } else if (line.rfind("payload ", 0) == 0 && !out.empty()) {
      out.back().payload = hex_bytes(line.substr(8));
    } else if (line.rfind("wire ", 0) == 0 && !out.empty()) {
      out.back().wire = hex_bytes(line.substr(5));
    }
  }
  for (const auto &v : out)
    if (v.payload.empty() || v.wire.empty())
      throw std::runtime_error(path + ":" + std::to_string(v.line) + ": vector without payload or wire");
  return out;
}

}  // namespace testvec

#endif  // STEPCHOIR_TESTS_VECTORS_H
