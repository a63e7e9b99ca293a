// plan_options.h: the plan's options (player/plan.h) from `play`, `render` and `jam`'s command
// line (SongSelection).
#ifndef STEPCHOIR_HOST_CLI_PLAN_OPTIONS_H
#define STEPCHOIR_HOST_CLI_PLAN_OPTIONS_H

#include <cstdint>
#include <vector>

#include "cli/play_command.h"
#include "player/plan.h"

namespace stepchoir {

// The plan options from the command line, for the board motors ids (in the plan's order) whose
// musical settings (the rig file's) are `music`. Called from: PlayCommand::run. Throws
// std::runtime_error for a bad --drums, --keep or --voices.
PlanOptions plan_options(const SongSelection &sel, const std::vector<uint8_t> &ids, std::vector<MotorConfig> music);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_PLAN_OPTIONS_H
