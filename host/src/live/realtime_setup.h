// realtime_setup.h: what the system grants a stage instrument: locked memory (mlockall, so no
// page fault delays a note) and SCHED_FIFO for the real-time threads, and the limits behind
// both. Called from: `stepchoir live` at start (it says what it got) and `stepchoir doctor`.
// Not for the real-time path: these run before it starts.
#ifndef STEPCHOIR_HOST_LIVE_REALTIME_SETUP_H
#define STEPCHOIR_HOST_LIVE_REALTIME_SETUP_H

#include <cstdint>
#include <string>

namespace stepchoir {

// The process's real-time limits.
struct RealtimeLimits {
  bool privileged = false;     // CAP_SYS_NICE and CAP_IPC_LOCK (root): no limit applies
  uint64_t rtprio = 0;         // RLIMIT_RTPRIO's soft limit (highest SCHED_FIFO priority allowed)
  uint64_t memlock_bytes = 0;  // RLIMIT_MEMLOCK's soft limit; UINT64_MAX: unlimited
};
RealtimeLimits realtime_limits();

// True when the limits let `live` lock its memory and run its threads at `priority`.
bool memory_lock_allowed(const RealtimeLimits &l);
bool priority_allowed(const RealtimeLimits &l, int priority);

// Locks the process's memory, now and later (mlockall), where the limits allow it without
// risking a later allocation's failure (unlimited, or privileged). Returns "" when locked,
// else why not, in plain words.
std::string lock_memory();

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_LIVE_REALTIME_SETUP_H
