// render_output.h: render's last step: the virtual boards' traces into one WAV and one piano
// roll, by stepchoir-render beside this program.
#ifndef STEPCHOIR_HOST_CLI_RENDER_OUTPUT_H
#define STEPCHOIR_HOST_CLI_RENDER_OUTPUT_H

#include <memory>
#include <string>
#include <vector>

#include "board/vboard_child.h"

namespace stepchoir {

// Stops the virtual boards (their traces complete) and has stepchoir-render write out_wav (and
// out_png unless ""): every board's motors, each trace placed by its board's first note
// (first_note_s; a board that played nothing is left out). Removes the traces unless
// keep_traces. False, said on stderr, when stepchoir-render failed. Called from: render, once
// every player has finished.
bool write_render(std::vector<std::unique_ptr<VirtualBoard>> &vbs, const std::vector<std::string> &traces,
                  const std::vector<double> &first_note_s, const std::string &out_wav, const std::string &out_png,
                  bool keep_traces);

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_CLI_RENDER_OUTPUT_H
