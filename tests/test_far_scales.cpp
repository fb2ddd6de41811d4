// Scenes at the far ends of the range: validate() and its running total of cube areas over
// scenes spanning 1e-6 to 1e9, and distances beyond the range of float with a raised
// Config::unbounded_limit.
//
// Oracles: fcl::NaiveCollisionManager and fcl::distance (support/oracle.h).

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/distance.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cube_collision/callbacks.h"
#include "cube_collision/config.h"
#include "cube_collision/cube_collision_manager.h"
#include "support/oracle.h"
#include "support/reentrancy_world.h"

namespace {

using namespace reentrancy;

// ------------------------------------------------------------------------------------------------
// validate() over scenes spanning 1e-6 to 1e9.
// ------------------------------------------------------------------------------------------------

template <typename T>
std::unique_ptr<ReObj<T>> reBoxAt(T size, T x, T y, T z) {
  auto o = std::make_unique<ReObj<T>>(std::make_shared<fcl::Box<T>>(size, size, size));
  o->setTranslation(fcl::Vector3<T>(x, y, z));
  o->computeAABB();
  return o;
}

// The reported case: small boxes registered one by one, one box far away (its centre at
// `far_at`), the far one unregistered: validate() said "tracked area 16.4 differs from 16.4" for
// a far box of size 100 at x = 1e9 (the running total lost the small cubes' area to
// cancellation). Then the same away along each axis, with setup() and update() in between.
template <typename T>
void reFarOneRemoved(const cube::Config& config, const fcl::Vector3<T>& far_at, T far_size) {
  std::vector<std::unique_ptr<ReObj<T>>> owned;
  std::vector<ReObj<T>*> small;
  for (int i = 0; i < 3; ++i) {
    owned.push_back(reBoxAt<T>(1, T(i), T(0.3 * (i % 2)), 0));
    small.push_back(owned.back().get());
  }
  owned.push_back(reBoxAt<T>(far_size, far_at[0], far_at[1], far_at[2]));
  ReObj<T>* far_one = owned.back().get();
  ReManager<T> m(config);
  std::string why;
  for (auto* o : small) {
    m.registerObject(o);
    ASSERT_TRUE(m.validate(&why)) << why;
  }
  m.registerObject(far_one);
  ASSERT_TRUE(m.validate(&why)) << "after registering the far box: " << why;
  m.unregisterObject(far_one);
  ASSERT_TRUE(m.validate(&why)) << "after unregistering the far box: " << why;
  EXPECT_EQ(reObjectsOf<T>(m), small);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(small));
  for (int axis = 0; axis < 3; ++axis) {
    fcl::Vector3<T> p(0, 0, 0);
    p[axis] = T(-1e9);
    far_one->setTranslation(p);
    far_one->computeAABB();
    m.setup();
    m.registerObject(far_one);
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ": " << why;
    m.update();
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ", after update(): " << why;
    m.unregisterObject(far_one);
    ASSERT_TRUE(m.validate(&why)) << "axis " << axis << ", after unregistering: " << why;
  }
  EXPECT_EQ(reObjectsOf<T>(m), small);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(small));
}

TEST(ReValidateArea, FarBoxRegisteredThenUnregistered) {
  cube::Config refit;
  refit.update_policy = cube::UpdatePolicy::refit;
  for (const cube::Config& config : {cube::Config(), refit}) {
    SCOPED_TRACE(config.update_policy == cube::UpdatePolicy::refit ? "refit" : "automatic");
    {
      SCOPED_TRACE("double, far box of size 100 at x = 1e9 (the reported case)");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 100);
    }
    {
      SCOPED_TRACE("double, far box of size 1 at x = 1e9");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 1);
    }
    {
      SCOPED_TRACE("double, far box of size 1 at (1e9, 1e9, 1e9)");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 1e9, 1e9), 1);
    }
    {
      SCOPED_TRACE("double, far box of size 1e9 at x = 1e9");
      reFarOneRemoved<S>(config, fcl::Vector3<S>(1e9, 0, 0), 1e9);
    }
    {
      SCOPED_TRACE("float, far box of size 100 at x = 1e9");
      reFarOneRemoved<float>(config, fcl::Vector3<float>(1e9f, 0, 0), 100);
    }
    {
      SCOPED_TRACE("float, far box of size 1 at (1e9, 1e9, 1e9)");
      reFarOneRemoved<float>(config, fcl::Vector3<float>(1e9f, 1e9f, 1e9f), 1);
    }
  }
}

// A random sequence of mutations over objects from 1e-6 to 1e9 in size and position, moving
// between near the origin and 1e9 away; validate() after every mutation.
template <typename T>
void reRandomFarNear(std::uint32_t seed, const cube::Config& config) {
  using Obj = ReObj<T>;
  std::mt19937 rng(seed);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  auto logUniform = [&](double lo, double hi) {
    return std::exp(uniform(std::log(lo), std::log(hi)));
  };
  const int kPool = 48;
  std::vector<std::unique_ptr<Obj>> pool;
  std::vector<bool> is_far(kPool, false);
  auto place = [&](int i, bool far) {
    fcl::Vector3<T> p;
    for (int k = 0; k < 3; ++k)
      p[k] = T(far ? (rng() % 2 ? 1.0 : -1.0) * 1e9 * uniform(0.5, 1.0)
                   : uniform(-1.0, 1.0) * logUniform(1e-6, 1.0));
    pool[i]->setTranslation(p);
    pool[i]->computeAABB();
    is_far[i] = far;
  };
  for (int i = 0; i < kPool; ++i) {
    const double r = uniform(0, 1);
    const double size = r < 0.7   ? logUniform(1e-6, 1)
                        : r < 0.9 ? logUniform(1, 1e3)
                                  : logUniform(1e6, 1e9);
    pool.push_back(std::make_unique<Obj>(std::make_shared<fcl::Box<T>>(T(size), T(size), T(size))));
    place(i, uniform(0, 1) < 0.2);
  }
  ReManager<T> m(config);
  std::vector<Obj*> reg;  // getObjects() order
  auto registered = [&](Obj* o) { return std::find(reg.begin(), reg.end(), o) != reg.end(); };
  auto indexOf = [&](Obj* o) {
    int i = 0;
    while (pool[i].get() != o) ++i;
    return i;
  };
  auto pickRegistered = [&]() { return reg[rng() % reg.size()]; };
  auto pickFree = [&]() -> Obj* {
    std::vector<Obj*> free;
    for (auto& p : pool)
      if (!registered(p.get())) free.push_back(p.get());
    return free.empty() ? nullptr : free[rng() % free.size()];
  };
  auto flip = [&](Obj* o) {
    const int i = indexOf(o);
    place(i, !is_far[i]);
  };
  const char* names[] = {"registerObject", "registerObjects", "unregisterObject",
                         "update(obj)",    "update()",        "update(vector)",
                         "setup"};
  std::discrete_distribution<int> op_of({20, 5, 20, 25, 10, 10, 10});
  std::string why;
  for (int step = 0; step < 1500; ++step) {
    int op = op_of(rng);
    if (reg.size() < 3) op = 0;
    if (op == 0) {
      if (Obj* o = pickFree()) {
        m.registerObject(o);
        reg.push_back(o);
      }
    } else if (op == 1) {
      std::vector<Obj*> batch;
      for (int k = 0; k < 3; ++k)
        if (Obj* o = pickFree())
          if (std::find(batch.begin(), batch.end(), o) == batch.end()) batch.push_back(o);
      m.registerObjects(batch);
      reg.insert(reg.end(), batch.begin(), batch.end());
    } else if (op == 2) {
      Obj* o = pickRegistered();
      m.unregisterObject(o);
      reg.erase(std::find(reg.begin(), reg.end(), o));
    } else if (op == 3) {
      Obj* o = pickRegistered();
      flip(o);
      m.update(o);
    } else if (op == 4 || op == 5) {
      std::vector<Obj*> moved;
      for (int k = 1 + int(rng() % 3); k > 0; --k) {
        Obj* o = pickRegistered();
        if (std::find(moved.begin(), moved.end(), o) != moved.end()) continue;
        flip(o);
        moved.push_back(o);
      }
      if (op == 4)
        m.update();
      else
        m.update(moved);
    } else {
      m.setup();
    }
    ASSERT_TRUE(m.validate(&why)) << "step " << step << " (" << names[op] << ", " << reg.size()
                                  << " objects): " << why;
    if (step % 100 == 99) {
      ASSERT_EQ(reObjectsOf<T>(m), reg) << "step " << step;
      ASSERT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(reg)) << "step " << step;
    }
  }
  EXPECT_EQ(reObjectsOf<T>(m), reg);
  EXPECT_EQ(cube::oracle::selfPairs(m), cube::oracle::bruteSelfPairs(reg));
  auto naive = cube::oracle::naiveOf(reg);
  EXPECT_EQ(cube::oracle::selfPairs(naive), cube::oracle::bruteSelfPairs(reg));
}

TEST(ReValidateArea, RandomMutationsAcrossFifteenDecades) {
  cube::Config refit, pairs;
  refit.update_policy = cube::UpdatePolicy::refit;
  pairs.keep_pairs = true;
  const std::pair<const char*, cube::Config> configs[] = {
      {"default", cube::Config()}, {"refit", refit}, {"keep_pairs=true", pairs}};
  for (const auto& [name, config] : configs) {
    for (std::uint32_t seed : {21u, 2021u}) {
      SCOPED_TRACE(std::string(name) + ", seed " + std::to_string(seed));
      {
        SCOPED_TRACE("double");
        reRandomFarNear<S>(seed, config);
      }
      {
        SCOPED_TRACE("float");
        reRandomFarNear<float>(seed, config);
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Distances beyond float range (Config::unbounded_limit raised to 1e30).
// ------------------------------------------------------------------------------------------------

using ReDistObj = ReObj<S>;

// cube::defaultDistanceCallback, counting its calls.
struct ReCounted {
  cube::DistanceData<S> data;
  int calls = 0;
  static bool fn(ReDistObj* a, ReDistObj* b, void* d, S& dist) {
    auto* c = static_cast<ReCounted*>(d);
    ++c->calls;
    return cube::defaultDistanceCallback<S>(a, b, &c->data, dist);
  }
};

// leaf_size 1 puts every object in a leaf of its own, so that even two objects are reached
// through a cube against cube distance.
cube::Config reFarConfig(double limit = 1e30, int leaf_size = 8) {
  cube::Config c;
  c.unbounded_limit = limit;
  c.leaf_size = leaf_size;
  return c;
}

std::unique_ptr<ReDistObj> reSphereAt(S r, S x, S y, S z) {
  auto o = std::make_unique<ReDistObj>(std::make_shared<fcl::Sphere<S>>(r));
  o->setTranslation(fcl::Vector3<S>(x, y, z));
  o->computeAABB();
  return o;
}

// Minimum distance of a self distance query: (cube manager with defaultDistanceCallback and its
// call count, Naive with fcl::DefaultDistanceFunction), both also with the oracle's canonical
// narrowDistance.
struct ReMinDistances {
  S cube = 0, naive = 0, cube_canonical = 0, naive_canonical = 0;
  int cube_calls = 0;
};

ReMinDistances reSelfDistances(const ReManager<S>& m, const std::vector<ReDistObj*>& objs) {
  ReMinDistances r;
  ReCounted counted;
  m.distance(&counted, &ReCounted::fn);
  r.cube = counted.data.result.min_distance;
  r.cube_calls = counted.calls;
  auto naive = cube::oracle::naiveOf(objs);
  fcl::DefaultDistanceData<S> nd;
  naive.distance(&nd, fcl::DefaultDistanceFunction<S>);
  r.naive = nd.result.min_distance;
  r.cube_canonical = r.naive_canonical = std::numeric_limits<S>::max();
  m.distance(&r.cube_canonical, cube::oracle::narrowDistance<S>);
  naive.distance(&r.naive_canonical, cube::oracle::narrowDistance<S>);
  return r;
}

ReMinDistances reObjectDistances(const ReManager<S>& m, const std::vector<ReDistObj*>& objs,
                                 ReDistObj* q) {
  ReMinDistances r;
  ReCounted counted;
  m.distance(q, &counted, &ReCounted::fn);
  r.cube = counted.data.result.min_distance;
  r.cube_calls = counted.calls;
  auto naive = cube::oracle::naiveOf(objs);
  fcl::DefaultDistanceData<S> nd;
  naive.distance(q, &nd, fcl::DefaultDistanceFunction<S>);
  r.naive = nd.result.min_distance;
  r.cube_canonical = r.naive_canonical = std::numeric_limits<S>::max();
  m.distance(q, &r.cube_canonical, cube::oracle::narrowDistance<S>);
  naive.distance(q, &r.naive_canonical, cube::oracle::narrowDistance<S>);
  return r;
}

void reExpectSame(const ReMinDistances& r, S exact = -1) {
  const S tol = 1e-9 * std::abs(r.naive);
  EXPECT_GE(r.cube_calls, 1) << "the callback was never called";
  EXPECT_NEAR(r.cube, r.naive, tol)
      << "cube::defaultDistanceCallback vs fcl::DefaultDistanceFunction";
  EXPECT_NEAR(r.cube_canonical, r.naive_canonical, tol) << "oracle::narrowDistance";
  if (exact >= 0) {
    EXPECT_NEAR(r.naive, exact, 1e-9 * exact) << "Naive against the exact value";
  }
}

std::string reNum(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

TEST(ReFarDistance, TwoSpheresFarApart) {
  for (int leaf_size : {8, 1})
    for (S far : {1e20, 1e25}) {
      for (bool diagonal : {false, true}) {
        SCOPED_TRACE("apart by " + reNum(far) + (diagonal ? " on each axis" : " along x") +
                     ", leaf_size " + std::to_string(leaf_size));
        auto a = reSphereAt(0.5, 0, 0, 0);
        auto b = diagonal ? reSphereAt(0.5, far, far, far) : reSphereAt(0.5, far, 0, 0);
        ReManager<S> m(reFarConfig(1e30, leaf_size));
        m.registerObjects({a.get(), b.get()});
        std::string why;
        ASSERT_TRUE(m.validate(&why)) << why;
        {
          SCOPED_TRACE("self distance of the two");
          reExpectSame(reSelfDistances(m, {a.get(), b.get()}),
                       (diagonal ? std::sqrt(3.0) : 1) * far - 1);
        }
        // A query object as far again from the nearest one.
        auto q = reSphereAt(0.5, -far, 0, 0);
        ReManager<S> one(reFarConfig(1e30, leaf_size));
        one.registerObject(a.get());
        {
          SCOPED_TRACE("distance(query) with one object registered");
          reExpectSame(reObjectDistances(one, {a.get()}, q.get()), far - 1);
        }
        {
          SCOPED_TRACE("distance(query) with both registered");
          reExpectSame(reObjectDistances(m, {a.get(), b.get()}, q.get()), far - 1);
        }
      }
    }
}

// A scattered scene: a grid 1e20 apart, objects anywhere within 1e25, query objects among them;
// self distance, distance(obj) and distance(&other cube manager) against Naive. With the default
// unbounded_limit (1e15) as well, where every such object is in the unbounded list.
TEST(ReFarDistance, ScatteredSceneMatchesNaive) {
  for (double limit : {1e30, 1e15})
    for (int leaf_size : {8, 1}) {
      SCOPED_TRACE("unbounded_limit " + reNum(limit) + ", leaf_size " + std::to_string(leaf_size));
      std::mt19937 rng(21);
      std::uniform_real_distribution<double> coord(-1e25, 1e25), radius(1, 1e3);
      std::vector<std::unique_ptr<ReDistObj>> owned;
      std::vector<ReDistObj*> objs, others, queries;
      auto add = [&](std::vector<ReDistObj*>& to, std::unique_ptr<ReDistObj> o) {
        owned.push_back(std::move(o));
        to.push_back(owned.back().get());
      };
      for (int i = 0; i < 40; ++i)  // a 4 x 10 grid 1e20 apart, at 3e24 along x
        add(objs, reSphereAt(radius(rng), 3e24 + 1e20 * (i % 10), 1e20 * (i / 10), 0));
      for (int i = 0; i < 60; ++i) {
        const S r = radius(rng);
        const S x = coord(rng), y = coord(rng), z = coord(rng);
        if (i % 2)
          add(objs, reSphereAt(r, x, y, z));
        else
          add(objs, [&] {
            auto o = std::make_unique<ReDistObj>(std::make_shared<fcl::Box<S>>(r, 2 * r, r));
            o->setTranslation(fcl::Vector3<S>(x, y, z));
            o->computeAABB();
            return o;
          }());
      }
      for (int i = 0; i < 20; ++i) add(others, reSphereAt(radius(rng), coord(rng), coord(rng), 0));
      for (int i = 0; i < 6; ++i)
        add(queries, reSphereAt(radius(rng), coord(rng), coord(rng), coord(rng)));
      add(queries, reSphereAt(1, 3e24 + 4.5e20, 5e19, 0));  // amid the grid: nearest ~5e19 away

      ReManager<S> m(reFarConfig(limit, leaf_size)), other(reFarConfig(limit, leaf_size));
      m.registerObjects(objs);
      other.registerObjects(others);
      std::string why;
      ASSERT_TRUE(m.validate(&why)) << why;
      {
        SCOPED_TRACE("self distance");
        reExpectSame(reSelfDistances(m, objs));
      }
      for (std::size_t i = 0; i < queries.size(); ++i) {
        SCOPED_TRACE("distance(query #" + std::to_string(i) + ")");
        reExpectSame(reObjectDistances(m, objs, queries[i]));
      }
      {
        SCOPED_TRACE("distance(&other)");
        ReCounted counted;
        m.distance(&other, &counted, &ReCounted::fn);
        auto naive = cube::oracle::naiveOf(objs);
        auto naive_other = cube::oracle::naiveOf(others);
        fcl::DefaultDistanceData<S> nd;
        naive.distance(&naive_other, &nd, fcl::DefaultDistanceFunction<S>);
        EXPECT_GE(counted.calls, 1);
        EXPECT_NEAR(counted.data.result.min_distance, nd.result.min_distance,
                    1e-9 * nd.result.min_distance);
      }
    }
}

}  // namespace
