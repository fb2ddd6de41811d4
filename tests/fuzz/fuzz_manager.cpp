// libFuzzer target: the input bytes choose a whole operation sequence (scene, configuration,
// pool, operations) exactly as the ctest's random generator does, and every step is checked
// against the brute-force model and fcl::NaiveCollisionManager. Any mismatch aborts with the
// operation trace; the crashing input replays in test_differential's FuzzerRegressions.

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "../support/differential.h"

namespace {

// Always on (assert() is compiled out with NDEBUG): a failed check prints why and aborts, which
// libFuzzer reports as a crash and saves the input.
void check(bool ok, const std::string& why) {
  if (!ok) {
    std::fprintf(stderr, "cube fuzz mismatch: %s\n", why.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // CUBE_FUZZ_KNOWN_BUG: a validate() message already reported to the lead, ignored so the
  // fuzzer keeps looking for other bugs meanwhile.
  static const char* known = std::getenv("CUBE_FUZZ_KNOWN_BUG");
  cube::diff::ByteSource src(data, size);
  const std::string err = cube::diff::runSequence(src, 200, nullptr, nullptr, known ? known : "");
  // runSequence compares every step with brute force and Naive; empty means all agreed.
  check(err.empty(), err);
  return 0;
}
