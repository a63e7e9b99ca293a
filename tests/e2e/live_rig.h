// live_rig.h: the rig of a `stepchoir live` end-to-end test: a private JACK server, the test's
// keyboard on it, an Uno virtual board keeping a trace, and a rig file naming both.
#ifndef STEPCHOIR_TESTS_E2E_LIVE_RIG_H
#define STEPCHOIR_TESTS_E2E_LIVE_RIG_H

#include <fstream>
#include <string>

#include "e2e_util.h"
#include "jack_rig.h"
#include "vboard_process.h"

namespace e2e {

struct LiveRig {
  // name: the scratch files' stem (NAME.csv the trace, NAME.toml the rig file); extra_toml:
  // tables for the rig file (presets, controls), between its [midi] table and its board.
  explicit LiveRig(const std::string &name, const std::string &extra_toml = "")
      : trace_path(scratch(name + ".csv")),
        config_path(scratch(name + ".toml")),
        vb({"--board", "uno", "--trace", trace_path, "--quiet", "--no-measure"}) {
    std::ofstream(config_path) << "[midi]\ninput = \"" << Sender::kPort << "\"\napi = \"jack\"\n\n"
                               << extra_toml << "[[boards]]\nport = \"" << vb.pty() << "\"\n";
  }

  JackServer jack{1024};  // 21 ms periods
  Sender keys;
  std::string trace_path, config_path;
  VboardProcess vb;
};

}  // namespace e2e

#endif  // STEPCHOIR_TESTS_E2E_LIVE_RIG_H
