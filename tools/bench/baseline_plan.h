// baseline_plan.h: the song planner the arranger replaced, for the arrangement benchmark.
#ifndef STEPCHOIR_TOOLS_BENCH_BASELINE_PLAN_H
#define STEPCHOIR_TOOLS_BENCH_BASELINE_PLAN_H

#include "player/plan.h"

namespace stepchoir {

// Greedy onset-order allocation (baseline_plan.cpp). Called from: the arrangement benchmark.
Plan plan_song_baseline(const Song &song, const PlanOptions &options);

}  // namespace stepchoir

#endif  // STEPCHOIR_TOOLS_BENCH_BASELINE_PLAN_H
