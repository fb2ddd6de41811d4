#pragma once

// What the pair rule tests share (test_pair_filters.cpp, test_margins.cpp, test_pair_passes.cpp,
// test_canonical_pairs.cpp, test_excluded_pairs.cpp): filter bits drawn at random and set on a
// manager, brute force over every pair that the bits let through, and the scenes they run on; for
// pairPasses, managers whose bits, excluded pairs and pair filter are all drawn at random.

#include <fcl/narrowphase/collision_object.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
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

template <typename S>
void expectValid(const CubeCollisionManager<S>& m) {
  std::string why;
  EXPECT_TRUE(m.validate(&why)) << why;
}

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

// One manager's rules as drawn: bits per object, excluded pairs (unordered), and the pair filter
// it is given (keep), which counts its calls.
template <typename S>
struct Rules {
  std::map<Obj<S>*, Bits> bits;
  std::set<Pair<S>> excluded;
  const std::map<const Obj<S>*, int>* number = nullptr;  // every object's number, for keep
  bool asymmetric = false;
  mutable int calls = 0;

  bool keep(Obj<S>* a, Obj<S>* b) const {
    const int x = number->at(a), y = number->at(b);
    return ((asymmetric ? 2 * x : x) + y) % 5 != 0;
  }
  bool isExcluded(Obj<S>* a, Obj<S>* b) const { return excluded.count(unordered(a, b)) != 0; }
  /// Bits for an object registered in this manager (the default otherwise).
  Bits bitsOf(Obj<S>* o) const { return pair_rules::bitsOf(bits, o); }
};

// Draws bits, excluded pairs (a third of the overlapping pairs and as many random ones) and
// installs a counting pair filter on m, whose objects are `objs`.
template <typename S>
void drawRules(CubeCollisionManager<S>& m, const std::vector<Obj<S>*>& objs, Rules<S>& rules,
               std::uint32_t seed) {
  rules.bits = randomBits(m, objs, seed);
  std::mt19937 rng(seed + 1);
  // Overlapping pairs in the objects' order, not by address: the same draws on every run.
  for (std::size_t i = 0; i < objs.size(); ++i)
    for (std::size_t j = i + 1; j < objs.size(); ++j)
      if (objs[i]->getAABB().overlap(objs[j]->getAABB()) && rng() % 3 == 0)
        rules.excluded.insert(unordered(objs[i], objs[j]));
  for (std::size_t k = 0; k < objs.size() / 2; ++k) {
    Obj<S>* a = objs[rng() % objs.size()];
    Obj<S>* b = objs[rng() % objs.size()];
    if (a != b) rules.excluded.insert(unordered(a, b));
  }
  for (const auto& p : rules.excluded) {
    m.excludePair(p.first, p.second);
    expectValid(m);
  }
  const Rules<S>* r = &rules;
  m.setPairFilter([r](Obj<S>* a, Obj<S>* b) {
    ++r->calls;
    return r->keep(a, b);
  });
}

// The objects of scene(n, seed), then, if `loose` > 0, those of scene(loose, loose_seed) (for
// objects of no manager), every one numbered in that order for the pair filter of Rules.
template <typename S>
struct RulesScene {
  RulesScene(std::size_t n, std::uint32_t seed, std::size_t loose = 0, std::uint32_t loose_seed = 0)
      : main(scene<S>(n, seed)), objs(main.pointers()) {
    if (loose > 0) {
      extra = scene<S>(loose, loose_seed);
      others = extra.pointers();
    }
    for (const auto* list : {&objs, &others})
      for (Obj<S>* o : *list) number.emplace(o, int(number.size()));
  }
  /// objs[from, to).
  std::vector<Obj<S>*> slice(std::size_t from, std::size_t to) const {
    return std::vector<Obj<S>*>(objs.begin() + from, objs.begin() + to);
  }

  cube::scenes::Scene<S> main, extra;
  std::vector<Obj<S>*> objs, others;
  std::map<const Obj<S>*, int> number;
};

// A manager (of `config`) holding `objs` of a RulesScene, its rules drawn by drawRules from
// `seed`. Its pair filter reads `rules`: the two are neither copied nor moved.
template <typename S>
struct RuledManager {
  RuledManager(const RulesScene<S>& world, const std::vector<Obj<S>*>& objs, std::uint32_t seed,
               bool asymmetric = false, const cube::Config& config = cube::Config())
      : manager(config) {
    manager.registerObjects(objs);
    rules.number = &world.number;
    rules.asymmetric = asymmetric;
    drawRules(manager, objs, rules, seed);
  }
  RuledManager(const RuledManager&) = delete;
  RuledManager& operator=(const RuledManager&) = delete;

  CubeCollisionManager<S> manager;
  Rules<S> rules;
};

}  // namespace pair_rules
