#pragma once

// One thread's checker of the batched checks (queries/batch.cpp): the links placed for a state,
// the world's walks through the core's query entries, the cull on the records, FCL on the rest.
// The walk a run of states shares is in state_group.h, a state's clearance in
// state_clearance.h, a mesh against a grown primitive in grown_shapes.h. Private to the library.

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
#include <optional>
#include <type_traits>
#include <utility>
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
#include "queries/grown_shapes.h"

namespace cube {
namespace detail {

template <typename S>
using Links = typename BodySet<S>::Links;

// One thread's checker: the links' objects, boxes and records for the state at hand, and the
// walks of the world. Made once per thread and call; no allocation per state.
template <typename S>
class StateChecker {
 public:
  using Object = fcl::CollisionObject<S>;

  StateChecker(const Broadphase<S>& world, const Links<S>& links)
      : world_(world),
        links_(links),
        world_spheres_(world.table().spheres()),
        world_shapes_(world.table().shapes()),
        body_(links.view),
        judge_(request_),
        distance_judge_(distance_request_) {
    // The per-link arrays in one block: a batch of one state makes a checker for itself, and
    // each allocation of a kilobyte or more costs the allocator a sweep of its freed chunks.
    const std::size_t n = links.size();
    const std::size_t leaves = body_.leafCount();
    const std::size_t slot_at = 0;
    const std::size_t object_at = roundUp(slot_at + n * sizeof(Slot), alignof(ObjectStorage));
    const std::size_t number_at = roundUp(object_at + n * sizeof(ObjectStorage), alignof(S));
    const std::size_t flag_at = number_at + 20 * n * sizeof(S);
    const std::size_t order_at = roundUp(flag_at + leaves + n, alignof(std::uint32_t));
    const std::size_t end_at = order_at + 2 * leaves * sizeof(std::uint32_t);
    block_.reset(new Chunk[(end_at + sizeof(Chunk) - 1) / sizeof(Chunk)]);
    unsigned char* base = block_[0].bytes;
    slots_ = reinterpret_cast<Slot*>(base + slot_at);
    for (std::size_t l = 0; l < n; ++l) {
      new (&slots_[l]) Slot;  // the records written before read
      slots_[l].source = links.source[l];
    }
    self_gate_.excluded = links.excluded.data();  // the pairs BodySet::excludePair rules out
    self_gate_.excluded_n = n;
    margin_ = links.margin.data();
    objects_ = reinterpret_cast<ObjectStorage*>(base + object_at);  // constructed on first use
    close_ = base + flag_at;
    need_ = close_ + leaves;
    leaf_order_ = reinterpret_cast<std::uint32_t*>(base + order_at);
    leaf_hits_ = leaf_order_ + leaves;
    for (std::size_t k = 0; k < leaves; ++k) {
      leaf_order_[k] = std::uint32_t(k);
      leaf_hits_[k] = 0;
    }
    std::fill(close_, need_ + n, std::uint8_t(0));
    S* next = reinterpret_cast<S*>(base + number_at);  // written before read
    for (int d = 0; d < 3; ++d) {
      c_[d] = next;
      h_[d] = next + n;
      lo_[d] = next + 2 * n;
      hi_[d] = next + 3 * n;
      at_lo_[d] = next + 4 * n;
      at_hi_[d] = next + 5 * n;
      next += 6 * n;
    }
    grow_ = next;
    far_ = next + n;
    for (std::uint32_t l = 0; l < links.size(); ++l) body_.setObject(l, objectAt(l));
    eager_objects_ = bool(world.predicate());
    openScope();
  }

  /// For a checker kept from an earlier call on the same world and links (BatchScratch): what
  /// it read of the world then (its volumes may have been made or moved since, its predicate
  /// set or cleared).
  void rebind() {
    world_spheres_ = world_.table().spheres();
    world_shapes_ = world_.table().shapes();
    eager_objects_ = bool(world_.predicate());
  }
  /// Names the world as read by a query on this thread (the constructor does) until
  /// closeScope(); a checker kept between calls is closed in between.
  void openScope() { scope_.emplace(&world_); }
  void closeScope() { scope_.reset(); }
  // Reads nothing of the world or the links: a checker kept between calls may outlive them.
  ~StateChecker() {
    for (std::size_t l = 0; l < link_count_; ++l)
      if (slots_[l].made) objectAt(std::uint32_t(l))->~LinkObject<S>();
  }
  StateChecker(const StateChecker&) = delete;
  StateChecker& operator=(const StateChecker&) = delete;

  /// Whether the state collides; the first pair and the clearance into `out` as asked.
  /// kBadPose (and the link in badLink()) if a pose has a NaN or infinite entry, found while
  /// placing the links: the state's poses are read once.
  /// `extra` (null, or one value >= 0 per link): each link's margin raised by its value for this
  /// state alone (a continuous edge's motion bounds).
  static constexpr int kBadPose = -1;
  int check(const fcl::Transform3<S>* poses, bool self, bool first_pair, bool clearance,
            StateResult<S>* out, const S* extra = nullptr) {
    placeGroup(&poses, 1, self, extra != nullptr ? &extra : nullptr);
    return checkPlaced(0, self, first_pair, clearance, out);
  }

  /// Takes the links' poses of the first states of `count` (1 <= count <= kGroupStates),
  /// states[j] those of state j, and returns how many it took (1 or more), each then checked by
  /// checkPlaced(j). Where states lie close together (an edge's, leaf by leaf of the links'
  /// tree), it takes the largest such run of count, count / 2, ... states (kGroupMinStates or
  /// more), and those links share one walk of the world over a box that holds all their boxes
  /// in those states (from their positions alone: no state is placed here), the pairs it meets
  /// that stay apart over the run are dropped (dropApart); a state then places only the links
  /// left with a pair, and tests their boxes against those objects. The
  /// other links walk the world state by state. Otherwise it takes all `count`, each state
  /// placed and walking as it is checked. With a pair predicate (which sees each state's link
  /// objects) every state walks. The poses must stay until the last checkPlaced of the run.
  /// `extras` (null, or extras[j] as check()'s `extra` for state j): the states' raised margins.
  std::size_t placeGroup(const fcl::Transform3<S>* const* states, std::size_t count, bool self,
                         const S* const* extras = nullptr);

  /// State j of the run placeGroup took last: as check() for its poses.
  int checkPlaced(std::size_t j, bool self, bool first_pair, bool clearance, StateResult<S>* out) {
    const std::size_t n = links_.size();
    if (raised_) margin_ = raised_margins_.data() + j * n;
    const fcl::Transform3<S>* poses = state_poses_[j];
    select(poses);
    if (!shared_ || clearance) {  // every link (a clearance walks them all)
      if (!place(poses, 0, n)) return kBadPose;
      if (!shared_) {
        for (std::size_t l = 0; l < n; ++l) body_.box(std::uint32_t(l)) = walkedBox(l);
        // search() walks the world leaf by leaf; only the self pairs walk the whole tree.
        if (self)
          body_.refit();
        else
          body_.refitLeaves();
      }
    } else {
      // The links that met nothing in the run are not placed; their poses are still checked
      // (all of them placed where the check cannot tell at once).
      if (sumIsFinite(poses->data(), 16 * n)) {
        for (const auto& [first, end] : runs_) place(poses, first, end - first);
      } else if (!place(poses, 0, n)) {
        return kBadPose;
      }
    }
    if (eager_objects_)  // a predicate sees every link object the walk offers: placed now
      for (std::uint32_t l = 0; l < n; ++l) object(l);
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

  /// The most states placeGroup takes.
  static constexpr std::size_t kGroupStates = 32;

 private:
  // Fewer states than this never share a walk; a walk shared by states whose boxes span more
  // than kGroupSpread times one state's (extents summed over the links) is not tried.
  static constexpr std::size_t kGroupMinStates = 3;
  static constexpr S kGroupSpread = S(2);

  // Per link: the cull's records (placed on first use), its object's state.
  struct Slot {
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
  // A world object a group's walk met for a link: its box as the walks test it.
  struct WorldPair {
    Box<S> box;
    ObjectId id;
  };

  static bool onGather(Object*, ObjectId iw, Object*, ObjectId link, void* data) {
    static_cast<StateChecker*>(data)->gather_.emplace_back(link, iw);
    return false;
  }
  static bool onGatherSelf(Object*, ObjectId x, Object*, ObjectId y, void* data) {
    static_cast<StateChecker*>(data)->self_pairs_.emplace_back(std::min(x, y), std::max(x, y));
    return false;
  }

  // The collector of a search: C names it by type, so the walks' callbacks find it statically.
  template <class C>
  C& hits() {
    if constexpr (C::kOrdered)
      return first_;
    else
      return any_;
  }

  // The selected state's pairs into collector C; whether it holds a hit.
  template <class C>
  bool search(bool self) {
    C& hits = this->hits<C>();
    hits.reset();
    if (shared_) return searchShared<C>(self);
    // The world leaf by leaf of the links' tree: a state in contact stops at the first group of
    // links that touches, and a free one walks little more than the whole tree at once would.
    // In link order where the first pair in that order is asked for; otherwise the groups that
    // touched most often first (a planner's states in contact mostly touch with the same links,
    // and each group checked first for nothing costs a whole walk).
    const std::size_t leaves = body_.leafCount();
    for (std::size_t i = 0; i < leaves && world_.size() != 0 && !hits.found(); ++i) {
      const std::size_t k = C::kOrdered ? i : leaf_order_[i];
      pending_.clear();
      world_.collide(body_.leafView(k), links_.any_bits ? links_.bits.data() : nullptr, this,
                     CollideFn<S>(&StateChecker::onWorld<C>), nullptr);
      if (hits.complete() || decidePending(hits)) {
        if (!C::kOrdered) countHit(i);
        return true;
      }
    }
    if (self) {
      pending_.clear();
      if (walkSelf<C>()) return true;
      decidePending(hits);
    }
    return hits.found();
  }

  // A contact found by the leaf at place i of leaf_order_: counted, and the leaf moved ahead of
  // those with fewer (counts halved before they overflow, keeping their order).
  void countHit(std::size_t i) {
    const std::uint32_t k = leaf_order_[i];
    if (++leaf_hits_[k] == UINT32_MAX)
      for (std::size_t j = 0; j < body_.leafCount(); ++j) leaf_hits_[j] /= 2;
    for (; i > 0 && leaf_hits_[leaf_order_[i - 1]] < leaf_hits_[k]; --i)
      leaf_order_[i] = leaf_order_[i - 1];
    leaf_order_[i] = k;
  }

  // The links' self pairs over the whole links' tree into collector C; whether its answer is
  // complete.
  template <class C>
  bool walkSelf() {
    collideViews(body_.view(), body_.view(), CollideFn<S>(&StateChecker::onLinks<C>), this, true, 0,
                 nullptr, &self_gate_);
    return hits<C>().complete();
  }

  // search() on the pairs the group's walk found, each kept if the state's boxes overlap, for
  // the leaves of links that took part in it; the other leaves walk the world as search() does.
  template <class C>
  bool searchShared(bool self);

  // Drops the pairs the walk shared by the run met that stay apart in every state of it: a
  // link's records in the run's middle state grown by how far any point of it moves from there
  // (sweptRecords) are apart from the other's records by more than the pair's margin. A link
  // left with no pair is then not placed state by state.
  void dropApart(const fcl::Transform3<S>* const* states, std::size_t count);

  // Link l's records in state `ref` of the run's first `count`, grown by the farthest any point
  // of its local AABB moves from there in a state of the run (translation, plus the rotation's
  // change, by its Frobenius norm, times the AABB's reach): they hold the link in every state.
  // Only what holds for the grown volume is kept (no inscribed ball, no cone bound); false
  // where the link has no records there or the bound is not finite.
  bool sweptRecords(const fcl::Transform3<S>* const* states, std::size_t count, std::size_t ref,
                    std::uint32_t l, VolumeSphere& sphere, VolumeShape& shape);

  typename Broadphase<S>::Probe probe(std::size_t l) {
    return typename Broadphase<S>::Probe{&object(std::uint32_t(l)), rateBox(l), margin_[l],
                                         links_.bits[l]};
  }

  // Link l's largest margin over the first `count` states of the run (raised, or its own).
  S runMargin(std::uint32_t l, std::size_t count) const;

  // Whether links first .. first + size - 1 lie close enough together over the states to share
  // a walk: each link's positions over the states span (extents summed over the links) less
  // than kGroupSpread - 1 times the links' own extents (the union of a link's boxes is then
  // within about kGroupSpread times one state's), and every position is finite. Keeps each
  // link's positions' box (at_lo_, at_hi_) and largest coordinate (far_).
  bool closeTogether(const S* const* states, std::size_t count, std::uint32_t first,
                     std::uint32_t size);
  S spreadOf(std::uint32_t l) const;

  // Links first .. first + count - 1 of the state posed by `poses` (the one selected): their
  // boxes, the boxes the walks test (walkedBox: the exact box of each posed local AABB grown by
  // the cull's rate, so that pairs FCL counts as touching within its tolerance are met, and by
  // the link's margin). False for a pose with a NaN or infinite entry (its link in bad_link_).
  bool place(const fcl::Transform3<S>* poses, std::size_t first, std::size_t count) {
    const std::size_t f = first;
    static_assert(sizeof(fcl::Transform3<S>) == 16 * sizeof(S), "a pose is 16 numbers");
    // In the kernels (four links per instruction with AVX2): placing the links is most of a
    // free state's check in a clustered world.
    poseBoxes(poses[f].data(), count,
              PoseBoxes<S>{{links_.mid_of[0].data() + f, links_.mid_of[1].data() + f,
                            links_.mid_of[2].data() + f},
                           {links_.half_of[0].data() + f, links_.half_of[1].data() + f,
                            links_.half_of[2].data() + f},
                           {c_[0] + f, c_[1] + f, c_[2] + f},
                           {h_[0] + f, h_[1] + f, h_[2] + f}});
    const bool finite = walkBoxes(count, WalkBoxes<S>{{c_[0] + f, c_[1] + f, c_[2] + f},
                                                      {h_[0] + f, h_[1] + f, h_[2] + f},
                                                      margin_ + f,
                                                      S(judge_.rate()),
                                                      grow_ + f,
                                                      {lo_[0] + f, lo_[1] + f, lo_[2] + f},
                                                      {hi_[0] + f, hi_[1] + f, hi_[2] + f}});
    if (!finite) {  // every entry of R and t reaches c or h
      for (std::size_t l = first; l < first + count; ++l)
        if (!poses[l].linear().allFinite() || !poses[l].translation().allFinite()) {
          bad_link_ = l;
          return false;
        }
    }
    return true;
  }

  // Link l's walked box in the state selected.
  Box<S> walkedBox(std::size_t l) const {
    Box<S> b;
    for (int d = 0; d < 3; ++d) {
      b.lo[d] = lo_[d][l];
      b.hi[d] = hi_[d][l];
    }
    return b;
  }

  // Makes the state posed by `poses` the one the records, objects and probes read.
  void select(const fcl::Transform3<S>* poses) {
    ++state_;
    poses_ = poses;
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
      objectAt(l)->place(poses_[l], lo, hi);
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
        // A pair with a mesh (its records prove no contact) whose mesh's centre lies in the
        // other's box, for a check that takes any hit: FCL at once, so that a state in contact
        // stops at its first such contact. Those pairs mostly meet, and FCL finds that quickly;
        // the other mesh pairs wait for the group's walk to end: a near miss costs FCL's BVH
        // walk far more than a contact does, and is tried only if no contact turned up first.
        if constexpr (!C::kOrdered)
          if (meshCentreInside(sa, ha, sb, hb)) return decide(hits, c) && hits.complete();
        pending_.push_back(c);
        return false;
    }
    return false;
  }

  // Whether one side is a mesh whose bounding sphere's centre lies in the other's box.
  static bool meshCentreInside(const VolumeSphere& sa, const VolumeShape& ha,
                               const VolumeSphere& sb, const VolumeShape& hb) {
    if (!(sa.r >= 0.f) || !(sb.r >= 0.f)) return false;  // a side without records
    return ((hb.flags & kVolumeHeavy) != 0 && volume_detail::pointBox(sb.c, sa, ha) <= 0.f) ||
           ((ha.flags & kVolumeHeavy) != 0 && volume_detail::pointBox(sa.c, sb, hb) <= 0.f);
  }

  // FCL on a pair the records left open; a contact is handed to the collector. Whether it is one.
  template <class C>
  bool decide(C& hits, const Candidate& c) {
    const S m =
        c.is_link ? margin_[c.link] + margin_[c.other] : margin_[c.link] + world_.marginOf(c.other);
    const Object& b =
        c.is_link ? static_cast<const Object&>(object(c.other)) : *world_.table().object(c.other);
    if (!narrow(object(c.link), b, m, c)) return false;
    hits.add(c);
    return true;
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
      if (decide(hits, c)) break;
    }
    return hits.complete();
  }

  // The world object's records: the table's, or built here (a world that keeps none, or a stale
  // record: an object that moved in a small world).
  void worldRecords(const Object& w, ObjectId iw, const VolumeSphere*& s, const VolumeShape*& h) {
    if (world_spheres_ != nullptr && !isStale(world_spheres_[iw])) {
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

  // FCL's answer for pair c: contact, or (margin m > 0) a distance of at most m. With raised
  // margins (a continuous edge's), FCL's distance starts from a cap above m (an eighth more,
  // plus the links' tolerance, beyond rounding): its BVH and octree walks skip what lies beyond
  // the cap, and a distance of at most m is found as without it.
  bool narrow(const Object& a, const Object& b, S m, const Candidate& c) {
    const bool raised = raised_ && m > S(0);
    S cap = 0;
    if (raised) {
      const S slack = c.is_link ? grow_[c.link] + grow_[c.other] : grow_[c.link];
      cap = m + m / S(8) + slack;
      // The grown primitive holds the primitive: clear of it, the pair neither touches nor
      // comes within m, and neither FCL call below is needed.
      if (grown_.apart(a, b, cap, request_)) return false;
    }
    fcl::CollisionResult<S> result;
    if (fclCollide(&a, &b, request_, result) > 0) return true;
    if (!(m > S(0))) return false;
    if (!raised) return pairDistance(a, b) <= m;
    fcl::DistanceResult<S> capped;
    capped.min_distance = cap;
    return fclDistance(&a, &b, distance_request_, capped) <= m;
  }

  S pairDistance(const Object& a, const Object& b) {
    fcl::DistanceResult<S> result;
    return fclDistance(&a, &b, distance_request_, result);
  }

  // The clearance of the state placed (state_clearance.h).
  static bool onWorldNear(Object* w, ObjectId iw, Object*, ObjectId, void* data, S& best);
  // Hands the distance of a and b to `closest` unless their records prove it is not below its
  // bound; true (stop) once the bound is 0 or less.
  bool lower(Closest<S>& closest, const Object& a, const VolumeSphere& sa, const VolumeShape& ha,
             const Object& b, const VolumeSphere& sb, const VolumeShape& hb);
  S clearanceOf(bool self);

  std::optional<QueryScope> scope_;  // a pair predicate that mutates the world is refused
  const Broadphase<S>& world_;
  const Links<S>& links_;
  const std::size_t link_count_ = links_.size();
  const VolumeSphere* world_spheres_;
  const VolumeShape* world_shapes_;
  BodyView<S> body_;       // the links' boxes (grown by their margins) for the walk
  PairGate<S> self_gate_;  // the links' self pairs: the body's excluded pairs
  const fcl::CollisionRequest<S> request_{};
  const fcl::DistanceRequest<S> distance_request_{};
  const PairJudge<S> judge_;           // a pair's contact, or within its margins
  const PairJudge<S> distance_judge_;  // whether a pair can lower the clearance
  std::uint64_t state_ = 0;
  // The block of the per-link arrays below (slots_, objects_, the numbers, close_, need_).
  struct alignas(std::max({alignof(Slot), alignof(LinkObject<S>), alignof(S)})) Chunk {
    unsigned char bytes[64];
  };
  static std::size_t roundUp(std::size_t at, std::size_t to) { return (at + to - 1) / to * to; }
  std::unique_ptr<Chunk[]> block_;
  static_assert(std::is_trivially_destructible<Slot>::value, "the block's release ends them");
  Slot* slots_ = nullptr;
  // Per link, in the state at hand: the posed local AABB per coordinate (centre, half
  // extents), the cull's rate times its scale, the walked box.
  // The per-link numbers, n each: the block's.
  S* c_[3];
  S* h_[3];
  S* lo_[3];
  S* hi_[3];
  S* grow_;
  const fcl::Transform3<S>* poses_ = nullptr;  // the state's
  const fcl::Transform3<S>* state_poses_[kGroupStates] = {};
  // A walk shared by the run placeGroup took: per link l its world objects
  // world_pairs_[world_at_[l] .. world_at_[l + 1]), the pairs of links whose boxes may meet, and
  // the links a state places (runs_, ranges of links), from the links' positions over the run.
  bool shared_ = false;
  bool self_shared_ = false;  // every leaf took part: the self pairs too
  // Per link: the margins of the state checked (its links' margins, or raised_margins_' entries
  // of the state in its run).
  const S* margin_ = nullptr;
  std::vector<S> raised_margins_;  // per state of the run and link: its raised margin
  bool raised_ = false;            // the run's margins are raised
  std::uint8_t* close_ = nullptr;  // per leaf of the links' tree: its links took part (block)
  std::uint8_t* need_ = nullptr;   // per link: placed in each state (block)
  // The leaves in the order a check for any contact walks them, and per leaf the contacts its
  // walk found (block): kept with the checker (BatchScratch) from call to call.
  std::uint32_t* leaf_order_ = nullptr;
  std::uint32_t* leaf_hits_ = nullptr;
  S* at_lo_[3];  // per link and coordinate: its positions' box over the run
  S* at_hi_[3];
  S* far_;  // per link: its positions' largest coordinate
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs_;
  std::vector<std::pair<std::uint32_t, ObjectId>> gather_;  // (link, world id) in walk order
  std::vector<std::uint32_t> world_at_, bucket_fill_;
  std::vector<WorldPair> world_pairs_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> self_pairs_;
  // The links of close leaves that met something, leaf by leaf: leaf k's pair_links_[leaf_at_[k]
  // .. leaf_at_[k + 1]).
  std::vector<std::uint32_t> pair_links_, leaf_at_;
  // Per link: its records grown to hold it over the run (dropApart), made on first use.
  struct Swept {
    VolumeSphere sphere;
    VolumeShape shape;
    bool made;
    bool usable;
  };
  std::vector<Swept> swept_;
  struct alignas(LinkObject<S>) ObjectStorage {
    unsigned char bytes[sizeof(LinkObject<S>)];
  };
  ObjectStorage* objects_ = nullptr;  // the block's room for LinkObjects, made on first use
  VolumeSphere built_sphere_{};
  VolumeShape built_shape_{};
  bool eager_objects_ = false;  // the world has a pair predicate: objects placed every state
  std::size_t bad_link_ = 0;
  GrownShapes<S> grown_;            // a mesh against a primitive grown by a raised margin
  AnyHit<Candidate> any_;           // a check for any contact
  FirstInOrder<Candidate> first_;   // a check for the first pair in Candidate's order
  std::vector<Candidate> pending_;  // pairs for FCL; its room kept between states
};

}  // namespace detail
}  // namespace cube

// The walks a run of states shares (placeGroup and what it calls).
#include "queries/state_group.h"
// The clearance of a state (clearanceOf and what it calls).
#include "queries/state_clearance.h"
