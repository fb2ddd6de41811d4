#pragma once

// The operations of a differential sequence: register (one, or a batch with repeats),
// unregister, moves with each update variant, moves the manager is not told about, clear, setup,
// NaN poses at register/update, stopping and throwing callbacks, and queries against another
// manager. Each applies itself to the manager and to the model, and writes one trace line.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cube_collision/cube_collision_manager.h"
#include "differential_expect.h"
#include "differential_other_managers.h"
#include "differential_pool.h"

namespace cube {
namespace diff {

class Operations {
 public:
  Operations(Source& src, Pool& pool, Model& model, CubeCollisionManager<S>& mgr,
             std::ostream& trace)
      : src_(src),
        pool_(pool),
        model_(model),
        mgr_(mgr),
        trace_(trace),
        other_managers_(src, pool, model, mgr, trace) {}

  /// Draws one operation and applies it; "" or what an operation that checks found wrong.
  std::string step() {
    const std::uint32_t op = src_.pick(16);
    switch (op) {
      case 0:
      case 1: {
        Object* o = pool_.any();
        trace_ << "registerObject " << pool_.name(o) << "\n";
        mgr_.registerObject(o);
        model_.add(o);
        return "";
      }
      case 2: {
        const auto batch = pool_.some(std::uint32_t(pool_.size()));
        trace_ << "registerObjects";
        for (auto* o : batch) trace_ << " " << pool_.name(o);
        trace_ << "\n";
        mgr_.registerObjects(batch);
        for (auto* o : batch) model_.add(o);
        return "";
      }
      case 3:
      case 4: {
        Object* o = pool_.any();
        trace_ << "unregisterObject " << pool_.name(o) << "\n";
        mgr_.unregisterObject(o);
        model_.remove(o);
        return "";
      }
      case 5:
      case 6:
      case 7:
        moveAndUpdate();
        return "";
      case 8: {
        // Moves the manager is not told about: it must keep using the AABBs it cached.
        const auto moved = pool_.some(3);
        trace_ << "move without update";
        for (auto* o : moved) trace_ << " " << pool_.name(o), pool_.setPose(o);
        trace_ << "\n";
        return "";
      }
      case 9:
        if (src_.pick(4) == 0) {
          trace_ << "clear\n";
          mgr_.clear();
          model_.clear();
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
        return other_managers_.run();
    }
  }

 private:
  // Move some objects, then one of the update variants (update(obj) per object, the vector form
  // with unknown objects and repeats mixed in, or update()).
  void moveAndUpdate() {
    const auto moved = pool_.some(4);
    for (auto* o : moved) pool_.setPose(o);
    const std::uint32_t how = src_.pick(3);
    trace_ << "move";
    for (auto* o : moved) trace_ << " " << pool_.name(o);
    trace_ << (how == 0   ? " + update(obj) each\n"
               : how == 1 ? " + update(vec)\n"
                          : " + update()\n");
    if (how == 0) {
      for (auto* o : moved) mgr_.update(o), model_.read(o);
    } else if (how == 1) {
      mgr_.update(moved);
      for (auto* o : moved) model_.read(o);
    } else {
      mgr_.update();
      model_.readAll();
    }
  }

  // An object gets a NaN AABB: registering it or updating it must throw and change nothing for
  // it, while every other object of the same update is updated.
  std::string nanOp() {
    Object* o = pool_.any();
    const fcl::Transform3<S> keep = o->getTransform();
    const std::uint32_t how = src_.pick(5);
    auto others = pool_.some(3);
    others.erase(std::remove(others.begin(), others.end(), o), others.end());
    for (auto* x : others) pool_.setPose(x);
    o->setTranslation(fcl::Vector3<S>(std::nan(""), 0, 0));
    o->computeAABB();
    trace_ << "NaN " << pool_.name(o) << " via " << how << " moving";
    for (auto* x : others) trace_ << " " << pool_.name(x);
    trace_ << "\n";
    const bool was = model_.registered(o);
    std::string expect;  // the text the message must contain
    bool thrown = false;
    std::string what;
    try {
      switch (how) {
        case 0:
          expect = "object #" + std::to_string(model_.order().size());
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
          for (auto* x : batch) model_.add(x);
          break;
        }
        case 2:
          expect = "object #" + std::to_string(model_.indexOf(o));
          mgr_.update(o);
          break;
        case 3: {
          std::vector<Object*> batch = others;
          batch.push_back(o);
          expect = "object #" + std::to_string(model_.indexOf(o));
          for (auto* x : others) model_.read(x);  // before the call: it throws
          mgr_.update(batch);
          break;
        }
        default:
          expect = "object #" + std::to_string(model_.indexOf(o));
          model_.readAll(o);
          mgr_.update();
          break;
      }
    } catch (const std::invalid_argument& e) {
      thrown = true;
      what = e.what();
    }
    // Queries with a NaN query object must throw too, but for an empty manager.
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
    if (model_.registered(o) != was || mgr_.size() != model_.order().size())
      return "NaN op changed the registered set";
    // Only a manager with objects reads the query object: an empty one returns at once.
    const bool query_should_throw = mgr_.size() > 0;
    if (query_threw != query_should_throw || dquery_threw != query_should_throw)
      return std::string("query with a NaN query object ") +
             (query_should_throw ? "did not throw" : "threw on an empty manager");
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
    const auto expected = selfPairs(model_);
    if (d.calls != std::min(k, expected.size()))
      return "stopping self-collide made " + std::to_string(d.calls) + " calls, expected " +
             std::to_string(std::min(k, expected.size()));
    for (const auto& p : d.seen)
      if (!std::binary_search(expected.begin(), expected.end(), p))
        return "stopping self-collide reported a pair that does not overlap";
    return "";
  }

  // A throwing callback: the exception reaches us, and the checks after the step then prove the
  // manager intact.
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
        mgr_.collide(pool_.any(), &d, [](Object*, Object*, void* p) {
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

  Source& src_;
  Pool& pool_;
  Model& model_;
  CubeCollisionManager<S>& mgr_;
  std::ostream& trace_;
  OtherManagerOp other_managers_;
};

}  // namespace diff
}  // namespace cube
