// doctor.h: `stepchoir doctor`: checks the rig a musician is about to play and prints the fix
// for each problem: the configuration's first mistake, serial permissions (the dialout group,
// the udev rule in tools/system/), real-time limits (tools/system/'s limits.d file), ALSA and
// JACK MIDI ports, and for each board its hello, firmware protocol and a round trip's latency.
#ifndef STEPCHOIR_HOST_CLI_DOCTOR_H
#define STEPCHOIR_HOST_CLI_DOCTOR_H

#include <string>
#include <vector>

namespace stepchoir {

struct DoctorOptions {
  std::string config;               // --config, else the default location
  std::vector<std::string> ports;   // --port (repeatable), else the file's boards
  int round_trips = 20;             // clock round trips timed per board
};

// Runs every check, printing "ok" or "FIX" lines with the fix under each; returns 0 when
// nothing needs fixing, 1 otherwise. Called from: main.
int run_doctor(const DoctorOptions &o);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_DOCTOR_H
