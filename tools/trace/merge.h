// merge.h: the traces of several virtual boards that played one song, as one trace on one
// time line (stepchoir render with several boards: one WAV and one piano roll of every motor).
#ifndef STEPCHOIR_TRACE_MERGE_H
#define STEPCHOIR_TRACE_MERGE_H

#include <vector>

#include "trace.h"

namespace sc {
namespace trace {

// The traces' motors in order (the first trace's, then the second's, ...), each trace's cycles
// shifted so that the song starts at one cycle for all: first_note_s[k] is the song time (s) of
// trace k's first step. Boards at the same f_cpu and clock_ppm only; throws std::runtime_error
// otherwise or when the counts differ. Called from: stepchoir-render.
Trace merge_traces(const std::vector<Trace> &traces, const std::vector<double> &first_note_s);

}  // namespace trace
}  // namespace sc

#endif  // STEPCHOIR_TRACE_MERGE_H
