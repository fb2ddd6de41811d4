#pragma once

// The walk a run of states shares (StateChecker::placeGroup and what it calls): whether the
// states lie close together leaf by leaf of the links' tree, one walk of the world over boxes
// that hold the links over the run, and the pairs it met that stay apart over the whole run
// dropped on the links' swept records. Included by state_checker.h only, after the class.

#include <algorithm>
#include <cstdint>
#include <limits>

namespace cube {
namespace detail {

/// A box that holds the walked box (placeBoxes: the posed local AABB grown by rate (1 + its
/// largest coordinate and half extent) and by margin) of a link whose local AABB lies within
/// `reach` of its origin, at any rotation and any position in [lo, hi] (`far`: the largest
/// absolute coordinate there): the positions' box grown by reach, by twice the largest growth
/// (rounding is far below it) and by the margin.
template <typename S>
Box<S> sweptBox(const fcl::Vector3<S>& lo, const fcl::Vector3<S>& hi, S far, S reach, S rate,
                S margin) {
  const S g = reach + S(2) * rate * (S(1) + far + reach) + margin;
  Box<S> u;
  for (int d = 0; d < 3; ++d) {
    u.lo[d] = lo[d] - g;
    u.hi[d] = hi[d] + g;
  }
  return u;
}

template <typename S>
std::size_t StateChecker<S>::placeGroup(const fcl::Transform3<S>* const* states, std::size_t count,
                                        bool self, const S* const* extras) {
  const std::size_t n = links_.size();
  shared_ = false;
  raised_ = extras != nullptr;
  margin_ = links_.margin.data();
  if (raised_) {
    if (raised_margins_.empty()) raised_margins_.resize(kGroupStates * n);  // once, if ever
    for (std::size_t j = 0; j < count; ++j)
      for (std::size_t l = 0; l < n; ++l)
        raised_margins_[j * n + l] = links_.margin[l] + extras[j][l];
    margin_ = raised_margins_.data();
  }
  for (std::size_t j = 0; j < count; ++j) state_poses_[j] = states[j];
  if (eager_objects_) return count;
  const std::size_t all_count = count;
  bool any = false, all = true;
  const S* data[kGroupStates];  // each state's poses as numbers
  for (std::size_t j = 0; j < count; ++j) data[j] = states[j]->data();
  for (; count >= kGroupMinStates; count /= 2) {
    all = true;
    for (std::size_t k = 0; k < body_.leafCount(); ++k) {
      close_[k] = closeTogether(data, count, body_.leafFirst(k), body_.leafSize(k));
      any = any || close_[k];
      all = all && close_[k];
    }
    if (any) break;
  }
  if (!any) return all_count;
  // A box around each link of a close leaf over the states (sweptBox); an empty box for the
  // links that walk state by state.
  const S rate = S(judge_.rate());
  for (std::size_t k = 0; k < body_.leafCount(); ++k)
    for (std::uint32_t l = body_.leafFirst(k); l < body_.leafFirst(k) + body_.leafSize(k); ++l) {
      Box<S>& u = body_.box(l);
      if (close_[k]) {
        u = sweptBox(fcl::Vector3<S>(at_lo_[0][l], at_lo_[1][l], at_lo_[2][l]),
                     fcl::Vector3<S>(at_hi_[0][l], at_hi_[1][l], at_hi_[2][l]), far_[l],
                     links_.reach[l], rate, runMargin(l, count));
      } else {
        for (int d = 0; d < 3; ++d) {
          u.lo[d] = std::numeric_limits<S>::max();
          u.hi[d] = std::numeric_limits<S>::lowest();
        }
      }
    }
  body_.refit();
  shared_ = true;
  self_shared_ = all;
  gather_.clear();
  if (world_.size() != 0)
    world_.collide(body_.view(), links_.any_bits ? links_.bits.data() : nullptr, this,
                   CollideFn<S>(&StateChecker::onGather), nullptr);
  // Bucketed by link, in walk order within a link.
  world_at_.assign(n + 1, 0);
  for (const auto& g : gather_) ++world_at_[g.first + 1];
  for (std::size_t l = 0; l < n; ++l) world_at_[l + 1] += world_at_[l];
  world_pairs_.resize(gather_.size());
  bucket_fill_.assign(world_at_.begin(), world_at_.end() - 1);
  const Scene<S> scene = world_.scene();
  for (const auto& g : gather_)
    world_pairs_[bucket_fill_[g.first]++] = WorldPair{scene.item(g.second).box, g.second};
  self_pairs_.clear();
  if (self && self_shared_)
    collideViews(body_.view(), body_.view(), CollideFn<S>(&StateChecker::onGatherSelf), this, true,
                 0, nullptr, &self_gate_);
  dropApart(states, count);
  // The links each state places: those that met something, those of leaves that walk, and
  // every link when the self pairs walk state by state.
  runs_.clear();
  pair_links_.clear();
  leaf_at_.resize(body_.leafCount() + 1);
  for (std::size_t k = 0; k < body_.leafCount(); ++k) {
    leaf_at_[k] = std::uint32_t(pair_links_.size());
    for (std::uint32_t l = body_.leafFirst(k); l < body_.leafFirst(k) + body_.leafSize(k); ++l) {
      const bool met = world_at_[l] != world_at_[l + 1];
      if (close_[k] && met) pair_links_.push_back(l);
      need_[l] = !close_[k] || (self && !self_shared_) || met;
    }
  }
  leaf_at_[body_.leafCount()] = std::uint32_t(pair_links_.size());
  for (const auto& [i, j] : self_pairs_) need_[i] = need_[j] = 1;
  for (std::uint32_t l = 0; l < n; ++l)
    if (need_[l]) {
      if (!runs_.empty() && runs_.back().second == l)
        ++runs_.back().second;
      else
        runs_.emplace_back(l, l + 1);
    }
  return count;
}

template <typename S>
template <class C>
bool StateChecker<S>::searchShared(bool self) {
  C& hits = this->hits<C>();
  const std::size_t n = links_.size();
  // The leaves in search()'s order: a hit is counted for the leaf that found it.
  const auto world_hit = [&](std::size_t i) {
    if (!C::kOrdered) countHit(i);
    return true;
  };
  for (std::size_t i = 0; i < body_.leafCount() && !hits.found(); ++i) {
    const std::size_t k = C::kOrdered ? i : leaf_order_[i];
    const std::uint32_t first = body_.leafFirst(k), end = first + body_.leafSize(k);
    if (close_[k] && leaf_at_[k] == leaf_at_[k + 1]) continue;  // its links met nothing
    pending_.clear();
    if (close_[k]) {
      for (std::uint32_t at = leaf_at_[k]; at < leaf_at_[k + 1]; ++at) {
        const std::uint32_t l = pair_links_[at];
        const Box<S> box = walkedBox(l);
        for (std::uint32_t p = world_at_[l]; p < world_at_[l + 1]; ++p) {
          const WorldPair& w = world_pairs_[p];
          if (!overlap(box, w.box)) continue;
          if (onWorld<C>(world_.table().object(w.id), w.id, nullptr, l, this)) return world_hit(i);
        }
      }
    } else if (world_.size() != 0) {
      for (std::uint32_t l = first; l < end; ++l) body_.box(l) = walkedBox(l);
      body_.refitLeaf(k);
      world_.collide(body_.leafView(k), links_.any_bits ? links_.bits.data() : nullptr, this,
                     CollideFn<S>(&StateChecker::onWorld<C>), nullptr);
      if (hits.complete()) return world_hit(i);
    }
    if (decidePending(hits)) return world_hit(i);
  }
  if (self) {
    pending_.clear();
    if (self_shared_) {
      for (const auto& [i, j] : self_pairs_)
        if (overlap(walkedBox(i), walkedBox(j)) && onLinks<C>(nullptr, i, nullptr, j, this))
          return true;
    } else {
      for (std::size_t l = 0; l < n; ++l) body_.box(std::uint32_t(l)) = walkedBox(l);
      body_.refit();
      if (walkSelf<C>()) return true;
    }
    decidePending(hits);
  }
  return hits.found();
}

template <typename S>
void StateChecker<S>::dropApart(const fcl::Transform3<S>* const* states, std::size_t count) {
  const std::size_t n = links_.size(), mid = count / 2;
  swept_.resize(n);  // room once
  for (Swept& w : swept_) w.made = false;
  const auto swept = [&](std::uint32_t l) -> const Swept* {
    Swept& w = swept_[l];
    if (!w.made) {
      w.made = true;
      w.usable = sweptRecords(states, count, mid, l, w.sphere, w.shape);
    }
    return w.usable ? &w : nullptr;
  };
  std::uint32_t kept = 0, begin = 0;
  for (std::uint32_t l = 0; l < n; ++l) {
    const std::uint32_t end = world_at_[l + 1];
    world_at_[l] = kept;
    const Swept* w = end > begin ? swept(l) : nullptr;
    for (std::uint32_t i = begin; i < end; ++i) {
      const WorldPair& p = world_pairs_[i];
      if (w != nullptr) {
        const VolumeSphere* s;
        const VolumeShape* h;
        worldRecords(*world_.table().object(p.id), p.id, s, h);
        if (judge_.withinMargin(Records{&w->sphere, &w->shape}, Records{s, h},
                                runMargin(l, count) + world_.marginOf(p.id)) == Verdict::kApart)
          continue;
      }
      world_pairs_[kept++] = p;
    }
    begin = end;
  }
  world_at_[n] = kept;
  std::size_t self_kept = 0;
  for (const auto& [i, j] : self_pairs_) {
    const Swept* a = swept(i);
    const Swept* b = a != nullptr ? swept(j) : nullptr;
    if (b != nullptr &&
        judge_.withinMargin(Records{&a->sphere, &a->shape}, Records{&b->sphere, &b->shape},
                            runMargin(i, count) + runMargin(j, count)) == Verdict::kApart)
      continue;
    self_pairs_[self_kept++] = {i, j};
  }
  self_pairs_.resize(self_kept);
}

template <typename S>
bool StateChecker<S>::sweptRecords(const fcl::Transform3<S>* const* states, std::size_t count,
                                   std::size_t ref, std::uint32_t l, VolumeSphere& sphere,
                                   VolumeShape& shape) {
  const fcl::Transform3<S>& at = states[ref][l];
  double move = 0;
  for (std::size_t j = 0; j < count; ++j) {
    const fcl::Transform3<S>& p = states[j][l];
    const double turn = double((p.linear() - at.linear()).norm());
    const double shift = double((p.translation() - at.translation()).norm());
    move = std::max(move, shift + double(links_.reach[l]) * turn);
  }
  if (!(move < double(kVolumeMaxScale))) return false;  // NaN too
  if (!slots_[l].made) construct(l);
  objectAt(l)->setTransform(at);
  moveVolume(*objectAt(l), slots_[l].source, sphere, shape);
  if (!(sphere.r >= 0.f)) return false;
  // Outward: the sums in double, raised by far more than the float rounding's 2^-24.
  const auto up = [move](float x) { return float((double(x) + move) * (1.0 + 1e-6)); };
  sphere.r = up(sphere.r);
  for (float& e : shape.e) e = up(e);
  shape.scale = std::max(shape.scale, sphere.r);
  shape.inner_r = 0.f;
  shape.flags &= ~kVolumeCone;
  return true;
}

template <typename S>
S StateChecker<S>::runMargin(std::uint32_t l, std::size_t count) const {
  if (!raised_) return links_.margin[l];
  const std::size_t n = links_.size();
  S m = raised_margins_[l];
  for (std::size_t j = 1; j < count; ++j) m = std::max(m, raised_margins_[j * n + l]);
  return m;
}

template <typename S>
bool StateChecker<S>::closeTogether(const S* const* states, std::size_t count, std::uint32_t first,
                                    std::uint32_t size) {
  S extent = 0;
  for (std::uint32_t l = first; l < first + size; ++l)
    extent += S(2) * (links_.half_of[0][l] + links_.half_of[1][l] + links_.half_of[2][l]) +
              S(6) * margin_[l];
  const S limit = (kGroupSpread - S(1)) * extent;
  // The first link alone, then the rest: states far apart (random samples) stop at the first.
  if (!positionBoxes(states, count, first, 1, at_lo_, at_hi_) || !(spreadOf(first) <= limit))
    return false;
  if (size > 1 && !positionBoxes(states, count, first + 1, size - 1, at_lo_, at_hi_)) return false;
  S spread = 0;
  for (std::uint32_t l = first; l < first + size; ++l) {
    spread += spreadOf(l);
    S far = 0;
    for (int d = 0; d < 3; ++d)
      far = std::max({far, std::abs(at_lo_[d][l]), std::abs(at_hi_[d][l])});
    far_[l] = far;
  }
  return spread <= limit;
}

template <typename S>
S StateChecker<S>::spreadOf(std::uint32_t l) const {
  return (at_hi_[0][l] - at_lo_[0][l]) + (at_hi_[1][l] - at_lo_[1][l]) +
         (at_hi_[2][l] - at_lo_[2][l]);
}

}  // namespace detail
}  // namespace cube
