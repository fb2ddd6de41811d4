#pragma once

// Randomized differential testing of CubeCollisionManager: random operation sequences over a
// small pool of objects, every step checked against a brute-force model of what the manager
// holds (the AABBs it cached at register/update time) and, when those equal the live AABBs,
// against fcl::NaiveCollisionManager's narrow-phase results. Shared by the ctest
// (test_differential.cpp, choices from a seeded PRNG) and the libFuzzer target (choices from the
// input bytes), so any fuzzer finding replays as an ordinary test.
//
// The parts, by role: differential_sources.h (where choices come from, scene families,
// configurations), differential_pool.h (the objects and the model of what the manager holds),
// differential_operations.h and differential_other_managers.h (the operations),
// differential_expect.h (recorders, brute-force answers, failure texts),
// differential_checks.h (what is checked after each step); this file drives a sequence.

#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "differential_checks.h"
#include "differential_operations.h"
#include "differential_pool.h"
#include "differential_sources.h"

namespace cube {
namespace diff {

/// One random sequence: owns the pool, the manager under test and the model.
class Runner {
 public:
  /// `pool` objects (1..64) of a scene family; `planes` mixes planes and halfspaces in.
  Runner(Source& src, const Config& config, Scene scene, int pool, bool planes)
      : src_(src),
        pool_(src, scene, pool, planes),
        mgr_(config),
        ops_(src, pool_, model_, mgr_, trace_),
        checks_(src, pool_, model_, mgr_, scene) {
    trace_ << "scene " << sceneName(scene) << " pool " << pool << " planes " << planes << " config "
           << describe(config) << "\n";
  }
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  /// Runs up to `steps` operations (fewer if a byte source runs dry); returns "" or what went
  /// wrong, with the trace of the operations so far.
  std::string run(int steps) {
    for (int i = 0; i < steps && !src_.done(); ++i) {
      ++steps_;
      std::string err = ops_.step();
      if (err.empty()) err = checks_.afterStep();
      if (!err.empty()) return err + "\n--- trace ---\n" + trace_.str();
    }
    return "";
  }

  /// Only for the fuzzer, while the lead fixes a reported bug: validate() failures whose
  /// message contains `text` are not reported (so the fuzzer can look for other bugs).
  void tolerateKnownBug(const std::string& text) { checks_.tolerateKnownBug(text); }

  std::size_t stepsRun() const { return steps_; }
  std::size_t checksRun() const { return checks_.checksRun(); }
  std::size_t narrowChecksRun() const { return checks_.narrowChecksRun(); }

 private:
  Source& src_;
  Pool pool_;
  CubeCollisionManager<S> mgr_;
  Model model_;  // what the manager should hold
  std::ostringstream trace_;
  Operations ops_;
  StepChecks checks_;
  std::size_t steps_ = 0;
};

/// A whole sequence decided by the source: scene, configuration, pool and operations.
inline std::string runSequence(Source& src, int max_steps, std::size_t* steps = nullptr,
                               std::size_t* narrow = nullptr, const std::string& known = "") {
  static const std::vector<Config> all = configs();
  const Scene scene = Scene(src.pick(std::uint32_t(Scene::kCount)));
  const Config& config = all[src.pick(std::uint32_t(all.size()))];
  const int pool = 1 + int(src.pick(src.pick(4) == 0 ? 64 : 24));
  const bool planes = src.pick(3) == 0;
  Runner r(src, config, scene, pool, planes);
  r.tolerateKnownBug(known);
  std::string err = r.run(max_steps);
  if (steps) *steps += r.stepsRun();
  if (narrow) *narrow += r.narrowChecksRun();
  return err;
}

}  // namespace diff
}  // namespace cube
