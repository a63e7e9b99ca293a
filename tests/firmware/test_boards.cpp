// test_boards.cpp: microstep tables, switch levels, and every board-table pin and every entry of
// each board's Arduino pin map checked against the Arduino core's own variant table (Debian
// arduino-core-avr).
#include <catch2/catch.hpp>

#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "boards/mega_ramps_14.h"
#include "boards/uno_cnc_shield_v3.h"
#include "microstep.h"

namespace {

// Arduino pin number -> "D2"-style port+bit from a variant's pins_arduino.h comments/table.
std::map<int, std::string> variant_pins(const std::string &variant) {
  const std::string path = "/usr/share/arduino/hardware/arduino/avr/variants/" + variant + "/pins_arduino.h";
  std::ifstream f(path);
  REQUIRE(f);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string s = ss.str();
  std::map<int, std::string> out;
  // The port table: digital_pin_to_port_PGM lists PA..PL per pin, bit table lists _BV(n).
  auto table = [&](const std::string &name) {
    const auto a = s.find(name);
    const auto b = s.find("};", a);
    std::vector<std::string> items;
    std::regex item(name.find("port") != std::string::npos ? "\\bP([A-L])\\b" : "_BV\\(\\s*(\\d)\\s*\\)");
    const std::string body = s.substr(a, b - a);
    std::string clean;
    std::istringstream lines(body);
    std::string line;
    while (std::getline(lines, line)) clean += line.substr(0, line.find("//")) + "\n";
    for (std::sregex_iterator it(clean.begin(), clean.end(), item), end; it != end; ++it) items.push_back((*it)[1]);
    return items;
  };
  const auto ports = table("digital_pin_to_port_PGM");
  const auto bits = table("digital_pin_to_bit_mask_PGM");
  REQUIRE(ports.size() == bits.size());
  for (size_t i = 0; i < ports.size(); ++i) out[int(i)] = ports[i] + bits[i];
  return out;
}

// Checks every wired pin of a board table against the variant.
template <size_t N>
void check_board(const board::MotorPins (&motors)[N], const std::string &variant) {
  const auto pins = variant_pins(variant);
  for (const auto &m : motors) {
    for (board::Pin p : {m.step, m.dir, m.enable, m.min_switch, m.max_switch, m.m0, m.m1, m.m2, m.reset, m.sleep}) {
      if (!p.wired()) continue;
      INFO("axis " << m.axis << " Arduino pin " << int(p.arduino));
      REQUIRE(pins.count(p.arduino));
      CHECK(pins.at(p.arduino) == std::string(1, p.port) + std::to_string(p.bit));
    }
  }
}

// Checks a board's whole Arduino pin map (pin number -> port and bit) against the variant.
void check_pin_map(const uint8_t *map, uint8_t count, const std::string &variant) {
  const auto pins = variant_pins(variant);
  CHECK(count == pins.size());
  for (int n = 0; n < count; ++n) {
    const board::Pin p = board::pin_from_map(map, count, static_cast<int8_t>(n));
    INFO(variant << ": Arduino pin " << n);
    REQUIRE(pins.count(n));
    CHECK(p.arduino == n);
    CHECK(pins.at(n) == std::string(1, p.port) + std::to_string(p.bit));
  }
}

}  // namespace

TEST_CASE("board pin tables match the Arduino core's variants") {
  check_board(board::uno_cnc_shield_v3::kMotors, "standard");
  check_board(board::mega_ramps_14::kMotors, "mega");
}

TEST_CASE("board pin maps (Arduino pin -> port and bit) match the Arduino core's variants") {
  check_pin_map(board::uno_cnc_shield_v3::kPinMap, board::uno_cnc_shield_v3::kPinCount, "standard");
  check_pin_map(board::mega_ramps_14::kPinMap, board::mega_ramps_14::kPinCount, "mega");
}

TEST_CASE("board tables have the motors the shields have") {
  CHECK(board::uno_cnc_shield_v3::kMotorCount == 4);
  CHECK(board::mega_ramps_14::kMotorCount == 5);
  CHECK(board::same_pin(board::uno_cnc_shield_v3::kMotors[0].min_switch, board::uno_cnc_shield_v3::kMotors[0].max_switch));
  CHECK_FALSE(board::uno_cnc_shield_v3::kMotors[3].min_switch.wired());
  CHECK_FALSE(board::same_pin(board::mega_ramps_14::kMotors[0].min_switch, board::mega_ramps_14::kMotors[0].max_switch));
}

TEST_CASE("microstep tables per driver") {
  uint8_t bits = 0xAA;
  // DRV8825: M0 M1 M2
  const std::pair<int, int> drv[] = {{1, 0}, {2, 1}, {4, 2}, {8, 3}, {16, 4}, {32, 5}};
  for (auto [mode, want] : drv) {
    REQUIRE(drv::microstep_bits(sc::kDriverDrv8825, uint8_t(mode), &bits));
    CHECK(bits == want);
  }
  // A4988: MS1 MS2 MS3, 1/16 = HHH, no 1/32
  const std::pair<int, int> a49[] = {{1, 0}, {2, 1}, {4, 2}, {8, 3}, {16, 7}};
  for (auto [mode, want] : a49) {
    REQUIRE(drv::microstep_bits(sc::kDriverA4988, uint8_t(mode), &bits));
    CHECK(bits == want);
  }
  CHECK_FALSE(drv::microstep_bits(sc::kDriverA4988, 32, &bits));
  CHECK_FALSE(drv::microstep_bits(sc::kDriverDrv8825, 3, &bits));
  CHECK(drv::microstep_bits(sc::kDriverTb6600, 32, &bits));  // DIP switches: accepted, no pins
  CHECK_FALSE(drv::microstep_by_pins(sc::kDriverTb6600));
  CHECK(drv::default_pulse_us(sc::kDriverTb6600) >= 3);
  CHECK(drv::default_pulse_us(sc::kDriverA4988) >= 2);
}

TEST_CASE("switch levels follow the seed's table") {
  CHECK(drv::switch_pressed(false, false));
  CHECK_FALSE(drv::switch_pressed(true, false));
  CHECK_FALSE(drv::switch_pressed(false, true));
  CHECK(drv::switch_pressed(true, true));
}
