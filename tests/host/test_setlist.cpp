// test_setlist.cpp: the rig file's [setlist]: items by preset name and song file, a song's
// motors from its preset's mutes, paths from the rig file's directory, and mistakes with their
// line and column.
#include <catch2/catch.hpp>

#include <string>

#include "config/config.h"

using namespace stepchoir;

namespace {

const std::string kPresets =
    "[[presets]]\nprogram = 1\nname = \"plain\"\n\n[[presets]]\nprogram = 2\nname = \"duet\"\nmute_motors = [0, 1]\n\n";

}  // namespace

TEST_CASE("setlist: items by preset name and song, song motors from the preset's mutes", "[setlist][config]") {
  const LiveConfig c = parse_config(kPresets + "[setlist]\nitems = [\n  { preset = \"plain\" },\n"
                                               "  { song = \"songs/ode.mid\", preset = \"duet\", tempo = 0.5 },\n"
                                               "  { song = \"/abs/b.mid\", song_motors = [3], name = \"encore\", transpose = -12 },\n]\n",
                                    "/home/me/rig/stepchoir.toml");
  REQUIRE(c.setlist.size() == 3);
  CHECK(c.setlist[0].preset == 0);
  CHECK(c.setlist[0].name == "plain");
  CHECK(c.setlist[0].song.empty());
  CHECK(c.setlist[1].preset == 1);
  CHECK(c.setlist[1].song == "/home/me/rig/songs/ode.mid");
  CHECK(c.setlist[1].song_motors == std::vector<uint8_t>{0, 1});
  CHECK(c.setlist[1].tempo == 0.5);
  CHECK(c.setlist[1].name == "duet");
  CHECK(c.setlist[2].preset == -1);
  CHECK(c.setlist[2].song == "/abs/b.mid");
  CHECK(c.setlist[2].song_motors == std::vector<uint8_t>{3});
  CHECK(c.setlist[2].transpose == -12);
  CHECK(c.setlist[2].name == "encore");
}

TEST_CASE("setlist: mistakes name the file, line and column", "[setlist][config]") {
  auto parse = [](const std::string &setlist) { return parse_config(kPresets + setlist, "f.toml"); };
  CHECK_THROWS_WITH(parse("[setlist]\nitems = [{ preset = \"lead\" }]\n"),
                    Catch::StartsWith("f.toml:11:21: preset 'lead': no [[presets]] table"));
  CHECK_THROWS_WITH(parse("[setlist]\nitems = [{ name = \"x\" }]\n"),
                    Catch::StartsWith("f.toml:11:10: a setlist item needs a preset, a song or both"));
  CHECK_THROWS_WITH(parse("[setlist]\nitems = [{ song = \"a.mid\", preset = \"plain\" }]\n"),
                    Catch::Contains("a song item needs song_motors"));
  CHECK_THROWS_WITH(parse("[setlist]\nitems = [{ preset = \"plain\", song_motors = [1] }]\n"),
                    Catch::Contains("song_motors: the item has no song"));
  CHECK_THROWS_WITH(parse("[setlist]\nitems = []\n"), Catch::StartsWith("f.toml:11:9: items: expected a list"));
  CHECK_THROWS_WITH(parse("[setlist]\nsongs = []\n"), Catch::Contains("unknown key 'songs'"));
  CHECK_THROWS_WITH(parse("[setlist]\nitems = [{ preset = \"plain\", tempo = 0 }]\n"), Catch::Contains("tempo"));
}
