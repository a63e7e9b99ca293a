// bench_date.h: the text of a results file's "Date:" line: now, in UTC, to the second.
// Called from: the benches that write bench/results/ (live_bench.cpp, bridge_16u2_bench.cpp).
#ifndef STEPCHOIR_BENCH_DATE_H
#define STEPCHOIR_BENCH_DATE_H

#include <ctime>
#include <string>

inline std::string utc_now_text() {
  char text[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  return text;
}

#endif  // STEPCHOIR_BENCH_DATE_H
