// Linked into every test executable: the thread counts the tests ask for run as asked however busy
// the machine is (src/core/thread_policy.h sizes a region's team by the machine's load unless
// CUBE_THREADS_IGNORE_LOAD is set), so that the threaded paths they check are taken. Set before
// any query reads it (regionTeam reads it at its first call).

#include <cstdlib>

namespace {

[[maybe_unused]] const bool kIgnoreLoad = ::setenv("CUBE_THREADS_IGNORE_LOAD", "1", 1) == 0;

}  // namespace
