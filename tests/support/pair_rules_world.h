#pragma once

// What the pair rule tests share (test_pair_filters.cpp, test_margins.cpp, test_pair_passes.cpp,
// test_canonical_pairs.cpp, test_excluded_pairs.cpp): filter bits drawn at random and set on a
// manager, brute force over every pair that the bits let through, and the scenes they run on.

#include <fcl/narrowphase/collision_object.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "oracle.h"
#include "scenes.h"

namespace pair_rules {

using cube::CubeCollisionManager;
using cube::oracle::Pair;
using cube::oracle::unordered;

template <typename S>
using Obj = fcl::CollisionObject<S>;

struct Bits {
  std::uint64_t category = 1, mask = ~std::uint64_t(0);
};

inline bool pass(const Bits& a, const Bits& b) {
  return (a.category & b.mask) != 0 && (b.category & a.mask) != 0;
}

// Random bits over four groups for about two thirds of the objects; the others keep the default.
template <typename S>
std::map<Obj<S>*, Bits> randomBits(CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs,
                                   std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::map<Obj<S>*, Bits> bits;
  for (Obj<S>* o : objs) {
    Bits b;
    if (rng() % 3 != 0) {
      b.category = std::uint64_t(1) << (rng() % 4);
      b.mask = rng() % 16;
      m.setFilter(o, b.category, b.mask);
      std::string why;
      EXPECT_TRUE(m.validate(&why)) << why;
    }
    bits[o] = b;
  }
  return bits;
}

template <typename S>
Bits bitsOf(const std::map<Obj<S>*, Bits>& bits, Obj<S>* o) {
  const auto it = bits.find(o);
  return it == bits.end() ? Bits{} : it->second;
}

// Brute force: overlapping AABBs that pass the bits, as sorted unordered pairs.
template <typename S>
std::vector<Pair<S>> bruteFiltered(const std::vector<Obj<S>*>& objs,
                                   const std::map<Obj<S>*, Bits>& bits) {
  std::vector<Pair<S>> out;
  for (const auto& p : cube::oracle::bruteSelfPairs(objs))
    if (pass(bitsOf(bits, p.first), bitsOf(bits, p.second))) out.push_back(p);
  return out;
}

// The least narrow-phase distance over the pairs (i < j) that `allowed` keeps, by brute force
// with the function the manager's distance query is given.
template <class Allowed>
double bruteSelfDistance(const std::vector<Obj<double>*>& objs, Allowed&& allowed) {
  double brute = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j) {
      if (!allowed(i, j)) continue;
      double d = std::numeric_limits<double>::max();
      double tmp = d;
      cube::oracle::narrowDistance<double>(objs[i], objs[j], &tmp, d);
      brute = std::min(brute, tmp);
    }
  return brute;
}

template <typename S>
cube::scenes::Scene<S> scene(std::size_t n, std::uint32_t seed, double overlaps = 3.0) {
  cube::scenes::SceneOptions o;
  o.n = n;
  o.seed = seed;
  o.overlaps_per_object = overlaps;
  return cube::scenes::makeScene<S>(o);
}

}  // namespace pair_rules
