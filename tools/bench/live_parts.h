// live_parts.h: the live bench's single notes, key -> first STEP edge, split into its parts on
// one monotonic clock: the host's stamps per note and the virtual board's trace (its STEP edges
// and, with stepchoir-vboard --trace-frames, each host frame's first and last byte at the UART),
// laid on that clock through the trace's wall_start line. Called from: live_bench.cpp.
#ifndef STEPCHOIR_BENCH_LIVE_PARTS_H
#define STEPCHOIR_BENCH_LIVE_PARTS_H

#include <cstdint>
#include <string>
#include <vector>

#include "trace.h"

namespace live_parts {

constexpr double kWithinS = 0.020;  // a key's first STEP edge comes this soon, s, or counts as not found

// What the host saw of one note, monotonic_us: the sender's clock just before it handed the note
// to JACK, the MIDI callback's stamp and the return of the write() that carried its frame
// (both 0 when no frame of this note was written: BoardStats::last_event_us was older).
struct NoteStamps {
  uint64_t key_us = 0, callback_us = 0, written_us = 0;
};

// One note's parts, us; they add up to total.
struct NoteParts {
  double jack = 0;      // key -> the MIDI callback's stamp
  double host = 0;      // callback -> write() on the link returned
  double link = 0;      // write returned -> the frame's first byte at the board's UART
  double wire = 0;      // first byte -> last byte (the delimiter) at the UART, cycles exact
  double firmware = 0;  // last byte -> the motor's first STEP edge, cycles exact
  double total = 0;     // key -> first STEP edge
  double sum() const { return jack + host + link + wire + firmware; }
  double after_midi() const { return total - jack; }  // the MIDI callback's stamp -> first STEP edge
};

struct Split {
  std::vector<double> totals_us;  // key -> first STEP edge of every note whose edge was found
  std::vector<NoteParts> parts;   // of those, every one with host stamps and a frame before its edge
  size_t no_stamps = 0;           // edge found, but no host stamps of the note
  size_t no_frame = 0;            // edge found, but no traced frame before it
  double worst_sum_error_us = 0;  // largest |sum of parts - total| over parts
};

// Each key's first STEP edge: the first edge on any motor after a silence of 15 ms or more on
// that motor, after the key, within 20 ms; its frame: the last whose delimiter reached the UART
// before that edge. Needs trace.has_wall_start.
Split split_notes(const sc::trace::Trace &trace, const std::vector<NoteStamps> &notes);

// The results file's table "key -> first STEP edge, part by part" (Markdown, with its heading and
// a note on method): p50 / p99 / max of each part and of the total, and each part's bound.
// jack_period_us: the server's period; link_model: the virtual board's --link-model;
// frame_bytes: one note's frame on the wire; baud: the protocol's.
std::string parts_table(const Split &split, size_t onsets, double jack_period_us, const std::string &link_model,
                        unsigned frame_bytes, unsigned baud);

// Nearest-rank percentile (q in [0, 1]) of values, 0 when empty. Sorts a copy.
double percentile(std::vector<double> values, double q);

}  // namespace live_parts

#endif  // STEPCHOIR_BENCH_LIVE_PARTS_H
