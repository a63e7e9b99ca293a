// rt_guard.h: a debug-build check that real-time code (the MIDI callback, the live engine and
// writer loops) never allocates.
//
// An RtScope marks the current thread as inside real-time code. In builds with
// STEPCHOIR_RT_GUARD (CMake's Debug configuration) rt_guard.cpp replaces the global operator
// new with one that aborts with a message when called inside an RtScope; in other builds the
// scope is an increment and a decrement of a thread-local counter.
#ifndef STEPCHOIR_HOST_RT_GUARD_H
#define STEPCHOIR_HOST_RT_GUARD_H

namespace stepchoir {

class RtScope {
 public:
  // Called from: the top of a real-time entry point (the MIDI callback). Does not allocate.
  RtScope() noexcept;
  ~RtScope();
  RtScope(const RtScope &) = delete;
  RtScope &operator=(const RtScope &) = delete;
};

// Suspends the thread's real-time scopes for a block. Called from: test fakes that stand in
// for I/O the real-time path calls (a Link's write) and record what they get with
// allocations; never from the product's code.
class RtExempt {
 public:
  RtExempt() noexcept;
  ~RtExempt();
  RtExempt(const RtExempt &) = delete;
  RtExempt &operator=(const RtExempt &) = delete;

 private:
  int saved_;
};

// True on a thread inside an RtScope. Called from: the allocation hook, tests.
bool in_rt_scope() noexcept;

// True when this build aborts on allocation inside an RtScope.
bool rt_guard_enabled() noexcept;

}  // namespace stepchoir

#endif  // STEPCHOIR_HOST_RT_GUARD_H
