// The team of a region (thread_policy.h): the threads asked for, less the cores other runnable
// threads hold now; and the threads asked for (resolveThreads, parallel_for.h).

#include "core/thread_policy.h"

#include <fcntl.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>

#include "core/parallel_for.h"

namespace cube {
namespace detail {

namespace {

std::atomic<long long> g_last_close_ns{0};
std::atomic<int> g_last_team{1};

long long nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Runnable threads on the machine now, the caller included (the "R" of /proc/loadavg's "R/T");
// -1 if unknown.
int runnableThreads() {
  // Opened once and read from its start each time (pread: safe on several threads at once).
  static const int fd = ::open("/proc/loadavg", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char buf[128];
  const ssize_t got = ::pread(fd, buf, sizeof(buf) - 1, 0);
  if (got <= 0) return -1;
  buf[got] = '\0';
  // "0.52 0.61 0.70 3/412 12345": the fourth field.
  const char* p = buf;
  for (int field = 0; field < 3; ++field) {
    while (*p != '\0' && *p != ' ') ++p;
    while (*p == ' ') ++p;
  }
  char* end = nullptr;
  const long r = std::strtol(p, &end, 10);
  if (end == p || *end != '/' || r < 1) return -1;
  return int(r);
}

}  // namespace

int regionTeam(int requested) {
  if (requested <= 1) return 1;
  static const bool ignore_load = std::getenv("CUBE_THREADS_IGNORE_LOAD") != nullptr;
  if (ignore_load) return requested;
  const int running = runnableThreads();
  if (running < 0) return requested;
  // Others: every runnable thread but this one and the workers of this process's last region if
  // they may still be spinning.
  int others = running - 1;
  if (nowNs() - g_last_close_ns.load(std::memory_order_relaxed) < kRecentRegionNs)
    others -= g_last_team.load(std::memory_order_relaxed) - 1;
  return std::clamp(requested - std::max(others, 0), 1, requested);
}

int resolveThreads(int threads) {
  return threads > 0 ? threads : std::max(1, omp_get_max_threads());
}

void regionClosed(int team) {
  if (team <= 1) return;
  g_last_team.store(team, std::memory_order_relaxed);
  g_last_close_ns.store(nowNs(), std::memory_order_relaxed);
}

}  // namespace detail
}  // namespace cube
