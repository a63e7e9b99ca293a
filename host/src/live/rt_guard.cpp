// rt_guard.cpp: the real-time scope counter and, with STEPCHOIR_RT_GUARD, an operator new
// that aborts inside a real-time scope.
#include "live/rt_guard.h"

#include <unistd.h>

#include <cstdlib>
#include <new>

namespace stepchoir {
namespace {
thread_local int t_rt_depth = 0;
}  // namespace

RtScope::RtScope() noexcept { ++t_rt_depth; }
RtScope::~RtScope() { --t_rt_depth; }
RtExempt::RtExempt() noexcept : saved_(t_rt_depth) { t_rt_depth = 0; }
RtExempt::~RtExempt() { t_rt_depth = saved_; }
bool in_rt_scope() noexcept { return t_rt_depth > 0; }

bool rt_guard_enabled() noexcept {
#ifdef STEPCHOIR_RT_GUARD
  return true;
#else
  return false;
#endif
}

}  // namespace stepchoir

#ifdef STEPCHOIR_RT_GUARD
// Called from: every allocation of the program. Aborts (write(2) only, nothing that could
// allocate) when the caller is inside an RtScope.
static void *checked_alloc(std::size_t size) {
  if (stepchoir::in_rt_scope()) {
    static const char msg[] = "stepchoir: allocation inside real-time code (RtScope)\n";
    (void)!::write(2, msg, sizeof msg - 1);
    std::abort();
  }
  if (void *p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void *operator new(std::size_t size) { return checked_alloc(size); }
void *operator new[](std::size_t size) { return checked_alloc(size); }
// The nothrow forms too, so that every new and delete of the program pair up (a sanitizer
// checks that they do).
void *operator new(std::size_t size, const std::nothrow_t &) noexcept {
  try {
    return checked_alloc(size);
  } catch (const std::bad_alloc &) {
    return nullptr;
  }
}
void *operator new[](std::size_t size, const std::nothrow_t &t) noexcept { return operator new(size, t); }
void operator delete(void *p, const std::nothrow_t &) noexcept { std::free(p); }
void operator delete[](void *p, const std::nothrow_t &) noexcept { std::free(p); }
void operator delete(void *p) noexcept { std::free(p); }
void operator delete[](void *p) noexcept { std::free(p); }
void operator delete(void *p, std::size_t) noexcept { std::free(p); }
void operator delete[](void *p, std::size_t) noexcept { std::free(p); }
#endif
