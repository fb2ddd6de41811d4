#pragma once

// Where a differential sequence's choices come from (a seeded PRNG for the ctest, the input bytes
// for the fuzzer), the scene families and the configurations sequences run with.

#include <cstdint>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cube_collision/config.h"

namespace cube {
namespace diff {

/// Where the choices come from.
class Source {
 public:
  virtual ~Source() = default;
  /// A number in [0, n) (n >= 1).
  virtual std::uint32_t pick(std::uint32_t n) = 0;
  /// A number in [0, 1].
  double unit() { return pick(1u << 16) / double((1u << 16) - 1); }
  /// True once a byte source has nothing left (the sequence then ends).
  virtual bool done() const { return false; }
};

class RandomSource : public Source {
 public:
  explicit RandomSource(std::uint32_t seed) : rng_(seed) {}
  std::uint32_t pick(std::uint32_t n) override {
    return std::uniform_int_distribution<std::uint32_t>(0, n - 1)(rng_);
  }

 private:
  std::mt19937 rng_;
};

class ByteSource : public Source {
 public:
  ByteSource(const std::uint8_t* data, std::size_t size) : p_(data), end_(data + size) {}
  std::uint32_t pick(std::uint32_t n) override {
    std::uint32_t v = 0;
    // As many bytes as n needs, so that small choices cost one byte of input.
    for (std::uint32_t range = 1; range < n && range != 0; range <<= 8) v = (v << 8) | next();
    return v % n;
  }
  bool done() const override { return p_ >= end_; }

 private:
  std::uint8_t next() { return p_ < end_ ? *p_++ : 0; }
  const std::uint8_t* p_;
  const std::uint8_t* end_;
};

/// Scene families; all but `normal` are degenerate on purpose.
enum class Scene { normal, one_point, identical, zero_size, line, huge, tiny, kCount };

inline const char* sceneName(Scene s) {
  static const char* names[] = {"normal", "one_point", "identical", "zero_size",
                                "line",   "huge",      "tiny"};
  return names[int(s)];
}

/// The configurations sequences run with.
inline std::vector<Config> configs() {
  std::vector<Config> out(12);
  out[1].leaf_size = 1;
  out[2].leaf_size = 16;
  out[3].max_depth = 2;
  out[4].max_depth = 1;
  out[4].leaf_size = 1;
  out[5].update_policy = UpdatePolicy::refit;
  out[6].update_policy = UpdatePolicy::rebuild;
  out[7].rebuild_threshold = 1.01;
  out[7].leaf_size = 2;
  // A tiny limit makes ordinary objects cross between the cubes and the unbounded list.
  out[8].unbounded_limit = 5;
  out[9].unbounded_limit = 5;
  out[9].leaf_size = 1;
  out[9].update_policy = UpdatePolicy::refit;
  // Pools hold at most 64 objects, so self-collide takes the all-pairs kernel unless it is off;
  // with a limit of 8 sequences cross between the kernel and the walk.
  for (int i : {1, 3, 7, 9, 10}) out[i].all_pairs_limit = 0;
  out[11].all_pairs_limit = 8;
  // The pair list (off by default) in two thirds of them, so that sequences run both paths.
  for (int i = 0; i < 12; ++i) out[i].keep_pairs = i % 3 != 0;
  return out;
}

inline std::string describe(const Config& c) {
  std::ostringstream s;
  s << "{leaf_size " << c.leaf_size << ", max_depth " << c.max_depth << ", policy "
    << int(c.update_policy) << ", threshold " << c.rebuild_threshold << ", unbounded_limit "
    << c.unbounded_limit << ", all_pairs_limit " << c.all_pairs_limit << ", keep_pairs "
    << c.keep_pairs << "}";
  return s.str();
}

}  // namespace diff
}  // namespace cube
