#pragma once

// One thread's checker of the batched checks (queries/batch.cpp): the links placed for a state,
// the world's walks through the core's query entries, the cull on the records, FCL on the rest.
// Private to the library.

#include <fcl/narrowphase/collision_request.h>
#include <fcl/narrowphase/collision_result.h>
#include <fcl/narrowphase/distance_request.h>
#include <fcl/narrowphase/distance_result.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <new>
#include <vector>

#include "adapter/query_guard.h"
#include "core/body_view.h"
#include "core/broadphase.h"
#include "core/kernels/pose_boxes.h"
#include "pipeline/collectors.h"
#include "pipeline/cull.h"
#include "pipeline/fcl_narrow.h"
#include "pipeline/pair_judge.h"
#include "queries/body_links.h"

namespace cube {
namespace detail {

// A link's object in one thread's scratch: shares the link's geometry without the
// computeLocalAABB() that FCL's constructors call (writing to a geometry other threads read).
template <typename S>
class LinkObject final : public fcl::CollisionObject<S> {
 public:
  explicit LinkObject(const std::shared_ptr<fcl::CollisionGeometry<S>>& geometry)
      : fcl::CollisionObject<S>(nullptr) {
    this->cgeom = geometry;
    this->cgeom_const = geometry;
  }
  /// The state's pose, and its AABB (what a predicate's getAABB() reads).
  void place(const fcl::Transform3<S>& pose, const fcl::Vector3<S>& lo, const fcl::Vector3<S>& hi) {
    this->setTransform(pose);
    this->aabb.min_ = lo;
    this->aabb.max_ = hi;
  }
};

template <typename S>
using Links = typename BodySet<S>::Links;

// One thread's checker: the links' objects, boxes and records for the state at hand, and the
// walks of the world. Made once per thread and call; no allocation per state.
template <typename S>
class StateChecker {
 public:
  using Object = fcl::CollisionObject<S>;

  StateChecker(const Broadphase<S>& world, const Links<S>& links)
      : scope_(&world),
        world_(world),
        links_(links),
        world_spheres_(world.table().spheres()),
        world_shapes_(world.table().shapes()),
        body_(links.view),
        judge_(request_),
        distance_judge_(distance_request_) {
    slots_.resize(links.size());
    for (std::size_t l = 0; l < links.size(); ++l) slots_[l].source = links.source[l];
    self_gate_.excluded = links.excluded.data();  // the pairs BodySet::excludePair rules out
    self_gate_.excluded_n = links.size();
    for (int d = 0; d < 3; ++d) {
      c_[d].resize(links.size());
      h_[d].resize(links.size());
    }
    grow_.resize(links.size());
    margin_ = links.margin;
    objects_ = std::make_unique<ObjectStorage[]>(links.size());
    for (std::uint32_t l = 0; l < links.size(); ++l) body_.setObject(l, objectAt(l));
    eager_objects_ = bool(world.predicate());
  }
  ~StateChecker() {
    for (std::size_t l = 0; l < slots_.size(); ++l)
      if (slots_[l].made) objectAt(std::uint32_t(l))->~LinkObject<S>();
  }
  StateChecker(const StateChecker&) = delete;
  StateChecker& operator=(const StateChecker&) = delete;

  /// Whether the state collides; the first pair and the clearance into `out` as asked.
  /// Two passes: the walks and the records settle what they can (most pairs apart, many in
  /// contact proved by inscribed balls), then FCL answers the rest, so that a colliding state
  /// proved on the records makes no FCL call.
  /// kBadPose (and the link in badLink()) if a pose has a NaN or infinite entry, found while
  /// placing the links: the state's poses are read once.
  /// `extra` (null, or one value >= 0 per link): each link's margin raised by its value for this
  /// state alone (a continuous edge's motion bounds).
  static constexpr int kBadPose = -1;
  int check(const fcl::Transform3<S>* poses, bool self, bool first_pair, bool clearance,
            StateResult<S>* out, const S* extra = nullptr) {
    if (extra != nullptr) {
      for (std::size_t l = 0; l < margin_.size(); ++l) margin_[l] = links_.margin[l] + extra[l];
      raised_ = true;
    } else if (raised_) {
      margin_ = links_.margin;
      raised_ = false;
    }
    if (!place(poses)) return kBadPose;
    // What the check keeps: the first pair in Candidate's order, or any pair.
    if (first_pair ? search<FirstInOrder<Candidate>>(self) : search<AnyHit<Candidate>>(self)) {
      if (out != nullptr && first_pair) {
        const Candidate& best = first_.hit();
        out->link = best.link;
        if (best.is_link)
          out->other_link = best.other;
        else
          out->object = world_.table().object(best.other);
      }
      return true;
    }
    if (out != nullptr && clearance) out->clearance = clearanceOf(self);
    return false;
  }

 private:
  // Per link: the state's pose, the cull's records (placed on first use), its object's state.
  struct Slot {
    const fcl::Transform3<S>* pose = nullptr;
    VolumeSource source;
    VolumeSphere sphere;
    VolumeShape shape;
    std::uint64_t placed = 0;  // the state the records were placed for
    std::uint64_t posed = 0;   // the state its object was placed for
    bool made = false;         // its LinkObject is constructed
  };
  // A pair the records did not settle, or the best contact so far: (link, key) ordered, key the
  // world object's registration number or the other link's index (links after the world).
  struct Candidate {
    std::uint32_t link;
    std::uint32_t key;
    std::uint32_t other;  // world id or link index
    bool is_link;
    bool operator<(const Candidate& c) const {
      if (link != c.link) return link < c.link;
      if (is_link != c.is_link) return !is_link;
      return key < c.key;
    }
  };
  struct WorldNear {
    StateChecker* checker;
    std::uint32_t link;
    Closest<S>* closest;
  };

  // The collector of a search: C names it by type, so the walks' callbacks find it statically.
  template <class C>
  C& hits() {
    if constexpr (C::kOrdered)
      return first_;
    else
      return any_;
  }

  // The walks of the placed state into collector C; whether it holds a hit.
  template <class C>
  bool search(bool self) {
    C& hits = this->hits<C>();
    hits.reset();
    // The world leaf by leaf of the links' tree, in link order: a state in contact stops at
    // the first group of links that touches (as a link-by-link check does), and a free one
    // walks little more than the whole tree at once would.
    for (std::size_t k = 0; k < body_.leafCount() && world_.size() != 0 && !hits.found(); ++k) {
      pending_.clear();
      world_.collide(body_.leafView(k), links_.any_bits ? links_.bits.data() : nullptr, this,
                     CollideFn<S>(&StateChecker::onWorld<C>), nullptr);
      if (hits.complete() || decidePending(hits)) return true;
    }
    if (self) {
      pending_.clear();
      collideViews(body_.view(), body_.view(), CollideFn<S>(&StateChecker::onLinks<C>), this, true,
                   0, nullptr, &self_gate_);
      if (hits.complete()) return true;
      decidePending(hits);
    }
    return hits.found();
  }

  typename Broadphase<S>::Probe probe(std::size_t l) {
    return typename Broadphase<S>::Probe{&object(std::uint32_t(l)), rateBox(l), margin_[l],
                                         links_.bits[l]};
  }

  // Poses the links: the boxes the walks test (the exact box of each posed local AABB grown by
  // the cull's rate, so that pairs FCL counts as touching within its tolerance are met, and by
  // the link's margin). Objects and records follow on first use.
  bool place(const fcl::Transform3<S>* poses) {
    ++state_;
    const std::size_t n = links_.size();
    static_assert(sizeof(fcl::Transform3<S>) == 16 * sizeof(S), "a pose is 16 numbers");
    // Centres and half extents of all links at once (four per instruction with AVX2): placing
    // the links is most of a free state's check in a clustered world.
    poseBoxes(
        poses->data(), n,
        PoseBoxes<S>{{links_.mid_of[0].data(), links_.mid_of[1].data(), links_.mid_of[2].data()},
                     {links_.half_of[0].data(), links_.half_of[1].data(), links_.half_of[2].data()},
                     {c_[0].data(), c_[1].data(), c_[2].data()},
                     {h_[0].data(), h_[1].data(), h_[2].data()}});
    // x - x is 0 for a finite x and NaN otherwise: summed over the links and tested once (every
    // entry of R and t reaches c or h; an infinite one times a zero extent is NaN).
    S finite = 0;
    const S rate = S(judge_.rate());
    for (std::size_t l = 0; l < n; ++l) {
      Slot& slot = slots_[l];
      const S c[3] = {c_[0][l], c_[1][l], c_[2][l]};
      const S h[3] = {h_[0][l], h_[1][l], h_[2][l]};
      finite += (c[0] - c[0]) + (c[1] - c[1]) + (c[2] - c[2]) + (h[0] - h[0]) + (h[1] - h[1]) +
                (h[2] - h[2]);
      slot.pose = poses + l;
      const S reach = std::max({std::fabs(c[0]), std::fabs(c[1]), std::fabs(c[2])}) +
                      std::max({h[0], h[1], h[2]});
      const S grow = rate * (S(1) + reach);
      grow_[l] = grow;
      const S g = grow + margin_[l];
      Box<S>& walked = body_.box(std::uint32_t(l));
      walked.lo[0] = c[0] - h[0] - g;
      walked.lo[1] = c[1] - h[1] - g;
      walked.lo[2] = c[2] - h[2] - g;
      walked.hi[0] = c[0] + h[0] + g;
      walked.hi[1] = c[1] + h[1] + g;
      walked.hi[2] = c[2] + h[2] + g;
    }
    if (!(finite == S(0))) {
      for (std::size_t l = 0; l < links_.size(); ++l)
        if (!poses[l].linear().allFinite() || !poses[l].translation().allFinite()) {
          bad_link_ = l;
          return false;
        }
    }
    // A predicate sees every link object the walk offers: placed now. Otherwise on first use.
    if (eager_objects_)
      for (std::uint32_t l = 0; l < links_.size(); ++l) object(l);
    body_.refit();
    return true;
  }

 public:
  std::size_t badLink() const { return bad_link_; }

 private:
  // Link l's exact box grown by the cull's rate (the walks' box before its margin).
  Box<S> rateBox(std::size_t l) const {
    Box<S> b;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = c_[k][l] - h_[k][l] - grow_[l];
      b.hi[k] = c_[k][l] + h_[k][l] + grow_[l];
    }
    return b;
  }
  LinkObject<S>* objectAt(std::uint32_t l) {
    return reinterpret_cast<LinkObject<S>*>(&objects_[l]);
  }
  void construct(std::uint32_t l) {
    new (&objects_[l]) LinkObject<S>(links_.geometry[l]);
    slots_[l].made = true;
  }
  // Link l's object, made on first use and placed for the state (most links meet no
  // candidate: their objects are never touched).
  LinkObject<S>& object(std::uint32_t l) {
    Slot& slot = slots_[l];
    if (slot.posed != state_) {
      if (!slot.made) construct(l);
      fcl::Vector3<S> lo, hi;
      for (int k = 0; k < 3; ++k) {
        lo[k] = c_[k][l] - h_[k][l];
        hi[k] = c_[k][l] + h_[k][l];
      }
      objectAt(l)->place(*slot.pose, lo, hi);
      slot.posed = state_;
    }
    return *objectAt(l);
  }

  // A pair offered by a walk: settled on the records if they can (a hit handed to the
  // collector, which says whether the walk may stop), else kept for FCL.
  template <class C>
  bool offer(C& hits, const Candidate& c, const VolumeSphere& sa, const VolumeShape& ha,
             const VolumeSphere& sb, const VolumeShape& hb, S m) {
    if (!hits.mayBeat(c)) return hits.complete();
    switch (judge_.withinMargin(Records{&sa, &ha}, Records{&sb, &hb}, m)) {
      case Verdict::kApart:
        return false;
      case Verdict::kTouching:
        return hits.add(c);
      case Verdict::kUnknown:
        pending_.push_back(c);
        return false;
    }
    return false;
  }

  template <class C>
  static bool onWorld(Object* w, ObjectId iw, Object*, ObjectId link, void* data) {
    StateChecker& c = *static_cast<StateChecker*>(data);
    C& hits = c.hits<C>();
    const Candidate cand{link, c.world_.table().seq(iw), iw, false};
    if (!hits.mayBeat(cand)) return hits.complete();  // cannot change the answer
    const VolumeSphere* s;
    const VolumeShape* h;
    c.worldRecords(*w, iw, s, h);
    const Slot& slot = c.linkRecords(link);
    return c.offer(hits, cand, slot.sphere, slot.shape, *s, *h,
                   c.margin_[link] + c.world_.marginOf(iw));
  }

  template <class C>
  static bool onLinks(Object*, ObjectId x, Object*, ObjectId y, void* data) {
    StateChecker& c = *static_cast<StateChecker*>(data);
    const std::uint32_t i = std::min(x, y), j = std::max(x, y);
    const Slot& a = c.linkRecords(i);
    const Slot& b = c.linkRecords(j);
    return c.offer(c.hits<C>(), Candidate{i, j, j, true}, a.sphere, a.shape, b.sphere, b.shape,
                   c.margin_[i] + c.margin_[j]);
  }

  // FCL on the pairs kept, in walk order (a collector that keeps the first in Candidate's
  // order: in that order, up to the best proved on the records). True once the collector's
  // answer is complete.
  template <class C>
  bool decidePending(C& hits) {
    if (C::kOrdered) std::sort(pending_.begin(), pending_.end());
    for (const Candidate& c : pending_) {
      if (!hits.mayBeat(c)) break;  // sorted (first pair), or found (any)
      const S m = c.is_link ? margin_[c.link] + margin_[c.other]
                            : margin_[c.link] + world_.marginOf(c.other);
      const Object& b =
          c.is_link ? static_cast<const Object&>(object(c.other)) : *world_.table().object(c.other);
      if (narrow(object(c.link), b, m,
                 c.is_link ? grow_[c.link] + grow_[c.other] : grow_[c.link])) {
        hits.add(c);
        break;
      }
    }
    return hits.complete();
  }

  // The world object's records: the table's, or built here (a world that keeps none).
  void worldRecords(const Object& w, ObjectId iw, const VolumeSphere*& s, const VolumeShape*& h) {
    if (world_spheres_ != nullptr) {
      s = world_spheres_ + iw;
      h = world_shapes_ + iw;
      return;
    }
    buildVolume(w, built_sphere_, built_shape_);
    s = &built_sphere_;
    h = &built_shape_;
  }

  // Link l's records, placed on first use in a state.
  Slot& linkRecords(std::uint32_t l) {
    Slot& slot = slots_[l];
    if (slot.placed != state_) {
      slot.placed = state_;
      moveVolume(object(l), slot.source, slot.sphere, slot.shape);
    }
    return slot;
  }

  // FCL's answer: contact, or (margin m > 0) a distance of at most m. With raised margins (a
  // continuous edge's), FCL's distance starts from a cap above m (an eighth more, plus the pair's
  // tolerance `slack`, beyond rounding): its BVH and octree walks skip what lies beyond the cap,
  // and a distance of at most m is found as without it.
  bool narrow(const Object& a, const Object& b, S m, S slack) {
    fcl::CollisionResult<S> result;
    if (fclCollide(&a, &b, request_, result) > 0) return true;
    if (!(m > S(0))) return false;
    if (!raised_) return pairDistance(a, b) <= m;
    fcl::DistanceResult<S> capped;
    capped.min_distance = m + m / S(8) + slack;
    return fclDistance(&a, &b, distance_request_, capped) <= m;
  }

  S pairDistance(const Object& a, const Object& b) {
    fcl::DistanceResult<S> result;
    return fclDistance(&a, &b, distance_request_, result);
  }

  static bool onWorldNear(Object* w, ObjectId iw, Object*, ObjectId, void* data, S& best) {
    WorldNear& near = *static_cast<WorldNear*>(data);
    StateChecker& c = *near.checker;
    const VolumeSphere* s;
    const VolumeShape* h;
    c.worldRecords(*w, iw, s, h);
    const Slot& slot = c.linkRecords(near.link);
    const bool stop =
        c.lower(*near.closest, c.object(near.link), slot.sphere, slot.shape, *w, *s, *h);
    best = near.closest->bound();
    return stop;
  }

  // Hands the distance of a and b to `closest` unless their records prove it is not below its
  // bound; true (stop) once the bound is 0 or less.
  bool lower(Closest<S>& closest, const Object& a, const VolumeSphere& sa, const VolumeShape& ha,
             const Object& b, const VolumeSphere& sb, const VolumeShape& hb) {
    if (!distance_judge_.mayBeat(Records{&sa, &ha}, Records{&sb, &hb}, closest.bound()))
      return false;
    closest.add(pairDistance(a, b));
    return closest.done();
  }

  S clearanceOf(bool self) {
    fcl::DistanceResult<S> result;  // the distance alone: no nearest points are kept
    Closest<S> closest(result);
    const std::size_t n = links_.size();
    for (std::size_t l = 0; l < n && !closest.done(); ++l) {
      if (world_.size() == 0) break;
      typename Broadphase<S>::Probe p = probe(l);
      p.margin = S(0);
      WorldNear near{this, std::uint32_t(l), &closest};
      S bound = closest.bound();  // the walk's, lowered by onWorldNear
      world_.distance(p, &near, DistanceFn<S>(&StateChecker::onWorldNear), bound, nullptr);
    }
    for (std::size_t i = 0; self && i < n && !closest.done(); ++i)
      for (std::uint32_t k = links_.after_at[i]; k < links_.after_at[i + 1] && !closest.done();
           ++k) {
        const std::uint32_t j = links_.after[k];
        const Box<S> bi = rateBox(i), bj = rateBox(j);
        S gap2 = 0;
        for (int a = 0; a < 3; ++a) {
          const S g = std::max({bi.lo[a] - bj.hi[a], bj.lo[a] - bi.hi[a], S(0)});
          gap2 += g * g;
        }
        if (std::sqrt(gap2) >= closest.bound()) continue;
        const Slot& x = linkRecords(std::uint32_t(i));
        const Slot& y = linkRecords(j);
        lower(closest, object(std::uint32_t(i)), x.sphere, x.shape, object(j), y.sphere, y.shape);
      }
    return closest.bound();
  }

  const QueryScope scope_;  // a pair predicate that mutates the world is refused
  const Broadphase<S>& world_;
  const Links<S>& links_;
  const VolumeSphere* world_spheres_;
  const VolumeShape* world_shapes_;
  BodyView<S> body_;       // the links' boxes (grown by their margins) for the walk
  PairGate<S> self_gate_;  // the links' self pairs: the body's excluded pairs
  const fcl::CollisionRequest<S> request_{};
  const fcl::DistanceRequest<S> distance_request_{};
  const PairJudge<S> judge_;           // a pair's contact, or within its margins
  const PairJudge<S> distance_judge_;  // whether a pair can lower the clearance
  std::uint64_t state_ = 0;
  std::vector<Slot> slots_;
  std::vector<S> c_[3], h_[3];  // the state's posed local AABBs, per coordinate
  std::vector<S> grow_;         // per link: the cull's rate times its scale
  std::vector<S> margin_;       // per link: its margin, raised for the state by check()'s extra
  bool raised_ = false;         // margin_ holds a raised state's margins
  struct alignas(LinkObject<S>) ObjectStorage {
    unsigned char bytes[sizeof(LinkObject<S>)];
  };
  std::unique_ptr<ObjectStorage[]> objects_;  // LinkObjects, constructed on first use
  VolumeSphere built_sphere_{};
  VolumeShape built_shape_{};
  bool eager_objects_ = false;  // the world has a pair predicate: objects placed every state
  std::size_t bad_link_ = 0;
  AnyHit<Candidate> any_;           // a check for any contact
  FirstInOrder<Candidate> first_;   // a check for the first pair in Candidate's order
  std::vector<Candidate> pending_;  // pairs for FCL; its room kept between states
};

}  // namespace detail
}  // namespace cube
