#pragma once

// A loaded machine for benchmarks and examples: N processes that each spin on a core beside the
// measurement (what perception, control or another planner do to a planner), started and stopped
// by the program, bounded in time. POSIX (Linux: a child also dies with its parent).

#include <signal.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace cube {
namespace scenes {

class BusyLoad {
 public:
  /// Starts `processes` spinning processes (none for 0) that stop by themselves after
  /// `max_seconds`, when this process ends, or when the object is destroyed.
  BusyLoad(int processes, double max_seconds) {
    const pid_t parent = ::getpid();
    for (int i = 0; i < processes; ++i) {
      const pid_t pid = ::fork();
      if (pid == 0) spin(parent, max_seconds);
      if (pid > 0) pids().push_back(pid);
    }
    static bool registered = false;
    if (!registered && processes > 0) {
      registered = true;
      std::atexit(&BusyLoad::stopAll);
    }
  }
  ~BusyLoad() { stopAll(); }
  BusyLoad(const BusyLoad&) = delete;
  BusyLoad& operator=(const BusyLoad&) = delete;

  /// Removes "--load=N" or "--load N" from argv; returns N (0 when absent).
  static int takeArgument(int& argc, char** argv, const char* name = "--load") {
    int n = 0;
    const std::size_t len = std::strlen(name);
    int out = 1;
    for (int i = 1; i < argc; ++i) {
      if (std::strncmp(argv[i], name, len) == 0 && argv[i][len] == '=') {
        n = std::atoi(argv[i] + len + 1);
      } else if (std::strcmp(argv[i], name) == 0 && i + 1 < argc) {
        n = std::atoi(argv[++i]);
      } else {
        argv[out++] = argv[i];
      }
    }
    argc = out;
    argv[argc] = nullptr;
    return n;
  }

  static void stopAll() {
    for (const pid_t pid : pids()) ::kill(pid, SIGKILL);
    for (const pid_t pid : pids()) ::waitpid(pid, nullptr, 0);
    pids().clear();
  }

 private:
  static std::vector<pid_t>& pids() {
    static std::vector<pid_t> p;
    return p;
  }

  [[noreturn]] static void spin(pid_t parent, double max_seconds) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(0);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(max_seconds);
    volatile unsigned long x = 0;
    while (std::chrono::steady_clock::now() < end)
      for (int k = 0; k < 1000000; ++k) x = x + 1;
    ::_exit(0);
  }
};

}  // namespace scenes
}  // namespace cube
