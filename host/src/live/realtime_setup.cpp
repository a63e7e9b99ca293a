// realtime_setup.cpp: see realtime_setup.h.
#include "live/realtime_setup.h"

#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace stepchoir {
namespace {

uint64_t soft_limit(int resource) {
  rlimit r{};
  if (::getrlimit(resource, &r) != 0) return 0;
  return r.rlim_cur == RLIM_INFINITY ? UINT64_MAX : static_cast<uint64_t>(r.rlim_cur);
}

}  // namespace

RealtimeLimits realtime_limits() {
  RealtimeLimits l;
  l.privileged = ::geteuid() == 0;
  l.rtprio = soft_limit(RLIMIT_RTPRIO);
  l.memlock_bytes = soft_limit(RLIMIT_MEMLOCK);
  return l;
}

bool memory_lock_allowed(const RealtimeLimits &l) { return l.privileged || l.memlock_bytes == UINT64_MAX; }

bool priority_allowed(const RealtimeLimits &l, int priority) {
  return l.privileged || l.rtprio >= static_cast<uint64_t>(priority);
}

std::string lock_memory() {
  const RealtimeLimits l = realtime_limits();
  // Locking the future too under a finite limit would make a later allocation fail.
  if (!memory_lock_allowed(l))
    return "memory not locked: the memlock limit is " + std::to_string(l.memlock_bytes / 1024) +
           " KiB, not unlimited (`stepchoir doctor` says how to raise it)";
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) != 0) return std::string("memory not locked: mlockall: ") + std::strerror(errno);
  return "";
}

}  // namespace stepchoir
