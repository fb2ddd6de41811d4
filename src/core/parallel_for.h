#pragma once

// The library's one parallel loop (OpenMP): the core's split walk, the narrow-phase pipeline's
// chunks of pairs and the batched state checks run through it, their teams sized by
// thread_policy.h. Exceptions are carried to the calling thread.

#include <algorithm>
#include <cstddef>
#include <exception>
#include <optional>
#include <vector>

#include "core/thread_policy.h"

namespace cube {
namespace detail {

/// A thread count asked for: `threads` if > 0, else the hardware's (OpenMP's default team, at
/// least 1; the public hardwareThreads()). Defined in thread_policy.cpp.
int resolveThreads(int threads);

/// Runs body(scratch, i) for every i in [0, n) on `threads` threads (the caller sized the team:
/// thread_policy.h), each thread with its own
/// scratch from make() (made once per thread, on that thread). An exception stops nothing: the
/// first one by index (a failed make() counts as index n) is rethrown once every call has run.
/// Dynamic chunks of at most `grain_max` items, about 8 a thread: item costs differ by orders of
/// magnitude (a narrow-phase call on a mesh against a culled pair).
template <class Make, class Body>
void parallelForWith(std::size_t n, int threads, std::size_t grain_max, const Make& make,
                     const Body& body) {
  std::vector<std::exception_ptr> errors;
  const auto keep = [&](std::size_t i) {
#pragma omp critical(cube_parallel_for_errors)
    {
      if (errors.empty()) errors.resize(n + 1);
      if (!errors[i]) errors[i] = std::current_exception();
    }
  };
  const auto run = [&](auto& scratch, std::size_t i) {
    try {
      body(scratch, i);
    } catch (...) {
      keep(i);
    }
  };
  if (threads <= 1 || n < 2) {
    try {
      auto scratch = make();
      for (std::size_t i = 0; i < n; ++i) run(scratch, i);
    } catch (...) {
      keep(n);
    }
  } else {
    const int grain = static_cast<int>(
        std::clamp<std::size_t>(n / (8 * static_cast<std::size_t>(threads)), 1, grain_max));
#pragma omp parallel num_threads(threads)
    {
      // Every thread meets the one worksharing loop, even one whose make() threw (it then
      // skips the items it takes: the call throws anyway).
      std::optional<decltype(make())> scratch;
      try {
        scratch.emplace(make());
      } catch (...) {
        keep(n);
      }
#pragma omp for schedule(dynamic, grain)
      for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
        if (scratch) run(*scratch, static_cast<std::size_t>(i));
    }
    regionClosed(threads);
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

/// parallelForWith without scratch: body(i). Chunks of at most 32 items: smaller chunks cost
/// about as much to hand out as the work they hold.
template <class Body>
void parallelFor(std::size_t n, int threads, const Body& body) {
  struct None {};
  parallelForWith(
      n, threads, 32, [] { return None{}; }, [&](None&, std::size_t i) { body(i); });
}

}  // namespace detail
}  // namespace cube
