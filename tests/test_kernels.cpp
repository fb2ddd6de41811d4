// The SIMD kernels against their plain references:
// - the all-pairs kernel that self-collides small scenes (detail::collideAllPairs), each
//   instruction set in turn, against brute force over the exact boxes: boxes that touch exactly,
//   gaps too small for float, infinite boxes, dead slots, every size up to the limit;
// - the leaf kernels of the walks (detail::leafOverlapMask) on the same kinds of boxes;
// - self-collide of trees large enough to test their leaves on float columns, against brute
//   force;
// - the outward rounding of boxes to float (detail::roundOut) against floatBelow;
// - the SSE2 per-box operations (src/core/kernels/box_ops_sse2.h) against the portable ones,
//   bit for bit.

#include <fcl/geometry/shape/box.h>
#include <fcl/narrowphase/collision_object.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/broadphase.h"
#include "core/kernels/box_ops_portable.h"
#include "core/traversal.h"
#if defined(__SSE2__)
#include "core/kernels/box_ops_sse2.h"
#endif

namespace {

using cube::detail::Box;
using cube::detail::Item;
using cube::detail::PairKernel;
using cube::detail::View;

template <typename S>
class AllPairs : public ::testing::Test {};
using Scalars = ::testing::Types<double, float>;
TYPED_TEST_SUITE(AllPairs, Scalars);

const PairKernel kKernels[] = {PairKernel::portable, PairKernel::sse2, PairKernel::avx2,
                               PairKernel::best};

const char* name(PairKernel k) {
  switch (k) {
    case PairKernel::portable:
      return "portable";
    case PairKernel::sse2:
      return "sse2";
    case PairKernel::avx2:
      return "avx2";
    case PairKernel::best:
      return "best";
  }
  return "?";
}

template <typename S>
using Obj = fcl::CollisionObject<S>;
template <typename S>
using Pairs = std::vector<std::pair<Obj<S>*, Obj<S>*>>;

template <typename S>
struct Recorder {
  Pairs<S> calls;
  std::size_t stop_after = 0;  // 0: never stop
  static bool fn(Obj<S>* a, Obj<S>* b, void* d) {
    auto* r = static_cast<Recorder*>(d);
    r->calls.emplace_back(a, b);
    return r->stop_after != 0 && r->calls.size() == r->stop_after;
  }
};

// A run of object slots (some dead) with awkward boxes, and what brute force says about it.
template <typename S>
struct Slots {
  std::vector<std::unique_ptr<Obj<S>>> owned;
  std::vector<Item<S>> items;

  cube::detail::Node
      bounds{};  // the root cube over the live boxes (what the views' walks start at)

  // With `near`, the awkward cases below are made against near's boxes as well as earlier ones.
  Slots(std::size_t n, std::uint32_t seed, const Slots* near = nullptr) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    auto geom = std::make_shared<fcl::Box<S>>(1, 1, 1);
    std::vector<Box<S>> live;
    if (near != nullptr)
      for (const Item<S>& it : near->items)
        if (it.obj != nullptr) live.push_back(it.box);
    while (items.size() < n) {
      Item<S> it{};
      if (u(rng) < 0.15) {  // a dead slot
        items.push_back(it);
        continue;
      }
      const double kind = u(rng);
      for (int k = 0; k < 3; ++k) {
        const double c = u(rng);
        it.box.lo[k] = S(c - 0.15 * u(rng));
        it.box.hi[k] = S(c + 0.15 * u(rng));
      }
      if (!live.empty() && kind < 0.25) {
        // Touches an earlier box exactly on one face (closed intervals: a pair).
        const Box<S>& o = live[std::size_t(u(rng) * live.size())];
        it.box = o;
        const S w = o.hi[0] - o.lo[0];
        it.box.lo[0] = o.hi[0];
        it.box.hi[0] = o.hi[0] + w;
      } else if (!live.empty() && kind < 0.45) {
        // Misses an earlier box by less than float can tell apart (no pair in double; in float
        // the same box touches).
        const Box<S>& o = live[std::size_t(u(rng) * live.size())];
        it.box = o;
        it.box.lo[1] = std::nextafter(o.hi[1], S(2));
        it.box.hi[1] = it.box.lo[1] + S(0.1);
      } else if (kind > 0.97) {
        // Everywhere, as a plane's box is: it meets every box (and any padding the kernels use).
        for (int k = 0; k < 3; ++k) {
          it.box.lo[k] = -std::numeric_limits<S>::infinity();
          it.box.hi[k] = std::numeric_limits<S>::infinity();
        }
      } else if (kind > 0.94) {
        // Unbounded in one direction, as a halfspace's box is.
        it.box.lo[2] = -std::numeric_limits<S>::infinity();
      }
      owned.push_back(std::make_unique<Obj<S>>(geom));
      it.obj = owned.back().get();
      live.push_back(it.box);
      items.push_back(it);
    }
    Box<S> all{};
    for (int k = 0; k < 3; ++k) {
      all.lo[k] = std::numeric_limits<S>::infinity();
      all.hi[k] = -std::numeric_limits<S>::infinity();
    }
    for (const Item<S>& it : items)
      if (it.obj != nullptr)
        for (int k = 0; k < 3; ++k) {
          all.lo[k] = std::min(all.lo[k], it.box.lo[k]);
          all.hi[k] = std::max(all.hi[k], it.box.hi[k]);
        }
    cube::detail::roundOut(all, bounds.lo, bounds.hi);
    bounds.count = 1;
  }

  View<S> view() const {
    const bool any =
        std::any_of(items.begin(), items.end(), [](const Item<S>& it) { return it.obj; });
    return View<S>{&bounds, items.data(), any ? 0 : cube::detail::kNone,
                   static_cast<std::uint32_t>(items.size())};
  }

  // Every overlapping pair of live slots, in slot order; with `other`, every pair of a live slot
  // here and one there, row by row in this one's slot order.
  Pairs<S> bruteForce(const Slots* other = nullptr) const {
    const std::vector<Item<S>>& ys = other ? other->items : items;
    Pairs<S> out;
    for (std::size_t i = 0; i < items.size(); ++i)
      for (std::size_t j = other ? 0 : i + 1; j < ys.size(); ++j) {
        if (items[i].obj == nullptr || ys[j].obj == nullptr) continue;
        bool hit = true;
        for (int k = 0; k < 3; ++k)
          hit =
              hit && items[i].box.lo[k] <= ys[j].box.hi[k] && ys[j].box.lo[k] <= items[i].box.hi[k];
        if (hit) out.emplace_back(items[i].obj, ys[j].obj);
      }
    return out;
  }
};

TYPED_TEST(AllPairs, EveryKernelEverySizeEqualsBruteForce) {
  using S = TypeParam;
  std::size_t kernels_run = 0, pairs_seen = 0;
  for (PairKernel k : kKernels) {
    if (!cube::detail::pairKernelAvailable(k)) {
      // Only a CPU without AVX2 (or a build without SSE2) gets here; the others still run.
      EXPECT_TRUE(k == PairKernel::avx2 || k == PairKernel::sse2) << name(k);
      continue;
    }
    ++kernels_run;
    for (std::size_t n : {0, 1, 2, 3, 7, 8, 9, 15, 16, 17, 31, 32, 33, 48, 63, 64})
      for (std::uint32_t seed = 1; seed <= 6; ++seed) {
        const Slots<S> s(n, seed * 1000 + std::uint32_t(n));
        const Pairs<S> expected = s.bruteForce();
        Recorder<S> r;
        cube::QueryStats st;
        EXPECT_FALSE(
            cube::detail::collideAllPairs(s.view(), s.view(), true, &r, &Recorder<S>::fn, &st, k));
        // Same pairs, in slot order (row by row).
        ASSERT_EQ(r.calls, expected) << name(k) << " n " << n << " seed " << seed;
        std::size_t live = 0;
        for (const auto& it : s.items) live += it.obj != nullptr;
        // Every pair in float, then at least the real pairs exactly.
        EXPECT_GE(st.box_tests, live * (live - (live > 0)) / 2 + expected.size());
        EXPECT_EQ(st.callbacks, expected.size());
        EXPECT_EQ(st.cubes_visited, 0u);
        pairs_seen += expected.size();
      }
  }
  EXPECT_GE(kernels_run, 2u);  // portable and best at least
  EXPECT_GT(pairs_seen, 1000u);
}

TYPED_TEST(AllPairs, StopsWhenTheCallbackSaysSo) {
  using S = TypeParam;
  const Slots<S> s(64, 99);
  const Pairs<S> expected = s.bruteForce();
  ASSERT_GT(expected.size(), 5u);
  for (PairKernel k : kKernels) {
    if (!cube::detail::pairKernelAvailable(k)) continue;
    Recorder<S> r;
    r.stop_after = 5;
    EXPECT_TRUE(
        cube::detail::collideAllPairs(s.view(), s.view(), true, &r, &Recorder<S>::fn, nullptr, k));
    EXPECT_EQ(r.calls, Pairs<S>(expected.begin(), expected.begin() + 5)) << name(k);
  }
}

TYPED_TEST(AllPairs, RefusesViewsBeyondTheLimit) {
  using S = TypeParam;
  const Slots<S> s(cube::detail::kAllPairsMax + 1, 3);
  Recorder<S> r;
  const Slots<S> small(8, 4);
  EXPECT_THROW(cube::detail::collideAllPairs(s.view(), s.view(), true, &r, &Recorder<S>::fn),
               std::logic_error);
  EXPECT_THROW(cube::detail::collideAllPairs(small.view(), s.view(), false, &r, &Recorder<S>::fn),
               std::logic_error);
  EXPECT_THROW(cube::detail::collideAllPairs(s.view(), small.view(), false, &r, &Recorder<S>::fn),
               std::logic_error);
  EXPECT_TRUE(r.calls.empty());
}

// Two small views against each other (a manager against another, both small): every kernel,
// every pair of sizes in a spread up to the limit, against brute force, in its order. The second
// view's awkward boxes are made against the first's: faces that touch exactly, gaps below float.
TYPED_TEST(AllPairs, TwoViewsEveryKernelEqualsBruteForce) {
  using S = TypeParam;
  std::size_t kernels_run = 0, pairs_seen = 0, apart = 0;
  for (PairKernel k : kKernels) {
    if (!cube::detail::pairKernelAvailable(k)) continue;
    ++kernels_run;
    for (std::size_t na : {0, 1, 5, 8, 9, 31, 64})
      for (std::size_t nb : {0, 1, 7, 16, 30, 33, 64})
        for (std::uint32_t seed = 1; seed <= 3; ++seed) {
          const Slots<S> a(na, seed * 7919 + std::uint32_t(na));
          const Slots<S> b(nb, seed * 104729 + std::uint32_t(nb), &a);
          const Pairs<S> expected = a.bruteForce(&b);
          Recorder<S> r;
          cube::QueryStats st;
          EXPECT_FALSE(cube::detail::collideAllPairs(a.view(), b.view(), false, &r,
                                                     &Recorder<S>::fn, &st, k));
          ASSERT_EQ(r.calls, expected)
              << name(k) << " na " << na << " nb " << nb << " seed " << seed;
          EXPECT_EQ(st.callbacks, expected.size());
          EXPECT_EQ(st.cubes_visited, 0u);
          pairs_seen += expected.size();
          // Stopping after the first pair.
          if (!expected.empty()) {
            Recorder<S> first;
            first.stop_after = 1;
            EXPECT_TRUE(cube::detail::collideAllPairs(a.view(), b.view(), false, &first,
                                                      &Recorder<S>::fn, nullptr, k));
            EXPECT_EQ(first.calls, Pairs<S>(expected.begin(), expected.begin() + 1)) << name(k);
          }
          // The same boxes moved far apart: nothing, and no box tested beyond the roots'.
          Slots<S> far(nb, seed * 104729 + std::uint32_t(nb), &a);
          for (Item<S>& it : far.items)
            for (int d = 0; d < 3; ++d) {
              it.box.lo[d] += S(1000);
              it.box.hi[d] += S(1000);
            }
          for (int d = 0; d < 3; ++d) {
            far.bounds.lo[d] += 1000.0f;
            far.bounds.hi[d] += 1000.0f;
          }
          if (a.bruteForce(&far).empty() && a.view().root == 0 && far.view().root == 0) {
            Recorder<S> none;
            cube::QueryStats fst;
            EXPECT_FALSE(cube::detail::collideAllPairs(a.view(), far.view(), false, &none,
                                                       &Recorder<S>::fn, &fst, k));
            EXPECT_TRUE(none.calls.empty());
            apart += fst.box_tests == 1;
          }
        }
  }
  EXPECT_GE(kernels_run, 2u);
  EXPECT_GT(pairs_seen, 1000u);
  EXPECT_GT(apart, 0u);  // the roots' test ended some calls at once
}

// The leaf kernels (detail::leafOverlapMask): every pair of runs of 1 to kMaskLeaf objects, self
// and not, against brute force over the exact boxes, for each kernel this CPU runs.
TYPED_TEST(AllPairs, LeafMasksEqualBruteForce) {
  using S = TypeParam;
  using cube::detail::kMaskLeaf;
  std::vector<PairKernel> kernels = {PairKernel::portable, PairKernel::best};
  if (cube::detail::pairKernelAvailable(PairKernel::avx2)) kernels.push_back(PairKernel::avx2);
  std::size_t hits_seen = 0, runs = 0;
  for (std::uint32_t seed = 1; seed <= 40; ++seed) {
    const Slots<S> s(3 * kMaskLeaf, seed);
    std::vector<Item<S>> live;  // leaves hold live objects only
    for (const Item<S>& it : s.items)
      if (it.obj != nullptr) live.push_back(it);
    ASSERT_GE(live.size(), 2 * kMaskLeaf);
    for (std::uint32_t nx = 1; nx <= kMaskLeaf; ++nx)
      for (std::uint32_t ny = 1; ny <= kMaskLeaf; ++ny)
        for (bool self : {false, true}) {
          if (self && nx != ny) continue;
          const Item<S>* xs = live.data();
          const Item<S>* ys = self ? xs : live.data() + live.size() - ny;
          std::uint64_t expected = 0;
          for (std::uint32_t i = 0; i < nx; ++i)
            for (std::uint32_t j = self ? i + 1 : 0; j < ny; ++j) {
              bool hit = true;
              for (int k = 0; k < 3; ++k)
                hit =
                    hit && xs[i].box.lo[k] <= ys[j].box.hi[k] && ys[j].box.lo[k] <= xs[i].box.hi[k];
              if (hit) expected |= std::uint64_t(1) << (kMaskLeaf * i + j);
            }
          for (PairKernel k : kernels)
            ASSERT_EQ(cube::detail::leafOverlapMask(xs, nx, ys, ny, self, k), expected)
                << name(k) << " seed " << seed << " nx " << nx << " ny " << ny << " self " << self;
          hits_seen += std::size_t(__builtin_popcountll(expected));
          ++runs;
        }
  }
  EXPECT_EQ(runs, 40u * (kMaskLeaf * kMaskLeaf + kMaskLeaf));
  EXPECT_GT(hits_seen, 2000u);  // the boxes overlap often enough for the comparison to mean much
  // Misuse is refused.
  const Slots<S> s(2, 1);
  EXPECT_THROW(cube::detail::leafOverlapMask(s.items.data(), kMaskLeaf + 1, s.items.data(), 1,
                                             false, PairKernel::portable),
               std::logic_error);
}

// Self-collide of a tree large enough for the walk to test its leaves on float columns (AVX2):
// the same pairs as brute force over the exact boxes, with exact touches, gaps float
// cannot see, and dead slots left by removals.
TYPED_TEST(AllPairs, LargeTreeSelfCollideEqualsBruteForce) {
  using S = TypeParam;
  std::size_t pairs_seen = 0;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    const Slots<S> s(700, 500 + seed);
    std::vector<Obj<S>*> objs;
    std::vector<Box<S>> boxes;
    for (const Item<S>& it : s.items) {
      if (it.obj == nullptr || !std::isfinite(it.box.lo[2]) || !std::isfinite(it.box.hi[0]))
        continue;  // unbounded boxes live outside the cubes
      objs.push_back(it.obj);
      boxes.push_back(it.box);
    }
    cube::detail::Broadphase<S> h{cube::Config()};
    h.addMany(objs.data(), boxes.data(), objs.size());
    // Every seventh object removed: its slot stays in the array, dead, until a rebuild.
    std::vector<std::pair<Obj<S>*, Box<S>>> kept;
    for (std::size_t i = 0; i < objs.size(); ++i) {
      if (i % 7 == 3)
        ASSERT_TRUE(h.remove(objs[i]));
      else
        kept.emplace_back(objs[i], boxes[i]);
    }
    std::string why;
    ASSERT_TRUE(h.validate(&why)) << why;
    ASSERT_GE(h.tree().view().slots, 256u);  // where the walk switches to columns
    Pairs<S> expected;
    for (std::size_t i = 0; i < kept.size(); ++i)
      for (std::size_t j = i + 1; j < kept.size(); ++j) {
        bool hit = true;
        for (int k = 0; k < 3; ++k)
          hit = hit && kept[i].second.lo[k] <= kept[j].second.hi[k] &&
                kept[j].second.lo[k] <= kept[i].second.hi[k];
        if (hit)
          expected.emplace_back(std::min(kept[i].first, kept[j].first),
                                std::max(kept[i].first, kept[j].first));
      }
    Recorder<S> r;
    EXPECT_FALSE(
        cube::detail::walkCubePairs(h.tree().view(), h.tree().view(), true, &r, &Recorder<S>::fn));
    for (auto& c : r.calls) c = {std::min(c.first, c.second), std::max(c.first, c.second)};
    std::sort(r.calls.begin(), r.calls.end());
    std::sort(expected.begin(), expected.end());
    ASSERT_EQ(r.calls, expected) << "seed " << seed;
    pairs_seen += expected.size();
    // A callback that stops the walk is obeyed there.
    Recorder<S> stop;
    stop.stop_after = 3;
    EXPECT_TRUE(cube::detail::walkCubePairs(h.tree().view(), h.tree().view(), true, &stop,
                                            &Recorder<S>::fn));
    EXPECT_EQ(stop.calls.size(), 3u);
  }
  EXPECT_GT(pairs_seen, 1000u);
}

// roundOut works on whole boxes with SIMD; its result must be floatBelow's bit for bit (lo) and
// its mirror image (hi), and contain the box.
// Column stores small and large (from kHugeColumnBytes on they come from another allocation):
// each column 32-byte aligned, its padding zeroed, every entry of every column its own.
TEST(ColumnStores, AreAlignedPaddedAndApartAtEverySize) {
  using cube::detail::ColumnStore;
  const std::uint32_t huge =
      std::uint32_t(cube::detail::kHugeColumnBytes / (6 * sizeof(float))) + 5;
  for (const std::uint32_t n : {1u, 300u, 4099u, huge}) {
    const ColumnStore store(n);
    const cube::detail::Columns& c = store.columns();
    for (int k = 0; k < 6; ++k) {
      ASSERT_EQ(reinterpret_cast<std::uintptr_t>(c.col[k]) % 32, 0u) << n;
      for (std::uint32_t i = n; i < n + cube::detail::kMaskLeaf; ++i)
        ASSERT_EQ(c.col[k][i], 0.0f) << n << " " << i;
    }
    for (std::uint32_t i : {0u, n / 2, n - 1})
      for (int k = 0; k < 6; ++k) c.col[k][i] = float(k + 1);
    for (std::uint32_t i : {0u, n / 2, n - 1})
      for (int k = 0; k < 6; ++k) ASSERT_EQ(c.col[k][i], float(k + 1)) << n << " " << i;
  }
}

TEST(RoundOut, EqualsTheScalarRoundingAndContainsTheBox) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> exponent(-140, 140);
  const double special[] = {0.0,
                            -0.0,
                            1e-45,
                            double(std::numeric_limits<float>::max()),
                            -double(std::numeric_limits<float>::max()),
                            1e39,
                            -1e300,
                            std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity()};
  std::size_t checked = 0;
  for (int rep = 0; rep < 20000; ++rep) {
    Box<double> b;
    for (int k = 0; k < 3; ++k) {
      double x = std::ldexp(unit(rng), exponent(rng));
      double y = std::ldexp(unit(rng), exponent(rng));
      if (rep % 7 == 0) x = special[std::size_t(rep / 7 + k) % std::size(special)];
      if (x > y) std::swap(x, y);
      b.lo[k] = x;
      b.hi[k] = y;
    }
    float lo[3], hi[3];
    cube::detail::roundOut(b, lo, hi);
    for (int k = 0; k < 3; ++k) {
      const float want_lo = cube::detail::floatBelow(b.lo[k]);
      const float want_hi = -cube::detail::floatBelow(-b.hi[k]);
      ASSERT_EQ(std::memcmp(&lo[k], &want_lo, sizeof(float)), 0) << b.lo[k];
      ASSERT_EQ(std::memcmp(&hi[k], &want_hi, sizeof(float)), 0) << b.hi[k];
      EXPECT_LE(double(lo[k]), b.lo[k]);
      EXPECT_GE(double(hi[k]), b.hi[k]);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 60000u);
}

#if defined(__SSE2__)
// Every SSE2 per-box operation gives the portable one's result bit for bit (a union's zero may
// differ in sign only, which roundOut maps to the same bound), on boxes with touching faces,
// infinities, signed zeros and sizes from 1e-30 to 1e30.
TEST(BoxOps, Sse2EqualsPortableBitForBit) {
  namespace pt = cube::detail::portable;
  namespace s2 = cube::detail::sse2;
  using cube::detail::BuildRecord;
  using cube::detail::Node;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::uniform_int_distribution<int> exponent(-100, 100);
  const double inf = std::numeric_limits<double>::infinity();
  const double special[] = {0.0, -0.0, inf, -inf, 1e39, -1e39, 1.0, -1.0};
  auto coordinate = [&]() {
    if (rng() % 6 == 0) return special[rng() % std::size(special)];
    return std::ldexp(unit(rng), exponent(rng) % 100);
  };
  auto randomBox = [&]() {
    Box<double> b;
    for (int k = 0; k < 3; ++k) {
      double x = coordinate(), y = coordinate();
      if (x > y) std::swap(x, y);
      b.lo[k] = x;
      b.hi[k] = y;
    }
    return b;
  };
  auto bits = [](auto x) {
    std::uint64_t u = 0;
    std::memcpy(&u, &x, sizeof x);
    return u;
  };
  auto toFloat = [](const Box<double>& b) {
    Box<float> f;
    for (int k = 0; k < 3; ++k) {
      f.lo[k] = static_cast<float>(b.lo[k]);
      f.hi[k] = static_cast<float>(b.hi[k]);
    }
    return f;
  };
  auto nodeOf = [](const Box<double>& b) {
    Node n{};
    pt::roundOut(b, n.lo, n.hi);
    return n;
  };
  std::size_t overlaps = 0, gaps = 0;
  for (int rep = 0; rep < 20000; ++rep) {
    const Box<double> a = randomBox();
    Box<double> b = randomBox();
    if (rep % 5 == 0) {  // touching faces along one axis
      const int k = rep / 5 % 3;
      b.lo[k] = a.hi[k];
      b.hi[k] = std::max(b.hi[k], b.lo[k]);
    }
    const Node na = nodeOf(a), nb = nodeOf(b);
    ASSERT_EQ(s2::overlap(a, b), pt::overlap(a, b)) << rep;
    // A box prepared for an object query's leaves (FixedBox) tests as overlap does.
    ASSERT_EQ(s2::FixedBox<double>(b).overlaps(a), pt::overlap(a, b)) << rep;
    ASSERT_EQ(s2::FixedBox<double>(a).overlaps(b), pt::overlap(b, a)) << rep;
    ASSERT_EQ(pt::FixedBox<double>(b).overlaps(a), pt::overlap(a, b)) << rep;
    // And in float, the boxes rounded to nearest (touching faces stay touching).
    const Box<float> fa = toFloat(a), fb = toFloat(b);
    ASSERT_EQ(s2::FixedBox<float>(fb).overlaps(fa), pt::overlap(fa, fb)) << rep;
    ASSERT_EQ(s2::FixedBox<float>(fa).overlaps(fb), pt::overlap(fb, fa)) << rep;
    ASSERT_EQ(bits(s2::boxGap2(fa, fb)), bits(pt::boxGap2(fa, fb))) << rep;
    ASSERT_EQ(s2::overlap(na, nb), pt::overlap(na, nb)) << rep;
    ASSERT_EQ(bits(s2::boxGap2(a, b)), bits(pt::boxGap2(a, b))) << rep;
    ASSERT_EQ(bits(s2::cubeGap2(na, nb)), bits(pt::cubeGap2(na, nb))) << rep;
    ASSERT_TRUE(s2::sameBox(a, a) && pt::sameBox(a, a));
    ASSERT_EQ(s2::sameBox(a, b), pt::sameBox(a, b)) << rep;
    ASSERT_EQ(s2::sameBounds(na, nb), pt::sameBounds(na, nb)) << rep;
    ASSERT_TRUE(s2::sameBounds(na, na));
    overlaps += pt::overlap(a, b);
    gaps += pt::boxGap2(a, b) > 0;
    float lo[2][3], hi[2][3];
    s2::roundOut(a, lo[0], hi[0]);
    pt::roundOut(a, lo[1], hi[1]);
    ASSERT_EQ(std::memcmp(lo[0], lo[1], sizeof lo[0]), 0) << rep;
    ASSERT_EQ(std::memcmp(hi[0], hi[1], sizeof hi[0]), 0) << rep;
    // Unions of items, of cubes and of build records, compared through their float bounds.
    Item<double> items[3] = {{a, nullptr, 0, 0}, {b, nullptr, 0, 1}, {randomBox(), nullptr, 0, 2}};
    Box<double> u[2];
    s2::unionOfItems(items, 0, 3, u[0]);
    pt::unionOfItems(items, 0, 3, u[1]);
    Node un[2] = {Node{}, Node{}};
    for (int i = 0; i < 2; ++i) pt::roundOut(u[i], un[i].lo, un[i].hi);
    ASSERT_TRUE(pt::sameBounds(un[0], un[1])) << rep;
    Node c[2] = {Node{}, Node{}};
    c[0].first = c[1].first = 7;
    s2::unionOfCubes(c[0], na, nb);
    pt::unionOfCubes(c[1], na, nb);
    ASSERT_TRUE(pt::sameBounds(c[0], c[1])) << rep;
    ASSERT_EQ(c[0].first, 7u);  // first/count untouched
    BuildRecord r[2];
    for (int i = 0; i < 2; ++i) pt::roundOut(i ? b : a, r[i].lo, r[i].hi);
    s2::unionOfRecords(r, r + 2, c[0]);
    pt::unionOfRecords(r, r + 2, c[1]);
    ASSERT_TRUE(pt::sameBounds(c[0], c[1])) << rep;
  }
  EXPECT_GT(overlaps, 1000u);  // both outcomes are common enough to mean something
  EXPECT_GT(gaps, 1000u);
}
#endif

}  // namespace
