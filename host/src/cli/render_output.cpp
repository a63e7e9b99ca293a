// render_output.cpp: see render_output.h.
#include "cli/render_output.h"

#include <unistd.h>

#include <cstdio>
#include <stdexcept>

#include "board/child_process.h"

namespace stepchoir {
namespace {

// Runs `prog` beside this program with args, waits; its exit status (or -1).
// Called from: render (stepchoir-render).
int run_sibling(const std::string &vboard_path, const std::string &prog, std::vector<std::string> args) {
  args.insert(args.begin(), vboard_path.substr(0, vboard_path.rfind('/')) + "/" + prog);
  try {
    ChildProcess::Options options;
    options.inherit_stdout = true;
    return ChildProcess(args, options).wait();
  } catch (const std::runtime_error &) {
    return -1;
  }
}

}  // namespace

bool write_render(std::vector<std::unique_ptr<VirtualBoard>> &vbs, const std::vector<std::string> &traces,
                  const std::vector<double> &first_note_s, const std::string &out_wav, const std::string &out_png,
                  bool keep_traces) {
  std::vector<std::string> args;
  for (size_t k = 0; k < vbs.size(); ++k) {
    vbs[k]->stop();
    if (vbs.size() > 1 && first_note_s[k] < 0) continue;  // a board that played nothing
    args.push_back(traces[k]);
    if (vbs.size() > 1) args.insert(args.end(), {"--first-note", std::to_string(first_note_s[k])});
  }
  args.insert(args.end(), {"-o", out_wav});
  if (!out_png.empty()) args.insert(args.end(), {"--png", out_png});
  const int rc = run_sibling(vbs[0]->path(), "stepchoir-render", args);
  if (!keep_traces)
    for (const std::string &t : traces) ::unlink(t.c_str());
  if (rc != 0) {
    std::fprintf(stderr, "render: stepchoir-render failed (exit %d)\n", rc);
    return false;
  }
  std::printf("render: wrote %s%s%s\n", out_wav.c_str(), out_png.empty() ? "" : " and ", out_png.c_str());
  return true;
}

}  // namespace stepchoir
