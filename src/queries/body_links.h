#pragma once

// What a BodySet keeps (private to the library): per link the geometry, margin, filter bits,
// local AABB (also per coordinate, for the pose-box kernel) and the cull's record source, the
// excluded pairs (BodySet::excludePair), and the links' tree the checkers copy; the object a
// checker places for a link.

#include <fcl/narrowphase/collision_object.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/body_view.h"
#include "core/geometry.h"
#include "core/volume.h"
#include "cube_collision/batch.h"

namespace cube {
namespace detail {
/// A number no Links content had before: what a BatchScratch compares to know the body it set
/// up for is the one it is given (a copy keeps its source's, as it holds the same links).
std::uint64_t newBodyGeneration();
}  // namespace detail

template <typename S>
struct BodySet<S>::Links {
  std::vector<std::shared_ptr<fcl::CollisionGeometry<S>>> geometry;
  std::vector<S> margin;
  std::vector<detail::Filter> bits;
  std::vector<S> mid_of[3], half_of[3];  // the local AABB per coordinate: centre, half
  std::vector<S> reach;  // the farthest point of the local AABB from the link's origin, bounded
  std::vector<detail::VolumeSource> source;    // the cull's records' geometry part
  std::vector<std::uint8_t> excluded;          // size() x size(): 1 = excluded, never checked
  std::vector<std::uint32_t> after, after_at;  // checked pairs (i, after[k]) for k in
                                               // [after_at[i], after_at[i + 1]), ascending
  bool any_bits = false;                       // a link has filter bits other than the default
  detail::BodyView<S> view{0};  // the links' tree, copied by each checker (bounds per state)
  std::uint64_t generation = detail::newBodyGeneration();  // new with every change

  std::size_t size() const { return geometry.size(); }
  void listPairs() {
    const std::size_t n = size();
    after.clear();
    after_at.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      after_at[i] = std::uint32_t(after.size());
      for (std::size_t j = i + 1; j < n; ++j)
        if (!excluded[i * n + j]) after.push_back(std::uint32_t(j));
    }
    after_at[n] = std::uint32_t(after.size());
  }
};

namespace detail {

/// The batch's std::invalid_argument: "cube::<where>: <what>".
[[noreturn]] inline void batchError(const char* where, const std::string& what) {
  throw std::invalid_argument(std::string("cube::") + where + ": " + what);
}

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

struct BodyAccess {
  template <typename S>
  static const typename BodySet<S>::Links& links(const BodySet<S>& body) {
    return *body.links_;
  }
};

}  // namespace detail

}  // namespace cube
