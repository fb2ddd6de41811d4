#pragma once

// Randomized differential testing of CubeCollisionManager: random operation sequences over a
// small pool of objects, every step checked against a brute-force model of what the manager
// holds (the AABBs it cached at register/update time) and, when those equal the live AABBs,
// against fcl::NaiveCollisionManager's narrow-phase results. Shared by the ctest
// (test_differential.cpp, choices from a seeded PRNG) and the libFuzzer target (choices from the
// input bytes), so any fuzzer finding replays as an ordinary test.

#include <fcl/broadphase/broadphase_bruteforce.h>
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/halfspace.h>
#include <fcl/geometry/shape/plane.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "adapter/manager_access.h"
#include "core/broadphase.h"
#include "cube_collision/cube_collision_manager.h"
#include "oracle.h"

namespace cube {
namespace diff {

using S = double;
using Object = fcl::CollisionObject<S>;
using AABB = fcl::AABB<S>;
using Manager = fcl::BroadPhaseCollisionManager<S>;
using Pair = std::pair<Object*, Object*>;

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

inline bool overlap(const AABB& a, const AABB& b) {
  return a.overlap(b);
}

inline bool sameBox(const AABB& a, const AABB& b) {
  for (int k = 0; k < 3; ++k)
    if (!(a.min_[k] == b.min_[k] && a.max_[k] == b.max_[k])) return false;
  return true;
}

inline Pair unordered(Object* a, Object* b) {
  return a < b ? Pair(a, b) : Pair(b, a);
}

/// One random sequence: owns the pool, the manager under test and the model.
class Runner {
 public:
  /// `pool` objects (1..64) of a scene family; `planes` mixes planes and halfspaces in.
  Runner(Source& src, const Config& config, Scene scene, int pool, bool planes)
      : src_(src), config_(config), scene_(scene), mgr_(config) {
    scale_ = scene == Scene::huge ? 1e6 : scene == Scene::tiny ? 1e-6 : 1.0;
    for (int i = 0; i < pool; ++i) pool_.push_back(makeObject(planes && src_.pick(6) == 0));
    trace_ << "scene " << sceneName(scene) << " pool " << pool << " planes " << planes << " config "
           << describe(config) << "\n";
  }

  /// Runs up to `steps` operations (fewer if a byte source runs dry); returns "" or what went
  /// wrong, with the trace of the operations so far.
  std::string run(int steps) {
    for (int i = 0; i < steps && !src_.done(); ++i) {
      std::string err = step();
      if (err.empty()) err = checkAll();
      if (!err.empty()) return err + "\n--- trace ---\n" + trace_.str();
    }
    return "";
  }

  /// Only for the fuzzer, while the lead fixes a reported bug: validate() failures whose
  /// message contains `text` are not reported (so the fuzzer can look for other bugs).
  void tolerateKnownBug(const std::string& text) { known_ = text; }

  std::size_t stepsRun() const { return steps_; }
  std::size_t checksRun() const { return checks_; }
  std::size_t narrowChecksRun() const { return narrow_checks_; }

 private:
  // ---- the pool ---------------------------------------------------------------------------

  double coord() {
    switch (scene_) {
      case Scene::one_point:
      case Scene::identical:
        return 0;
      case Scene::zero_size:
        return double(int(src_.pick(5)) - 2);  // a small grid: many coincident points
      default:
        return scale_ * (src_.unit() * 20 - 10);
    }
  }

  void setPose(Object* o) {
    fcl::Vector3<S> t(coord(), coord(), coord());
    if (scene_ == Scene::line) t[1] = t[2] = 0;
    fcl::Matrix3<S> r = fcl::Matrix3<S>::Identity();
    if (scene_ == Scene::identical) {
      // Two poses only, so that most objects are exactly alike.
      if (src_.pick(2)) r = Eigen::AngleAxis<S>(0.5, fcl::Vector3<S>::UnitZ()).toRotationMatrix();
    } else if (src_.pick(2)) {
      fcl::Vector3<S> axis(src_.unit() - 0.5, src_.unit() - 0.5, src_.unit() + 0.1);
      r = Eigen::AngleAxis<S>(src_.unit() * 6.28, axis.normalized()).toRotationMatrix();
    }
    o->setTransform(r, t);
    o->computeAABB();
  }

  std::shared_ptr<fcl::CollisionGeometry<S>> geometry(bool plane) {
    if (plane) {
      fcl::Vector3<S> n = fcl::Vector3<S>::Unit(int(src_.pick(3)));
      if (src_.pick(2)) n = fcl::Vector3<S>(src_.unit() - 0.5, src_.unit() - 0.5, 1).normalized();
      const S d = scale_ * (src_.unit() * 10 - 5);
      if (src_.pick(2)) return std::make_shared<fcl::Plane<S>>(n, d);
      return std::make_shared<fcl::Halfspace<S>>(n, d);
    }
    if (scene_ == Scene::identical) {
      if (!shared_) shared_ = std::make_shared<fcl::Box<S>>(1, 2, 3);
      return shared_;
    }
    if (scene_ == Scene::zero_size) return std::make_shared<fcl::Box<S>>(0, 0, 0);
    const S a = scale_ * (0.5 + 3 * src_.unit());
    switch (src_.pick(3)) {
      case 0:
        return std::make_shared<fcl::Box<S>>(a, a * 0.7, a * 1.3);
      case 1:
        return std::make_shared<fcl::Sphere<S>>(a * 0.5);
      default:
        return std::make_shared<fcl::Cylinder<S>>(a * 0.4, a);
    }
  }

  std::unique_ptr<Object> makeObject(bool plane) {
    auto o = std::make_unique<Object>(geometry(plane));
    setPose(o.get());
    return o;
  }

  Object* anyObject() { return pool_[src_.pick(std::uint32_t(pool_.size()))].get(); }
  bool registered(const Object* o) const { return cached_.count(o) != 0; }
  int indexOf(const Object* o) const {
    return int(std::find(order_.begin(), order_.end(), o) - order_.begin());
  }
  std::string name(const Object* o) const {
    for (std::size_t i = 0; i < pool_.size(); ++i)
      if (pool_[i].get() == o) return "p" + std::to_string(i);
    return "?";
  }

  // ---- the model --------------------------------------------------------------------------

  void modelRegister(Object* o) {
    if (registered(o)) return;
    cached_[o] = o->getAABB();
    order_.push_back(o);
  }
  void modelUnregister(Object* o) {
    if (!registered(o)) return;
    cached_.erase(o);
    order_.erase(std::find(order_.begin(), order_.end(), o));
  }
  void modelRead(Object* o) {
    if (registered(o)) cached_[o] = o->getAABB();
  }
  bool inSync() const {
    for (const auto& c : cached_)
      if (!sameBox(c.second, c.first->getAABB())) return false;
    return true;
  }

  // ---- operations -------------------------------------------------------------------------

  std::vector<Object*> someObjects(std::uint32_t max_count) {
    std::vector<Object*> out(src_.pick(max_count + 1));
    for (auto& o : out) o = anyObject();
    return out;
  }

  std::string step() {
    ++steps_;
    const std::uint32_t op = src_.pick(16);
    switch (op) {
      case 0:
      case 1: {
        Object* o = anyObject();
        trace_ << "registerObject " << name(o) << "\n";
        mgr_.registerObject(o);
        modelRegister(o);
        return "";
      }
      case 2: {
        const auto batch = someObjects(std::uint32_t(pool_.size()));
        trace_ << "registerObjects";
        for (auto* o : batch) trace_ << " " << name(o);
        trace_ << "\n";
        mgr_.registerObjects(batch);
        for (auto* o : batch) modelRegister(o);
        return "";
      }
      case 3:
      case 4: {
        Object* o = anyObject();
        trace_ << "unregisterObject " << name(o) << "\n";
        mgr_.unregisterObject(o);
        modelUnregister(o);
        return "";
      }
      case 5:
      case 6:
      case 7: {
        // Move some objects, then one of the update variants (update(obj) per object, the
        // vector form with unknown objects and repeats mixed in, or update()).
        const auto moved = someObjects(4);
        for (auto* o : moved) setPose(o);
        const std::uint32_t how = src_.pick(3);
        trace_ << "move";
        for (auto* o : moved) trace_ << " " << name(o);
        trace_ << (how == 0   ? " + update(obj) each\n"
                   : how == 1 ? " + update(vec)\n"
                              : " + update()\n");
        if (how == 0) {
          for (auto* o : moved) mgr_.update(o), modelRead(o);
        } else if (how == 1) {
          mgr_.update(moved);
          for (auto* o : moved) modelRead(o);
        } else {
          mgr_.update();
          for (auto& c : cached_) c.second = c.first->getAABB();
        }
        return "";
      }
      case 8: {
        // Moves the manager is not told about: it must keep using the AABBs it cached.
        const auto moved = someObjects(3);
        trace_ << "move without update";
        for (auto* o : moved) trace_ << " " << name(o), setPose(o);
        trace_ << "\n";
        return "";
      }
      case 9:
        if (src_.pick(4) == 0) {
          trace_ << "clear\n";
          mgr_.clear();
          cached_.clear();
          order_.clear();
        } else {
          trace_ << "setup\n";
          mgr_.setup();
        }
        return "";
      case 10:
        return nanOp();
      case 11:
        return stopOp();
      case 12:
        return throwOp();
      default:
        return otherManagerOp();
    }
  }

  // An object gets a NaN AABB: registering it or updating it must throw and change nothing for
  // it, while every other object of the same update is updated.
  std::string nanOp() {
    Object* o = anyObject();
    const fcl::Transform3<S> keep = o->getTransform();
    const std::uint32_t how = src_.pick(5);
    auto others = someObjects(3);
    others.erase(std::remove(others.begin(), others.end(), o), others.end());
    for (auto* x : others) setPose(x);
    o->setTranslation(fcl::Vector3<S>(std::nan(""), 0, 0));
    o->computeAABB();
    trace_ << "NaN " << name(o) << " via " << how << " moving";
    for (auto* x : others) trace_ << " " << name(x);
    trace_ << "\n";
    const bool was = registered(o);
    std::string expect;  // the text the message must contain
    bool thrown = false;
    std::string what;
    try {
      switch (how) {
        case 0:
          expect = "object #" + std::to_string(order_.size());
          mgr_.registerObject(o);
          break;
        case 1: {
          std::vector<Object*> batch = others;
          const std::size_t at = src_.pick(std::uint32_t(batch.size() + 1));
          batch.insert(batch.begin() + at, o);
          expect = "entry #" + std::to_string(at);
          // Ordinary objects before the bad one must not be registered either; if the bad one
          // is registered already, it is left alone and the others are registered.
          mgr_.registerObjects(batch);
          for (auto* x : batch) modelRegister(x);
          break;
        }
        case 2:
          expect = "object #" + std::to_string(indexOf(o));
          mgr_.update(o);
          break;
        case 3: {
          std::vector<Object*> batch = others;
          batch.push_back(o);
          expect = "object #" + std::to_string(indexOf(o));
          for (auto* x : others) modelRead(x);  // before the call: it throws
          mgr_.update(batch);
          break;
        }
        default:
          expect = "object #" + std::to_string(indexOf(o));
          for (auto& c : cached_)
            if (c.first != o) c.second = c.first->getAABB();
          mgr_.update();
          break;
      }
    } catch (const std::invalid_argument& e) {
      thrown = true;
      what = e.what();
    }
    // Queries with a NaN query object must throw too.
    bool query_threw = false;
    try {
      mgr_.collide(o, nullptr, [](Object*, Object*, void*) { return false; });
    } catch (const std::invalid_argument&) {
      query_threw = true;
    }
    bool dquery_threw = false;
    try {
      mgr_.distance(o, nullptr, [](Object*, Object*, void*, S&) { return false; });
    } catch (const std::invalid_argument&) {
      dquery_threw = true;
    }
    o->setTransform(keep);
    o->computeAABB();
    // Registering an object already registered has no effect, whatever its AABB (registerObject
    // and registerObjects alike); updates throw only for registered objects.
    const bool should_throw = how <= 1 ? !was : was;
    if (thrown != should_throw)
      return std::string("NaN op ") + std::to_string(how) + ": expected " +
             (should_throw ? "" : "no ") + "std::invalid_argument";
    if (thrown && what.find(expect) == std::string::npos)
      return "NaN op message '" + what + "' does not name '" + expect + "'";
    if (registered(o) != was || mgr_.size() != order_.size())
      return "NaN op changed the registered set";
    if (!query_threw || !dquery_threw) return "query with a NaN query object did not throw";
    return "";
  }

  // A callback returning true after k calls: exactly min(k, expected) calls, all expected.
  std::string stopOp() {
    const std::size_t k = src_.pick(4) + 1;
    trace_ << "stop after " << k << "\n";
    struct Data {
      std::size_t k, calls = 0;
      std::vector<Pair> seen;
    } d{k, 0, {}};
    mgr_.collide(&d, [](Object* a, Object* b, void* p) {
      auto* d = static_cast<Data*>(p);
      d->seen.push_back(unordered(a, b));
      return ++d->calls >= d->k;
    });
    const auto expected = selfExpected();
    if (d.calls != std::min(k, expected.size()))
      return "stopping self-collide made " + std::to_string(d.calls) + " calls, expected " +
             std::to_string(std::min(k, expected.size()));
    for (const auto& p : d.seen)
      if (!std::binary_search(expected.begin(), expected.end(), p))
        return "stopping self-collide reported a pair that does not overlap";
    return "";
  }

  // A throwing callback: the exception reaches us, and checkAll() then proves the manager intact.
  std::string throwOp() {
    const std::size_t k = src_.pick(3);
    const std::uint32_t which = src_.pick(3);
    trace_ << "throw after " << k << " calls in query " << which << "\n";
    struct Boom {};
    struct Data {
      std::size_t k, calls = 0;
    } d{k};
    bool thrown = false;
    try {
      if (which == 0) {
        mgr_.collide(&d, [](Object*, Object*, void* p) {
          auto* d = static_cast<Data*>(p);
          if (d->calls++ >= d->k) throw Boom();
          return false;
        });
      } else if (which == 1) {
        mgr_.distance(&d, [](Object*, Object*, void* p, S&) {
          auto* d = static_cast<Data*>(p);
          if (d->calls++ >= d->k) throw Boom();
          return false;
        });
      } else {
        mgr_.collide(anyObject(), &d, [](Object*, Object*, void* p) {
          auto* d = static_cast<Data*>(p);
          if (d->calls++ >= d->k) throw Boom();
          return false;
        });
      }
    } catch (const Boom&) {
      thrown = true;
    }
    if (thrown != (d.calls > k)) return "throwing callback: exception lost";
    return "";
  }

  // ---- brute-force expectations -----------------------------------------------------------

  std::vector<Pair> selfExpected() const {
    std::vector<Pair> out;
    for (std::size_t i = 0; i < order_.size(); ++i)
      for (std::size_t j = i + 1; j < order_.size(); ++j)
        if (overlap(cached_.at(order_[i]), cached_.at(order_[j])))
          out.push_back(unordered(order_[i], order_[j]));
    std::sort(out.begin(), out.end());
    return out;
  }

  // ---- recorders --------------------------------------------------------------------------

  struct Rec {
    std::vector<Pair> calls;
    static bool collide(Object* a, Object* b, void* d) {
      static_cast<Rec*>(d)->calls.emplace_back(a, b);
      return false;
    }
  };
  // Lowers dist to the pair's AABB distance (as the manager cached the first, the second from
  // `second_live` or the cache) and records the minimum.
  struct MinRec {
    const Runner* self;
    const std::map<const Object*, AABB>* first;
    const std::map<const Object*, AABB>* second;  // null: the live AABB
    S min = std::numeric_limits<S>::max();
    std::size_t calls = 0;
    bool bad = false;
    static bool distance(Object* a, Object* b, void* p, S& dist) {
      auto* r = static_cast<MinRec*>(p);
      ++r->calls;
      const auto ia = r->first->find(a);
      if (ia == r->first->end()) return r->bad = true;
      AABB bb = b->getAABB();
      if (r->second) {
        const auto ib = r->second->find(b);
        if (ib == r->second->end()) return r->bad = true;
        bb = ib->second;
      }
      const S d = ia->second.distance(bb);
      r->min = std::min(r->min, d);
      dist = std::min(dist, d);
      return false;
    }
  };

  std::string boxText(const Object* o) const {
    std::ostringstream s;
    s.precision(17);
    const auto it = cached_.find(o);
    const AABB& b = it != cached_.end() ? it->second : o->getAABB();
    s << name(o) << (it != cached_.end() ? "" : "(live)") << "[" << b.min_.transpose() << " | "
      << b.max_.transpose() << "]";
    return s.str();
  }
  // What one sorted pair list has that the other lacks, for the failure message.
  std::string diffPairs(const std::vector<Pair>& got, const std::vector<Pair>& want) const {
    std::vector<Pair> extra, missing;
    std::set_difference(got.begin(), got.end(), want.begin(), want.end(),
                        std::back_inserter(extra));
    std::set_difference(want.begin(), want.end(), got.begin(), got.end(),
                        std::back_inserter(missing));
    std::string out;
    for (const auto& p : extra) out += "\n  extra " + boxText(p.first) + " " + boxText(p.second);
    for (const auto& p : missing)
      out += "\n  missing " + boxText(p.first) + " " + boxText(p.second);
    return out;
  }

  // The manager's cubes and lists, for failure messages.
  std::string dump() const {
    std::ostringstream s;
    s.precision(9);
    const auto& h = ::cube::detail::coreOf(mgr_).tree();
    s << "\n--- hierarchy: root " << h.root() << " ---";
    for (std::size_t i = 0; i < h.nodes().size(); ++i) {
      const auto& n = h.nodes()[i];
      s << "\n  cube " << i << " [" << n.lo[0] << " " << n.lo[1] << " " << n.lo[2] << " | "
        << n.hi[0] << " " << n.hi[1] << " " << n.hi[2] << "] first " << n.first << " count "
        << n.count;
    }
    for (std::size_t i = 0; i < h.items().size(); ++i)
      s << "\n  item " << i << " " << (h.items()[i].obj ? name(h.items()[i].obj) : "dead")
        << " leaf " << h.items()[i].leaf;
    for (const auto& it : ::cube::detail::coreOf(mgr_).unboundedItems())
      s << "\n  unbounded " << name(it.obj);
    return s.str();
  }

  static std::vector<Pair> sorted(std::vector<Pair> v) {
    std::sort(v.begin(), v.end());
    return v;
  }

  // ---- the checks after every step --------------------------------------------------------

  std::string checkAll() {
    ++checks_;
    std::string why;
    if (!mgr_.validate(&why) && (known_.empty() || why.find(known_) == std::string::npos))
      return "validate() failed: " + why;
    if (mgr_.size() != order_.size() || mgr_.empty() != order_.empty())
      return "size() " + std::to_string(mgr_.size()) + ", expected " +
             std::to_string(order_.size());
    std::vector<Object*> objs;
    mgr_.getObjects(objs);
    if (objs != order_) return "getObjects() differs from the registered objects in order";
    std::string err = checkSelf();
    if (err.empty()) err = checkObjectQueries();
    if (err.empty() && src_.pick(4) == 0 && inSync() && scene_ != Scene::huge &&
        scene_ != Scene::tiny)
      err = checkNarrow();
    return err;
  }

  std::string checkSelf() {
    Rec r;
    mgr_.collide(&r, &Rec::collide);
    std::vector<Pair> got;
    for (const auto& c : r.calls) got.push_back(unordered(c.first, c.second));
    if (sorted(got) != selfExpected())
      return "self-collide pairs differ from brute force: " +
             diffPairs(sorted(got), selfExpected()) + dump();

    // Self distance, pruning: the minimum AABB distance over all pairs.
    MinRec m{this, &cached_, &cached_};
    mgr_.distance(&m, &MinRec::distance);
    S expected = std::numeric_limits<S>::max();
    for (std::size_t i = 0; i < order_.size(); ++i)
      for (std::size_t j = i + 1; j < order_.size(); ++j)
        expected = std::min(expected, cached_.at(order_[i]).distance(cached_.at(order_[j])));
    if (m.bad || m.min != expected)
      return "self distance minimum " + std::to_string(m.min) + ", expected " +
             std::to_string(expected);

    // Self distance with a callback that never lowers dist: every pair Naive would visit
    // (AABB distance below the largest double), each once.
    Rec all;
    mgr_.distance(&all, [](Object* a, Object* b, void* d, S&) { return Rec::collide(a, b, d); });
    std::vector<Pair> visited, want;
    for (const auto& c : all.calls) visited.push_back(unordered(c.first, c.second));
    for (std::size_t i = 0; i < order_.size(); ++i)
      for (std::size_t j = i + 1; j < order_.size(); ++j)
        if (cached_.at(order_[i]).distance(cached_.at(order_[j])) < std::numeric_limits<S>::max())
          want.push_back(unordered(order_[i], order_[j]));
    if (sorted(visited) != sorted(want))
      return "self distance without pruning visited " + std::to_string(visited.size()) +
             " pairs, expected " + std::to_string(want.size());
    return "";
  }

  std::string checkObjectQueries() {
    for (int q = 0; q < 2; ++q) {
      Object* o = anyObject();  // registered or not
      Rec r;
      mgr_.collide(o, &r, &Rec::collide);
      std::vector<Pair> got, want;
      for (const auto& c : r.calls) {
        if (c.second != o) return "collide(obj): second argument is not the query object";
        got.emplace_back(c.first, o);
      }
      for (auto* m : order_)
        if (m != o && overlap(cached_.at(m), o->getAABB())) want.emplace_back(m, o);
      if (sorted(got) != sorted(want))
        return "collide(" + name(o) + ") reported " + std::to_string(got.size()) +
               " objects, expected " + std::to_string(want.size());

      MinRec d{this, &cached_, nullptr};
      struct Check {
        MinRec* rec;
        Object* query;
        bool wrong = false;
      } chk{&d, o};
      mgr_.distance(o, &chk, [](Object* a, Object* b, void* p, S& dist) {
        auto* c = static_cast<Check*>(p);
        if (b != c->query) c->wrong = true;
        return MinRec::distance(a, b, c->rec, dist);
      });
      S expected = std::numeric_limits<S>::max();
      for (auto* m : order_)
        if (m != o) expected = std::min(expected, cached_.at(m).distance(o->getAABB()));
      if (chk.wrong || d.bad) return "distance(obj): wrong callback arguments";
      if (d.min != expected)
        return "distance(" + name(o) + ") minimum " + std::to_string(d.min) + ", expected " +
               std::to_string(expected);
    }
    return "";
  }

  // Manager against manager: another cube manager (both directions), a Naive one, FCL's dynamic
  // AABB tree, or the manager itself.
  std::string otherManagerOp() {
    const std::uint32_t kind = src_.pick(4);
    const auto members = someObjects(std::uint32_t(pool_.size()));
    static const std::vector<Config> all_configs = configs();
    std::unique_ptr<Manager> other;
    if (kind == 0) {
      auto c = std::make_unique<CubeCollisionManager<S>>(
          all_configs[src_.pick(std::uint32_t(all_configs.size()))]);
      // Half the time one by one, so the other tree is incremental rather than freshly built.
      if (src_.pick(2)) {
        for (auto* o : members) c->registerObject(o);
      } else {
        c->registerObjects(members);
      }
      other = std::move(c);
    } else if (kind == 1) {
      other = std::make_unique<fcl::NaiveCollisionManager<S>>();
      std::vector<Object*> distinct;
      for (auto* o : members)
        if (std::find(distinct.begin(), distinct.end(), o) == distinct.end()) distinct.push_back(o);
      other->registerObjects(distinct);
    } else if (kind == 2) {
      other = std::make_unique<fcl::DynamicAABBTreeCollisionManager<S>>();
      std::vector<Object*> distinct;
      for (auto* o : members)
        if (std::find(distinct.begin(), distinct.end(), o) == distinct.end()) distinct.push_back(o);
      // One by one and no setup(): FCL's own bulk build (topdown_0) crashes on the degenerate
      // scenes (coincident boxes); we only need its getObjects().
      for (auto* o : distinct) other->registerObject(o);
    }
    trace_ << "vs manager kind " << kind << " with " << members.size() << " objects\n";
    Manager* om = other ? other.get() : &mgr_;
    std::vector<Object*> theirs;
    om->getObjects(theirs);
    // The other side's boxes: a fresh manager read them now; the manager itself uses its cache.
    std::map<const Object*, AABB> their_boxes;
    for (auto* o : theirs) their_boxes[o] = other ? o->getAABB() : cached_.at(o);

    auto expectPairs = [&](bool reversed) {
      std::vector<Pair> out;
      if (!other) return selfExpected();
      for (auto* a : order_)
        for (auto* b : theirs)
          if (a != b && overlap(cached_.at(a), their_boxes.at(b)))
            out.push_back(reversed ? Pair(b, a) : Pair(a, b));
      std::sort(out.begin(), out.end());
      return out;
    };

    Rec r;
    mgr_.collide(om, &r, &Rec::collide);
    std::vector<Pair> got = r.calls;
    if (!other)
      for (auto& p : got) p = unordered(p.first, p.second);
    if (sorted(got) != expectPairs(false))
      return "collide(manager kind " + std::to_string(kind) + ") pairs differ from brute force";

    MinRec m{this, &cached_, &their_boxes};
    mgr_.distance(om, &m, &MinRec::distance);
    S expected = std::numeric_limits<S>::max();
    if (other) {
      for (auto* a : order_)
        for (auto* b : theirs)
          if (a != b) expected = std::min(expected, cached_.at(a).distance(their_boxes.at(b)));
    } else {
      for (std::size_t i = 0; i < order_.size(); ++i)
        for (std::size_t j = i + 1; j < order_.size(); ++j)
          expected = std::min(expected, cached_.at(order_[i]).distance(cached_.at(order_[j])));
    }
    if (m.bad || m.min != expected)
      return "distance(manager kind " + std::to_string(kind) + ") minimum " +
             std::to_string(m.min) + ", expected " + std::to_string(expected);

    if (kind == 0) {
      // The other direction: callback(object of other, object of this).
      Rec back;
      static_cast<CubeCollisionManager<S>*>(om)->collide(&mgr_, &back, &Rec::collide);
      if (sorted(back.calls) != expectPairs(true))
        return "reverse collide(manager) pairs differ from brute force";
      MinRec mb{this, &their_boxes, &cached_};
      static_cast<CubeCollisionManager<S>*>(om)->distance(&mgr_, &mb, &MinRec::distance);
      if (mb.bad || mb.min != expected) return "reverse distance(manager) minimum differs";
    }
    if (kind == 1 && inSync()) {
      // Against FCL itself: a Naive manager over our objects colliding with the other Naive.
      fcl::NaiveCollisionManager<S> mine;
      mine.registerObjects(order_);
      Rec n;
      mine.collide(om, &n, &Rec::collide);
      std::vector<Pair> want;
      for (const auto& p : n.calls)
        if (p.first != p.second) want.push_back(p);
      if (sorted(r.calls) != sorted(want))
        return "collide(Naive manager) differs from Naive vs Naive";
    }
    return "";
  }

  // The narrow-phase callbacks are oracle::narrowCollide / oracle::narrowDistance: the same
  // call per pair on both sides, argument order made canonical.

  std::string checkNarrow() {
    ++narrow_checks_;
    fcl::NaiveCollisionManager<S> naive;
    naive.registerObjects(order_);
    std::vector<Pair> ours, theirs;
    mgr_.collide(&ours, &oracle::narrowCollide<S>);
    naive.collide(&theirs, &oracle::narrowCollide<S>);
    if (sorted(ours) != sorted(theirs))
      return "narrow-phase colliding pairs differ from Naive (" + std::to_string(ours.size()) +
             " vs " + std::to_string(theirs.size()) + ")";
    S a = std::numeric_limits<S>::max(), b = a;
    mgr_.distance(&a, &oracle::narrowDistance<S>);
    naive.distance(&b, &oracle::narrowDistance<S>);
    if (std::abs(a - b) > 1e-9)
      return "narrow-phase self distance " + std::to_string(a) + " vs Naive " + std::to_string(b);
    // One query object through collide(obj) with FCL's own per-object loop.
    Object* q = anyObject();
    std::vector<Pair> oq, nq;
    mgr_.collide(q, &oq, &oracle::narrowCollide<S>);
    struct Filter {
      Object* q;
      std::vector<Pair>* out;
    } f{q, &nq};
    naive.collide(q, &f, [](Object* x, Object* y, void* p) {
      // Naive calls back for every object without an AABB test; skip the query itself and
      // AABB-disjoint pairs, which the narrow phase may still call touching.
      auto* f = static_cast<Filter*>(p);
      if (y == x || !x->getAABB().overlap(y->getAABB())) return false;
      return oracle::narrowCollide<S>(x, y, f->out);
    });
    if (sorted(oq) != sorted(nq)) return "narrow-phase collide(obj) differs from Naive";
    return "";
  }

  Source& src_;
  Config config_;
  Scene scene_;
  double scale_ = 1;
  std::vector<std::unique_ptr<Object>> pool_;
  std::shared_ptr<fcl::CollisionGeometry<S>> shared_;
  CubeCollisionManager<S> mgr_;
  std::map<const Object*, AABB> cached_;  // what the manager should hold
  std::vector<Object*> order_;            // registration order
  std::ostringstream trace_;
  std::size_t steps_ = 0, checks_ = 0, narrow_checks_ = 0;
  std::string known_;
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
