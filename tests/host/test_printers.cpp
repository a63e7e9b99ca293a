// test_printers.cpp: G-code for today's printers: CoreXY and delta kinematics (the head's and
// the towers' rules, random songs decoded back), the firmware limits the header sets, and the
// firmware motion model.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "gcode_check.h"
#include "song/corexy_head.h"
#include "song/delta_head.h"
#include "song/gcode.h"
#include "song/gcode_reader.h"
#include "song/motion_model.h"
#include "song/song.h"

using namespace stepchoir;
using gcheck::box;
using gcheck::random_song;
using gcheck::round_trip;
using gcheck::song_of;

TEST_CASE("gcode: CoreXY: A and B sing their voices at their step rates, the head inside the volume") {
  std::mt19937 rng(2024);
  for (int round = 0; round < 40; ++round) {
    INFO("round " << round);
    const Song s = random_song(rng, 1 + round % 3);
    Printer p = round % 4 == 0 ? box(3, 5, 2) : round % 4 == 1 ? box(40, 7, 10) : find_printer(builtin_printers(), "voron24");
    p.kinematics = Kinematics::kCoreXY;
    GcodeOptions o;
    o.fold_octaves = true;
    const auto d = round_trip(s, p, o);
    const std::string text = write_gcode(plan_gcode(s, p, o), p, o, "t");
    CHECK(text.find("; A plays track") != std::string::npos);
    CHECK(text.find(", corexy\n") != std::string::npos);
  }
}

TEST_CASE("gcode: CoreXY: at a side, the motor whose reversal leaves the head the longest way reverses") {
  // A 100 x 10 mm bed, the head at the top side (y = 10) in the middle. A alone moves the head
  // along (1, 1): up and out, so A reverses. With A and B at the same speed (pure X motion)
  // the head is at no side it heads out of: nothing changes.
  CoreXYHead h(50, 10, 0, 100, 0, 10, 1e-9);
  h.set_speed(0, 2);
  CHECK(h.vx() == 1);
  CHECK(h.vy() == 1);
  CHECK(h.heading_out());
  REQUIRE(h.choose(3));
  CHECK(h.vx() == -1);  // A reversed: down and left, 10 s to the bottom
  CHECK(h.vy() == -1);
  CHECK(h.time_to_side() == Approx(10));
  h.set_speed(1, 2);  // B joins: (dA sA + dB sB) / 2 = (-2 + 2) / 2: the head moves along -y
  CHECK(h.vx() == 0);
  CHECK(h.vy() == -2);
  // In a corner that the lone motor's line only touches, no way keeps the head in.
  CoreXYHead c(100, 0, 0, 100, 0, 10, 1e-9);
  c.set_speed(0, 2);
  CHECK_FALSE(c.choose(1));
  // The head lands on a side it reaches, not past it.
  CoreXYHead e(99, 5, 0, 100, 0, 10, 1e-9);
  e.set_speed(0, 2);
  e.set_speed(1, 2);
  e.advance(e.time_to_side());
  CHECK(e.x() == 100);
  CHECK(e.heading_out());
}

TEST_CASE("gcode: each firmware's header raises the motion limits to the preset's safe figures, its footer puts "
          "the printer's own back") {
  const Song s = song_of({{0, 0, 1, 60}});
  const Printer &e = find_printer(builtin_printers(), "ender3");
  struct Case {
    Firmware f;
    const char *set, *restore;
  };
  const Case cases[] = {
      {Firmware::kMarlin, "M201 X2000 Y2000 ;", "M501 ;"},
      {Firmware::kKlipper, "SET_VELOCITY_LIMIT ACCEL=2000 SQUARE_CORNER_VELOCITY=15.0 MINIMUM_CRUISE_RATIO=0.00 ;",
       "SET_VELOCITY_LIMIT ACCEL=500 SQUARE_CORNER_VELOCITY=10.0 MINIMUM_CRUISE_RATIO=0.50 ;"},
      {Firmware::kRepRap, "M566 X900 Y900 ;", "M566 X600 Y600 ;"},
  };
  for (const Case &c : cases) {
    INFO(firmware_name(c.f));
    GcodeOptions o;
    o.flavor = c.f;
    const std::string text = write_gcode(plan_gcode(s, e, o), e, o, "song");
    const size_t song_at = text.find("; song starts"), end_at = text.find("; song ends");
    CHECK(text.find(c.set) < song_at);
    CHECK(text.find(c.restore) > end_at);
    CHECK(text.find(std::string(", firmware ") + firmware_name(c.f)) != std::string::npos);
    const ReadGcode d = read_gcode(text);
    CHECK(d.restores_settings);
    const MotionLimits l = with_settings(printer_limits(e, c.f, false), d.song_settings);
    CHECK(l.accel_mm_s2 == 2000);  // the safe figure, read back as the firmware takes it
    if (c.f == Firmware::kKlipper) CHECK(l.min_cruise_ratio == 0);
    if (c.f == Firmware::kRepRap) CHECK(l.jerk_mm_s[0] == 15);
    if (c.f == Firmware::kMarlin) CHECK(l.junction_deviation_mm == Approx(0.4 * 15 * 15 / 2000).margin(1e-4));
    o.set_limits = false;
    const ReadGcode kept = read_gcode(write_gcode(plan_gcode(s, e, o), e, o, "song"));
    CHECK(kept.song_settings.accel_mm_s2 < 0);  // nothing set
    CHECK_FALSE(kept.restores_settings);
  }
}

TEST_CASE("gcode: on the motion model the sample songs play at least 95 % of their note time in tune on the "
          "Ender-3 and Voron presets, more than with the printers' own limits") {
  for (const char *name : {"ender3", "voron24"})
    for (const char *file : {"9th.sng", "canon.sng", "furelise.sng"}) {
      INFO(file << " on " << name);
      const Printer &p = find_printer(builtin_printers(), name);
      const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/" + file);
      GcodeOptions o;
      o.fold_octaves = true;
      o.flavor = p.motion.firmware;
      const HeaderEffect e = header_effect(s, p, o);
      const MotionReport &before = e.own, &after = e.header;
      INFO("in tune: " << 100 * before.share() << " % before, " << 100 * after.share() << " % after");
      CHECK(after.share() >= 0.95);
      CHECK(after.share() > before.share());
      CHECK(after.moves == before.moves);
      CHECK(after.note_s >= after.written_s * 0.999);  // accelerating never makes a move quicker
    }
}

TEST_CASE("gcode: the motion model: a lone move ramps up and down, a reversal stops, straight on keeps speed") {
  // X: 10 mm at 10 mm/s, accel 1000 mm/s^2: 10 ms up and 10 ms down (0.05 mm each), 9.9 mm at
  // cruise (0.99 s).
  ReadGcode g;
  GcodeMove m;
  m.to[0] = 10;
  m.feed_mm_min = 600;
  m.duration_s = 1;
  g.moves.push_back(m);
  MotionLimits l;
  l.accel_mm_s2 = 1000;
  MotionReport r = model_motion(g, l);
  CHECK(r.note_s == Approx(1.01));
  CHECK(r.in_tune_s == Approx(0.99 + 2 * 10 * (1 - std::pow(2.0, -5 / 1200.0)) / 1000).epsilon(1e-6));
  // Straight on at the same speed: no stop between the two halves.
  GcodeMove back = m;
  back.from[0] = 10;
  back.to[0] = 20;
  g.moves.push_back(back);
  r = model_motion(g, l);
  CHECK(r.note_s == Approx(2.01));
  // A reversal stops: each move ramps both ways.
  g.moves[1].to[0] = 0;
  r = model_motion(g, l);
  CHECK(r.note_s == Approx(2.02));
  // Klipper's minimum cruise ratio caps a short move's top speed: 0.02 mm cannot reach 10 mm/s.
  g.moves.resize(1);
  g.moves[0].to[0] = 0.02;
  l.firmware = Firmware::kKlipper;
  l.min_cruise_ratio = 0.5;
  r = model_motion(g, l);
  CHECK(r.in_tune_s == 0);
}


TEST_CASE("gcode: delta: inverse and forward kinematics agree across the printable space") {
  DeltaGeometry g;
  g.rod_mm = 267;
  g.radius_mm = 134;
  g.printable_mm = 115;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 p{115 * u(rng) / std::sqrt(2.0), 115 * u(rng) / std::sqrt(2.0), 150 + 150 * u(rng)};
    Vec3 h, back;
    REQUIRE(delta_inverse(g, p, &h));
    for (int t = 0; t < 3; ++t) CHECK(h[t] > p[2]);  // carriages above the effector
    REQUIRE(delta_forward(g, h, &back));
    for (int a = 0; a < 3; ++a) CHECK(back[a] == Approx(p[a]).margin(1e-9));
  }
  Vec3 h;
  CHECK_FALSE(delta_inverse(g, {400, 0, 0}, &h));  // beyond the rods' reach
}

TEST_CASE("gcode: delta: each tower sings its voice within 0.5 %, silent towers stand still, the effector stays "
          "inside") {
  Printer small = find_printer(builtin_printers(), "kossel");
  small.delta_printable_mm = 12;  // the effector reaches the border often
  small.axes[2].min_mm = 100;
  small.axes[2].max_mm = 110;
  std::mt19937 rng(77);
  for (int round = 0; round < 24; ++round) {
    INFO("round " << round);
    const Song s = random_song(rng, 1 + round % 3);
    GcodeOptions o;
    o.fold_octaves = true;
    round_trip(s, round % 2 ? small : find_printer(builtin_printers(), "kossel"), o);
  }
}

TEST_CASE("gcode: delta: within every straight move each carriage keeps its speed within 0.5 %") {
  const Printer &k = find_printer(builtin_printers(), "kossel");
  DeltaGeometry g;
  g.rod_mm = k.delta_rod_mm;
  g.radius_mm = k.delta_radius_mm;
  for (const char *file : {"9th.sng", "canon.sng", "furelise.sng"}) {
    INFO(file);
    GcodeOptions o;
    o.fold_octaves = true;
    const Song s = read_song_file(std::string(STEPCHOIR_SONGS_DIR) + "/" + file);
    const ReadGcode d = read_gcode(write_gcode(plan_gcode(s, k, o), k, o, file));
    size_t checked = 0;
    for (const GcodeMove &m : d.moves) {
      if (m.dwell) continue;
      Vec3 h0, hm, h1;
      REQUIRE(delta_inverse(g, {m.from[0], m.from[1], m.from[2]}, &h0));
      REQUIRE(delta_inverse(g, {(m.from[0] + m.to[0]) / 2, (m.from[1] + m.to[1]) / 2, (m.from[2] + m.to[2]) / 2}, &hm));
      REQUIRE(delta_inverse(g, {m.to[0], m.to[1], m.to[2]}, &h1));
      for (int t = 0; t < 3; ++t) {
        const double whole = std::fabs(h1[t] - h0[t]);
        if (whole < 0.05) continue;  // a silent or barely moving carriage: the rounding of its ends
        // the first half's travel against half the whole: speed within 0.5 % on each half
        CHECK(std::fabs(std::fabs(hm[t] - h0[t]) / (whole / 2) - 1) <= 0.005);
        ++checked;
      }
    }
    CHECK(checked > 100);
  }
}
