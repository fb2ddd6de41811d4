// BodySet (include/cube_collision/batch.h): the links and what every check needs from them,
// computed once per link.

#include <fcl/narrowphase/collision_object.h>

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "queries/body_links.h"

namespace cube {

using detail::batchError;

std::uint64_t detail::newBodyGeneration() {
  // Only a source of distinct numbers: no answer depends on its value.
  static std::atomic<std::uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

template <typename S>
BodySet<S>::BodySet() : links_(std::make_unique<Links>()) {
  links_->listPairs();
}
template <typename S>
BodySet<S>::~BodySet() = default;
template <typename S>
BodySet<S>::BodySet(const BodySet& other) : links_(std::make_unique<Links>(*other.links_)) {}
template <typename S>
BodySet<S>& BodySet<S>::operator=(const BodySet& other) {
  if (this != &other) links_ = std::make_unique<Links>(*other.links_);
  return *this;
}
template <typename S>
BodySet<S>::BodySet(BodySet&& other) noexcept : links_(std::move(other.links_)) {
  other.links_ = nullptr;
}
template <typename S>
BodySet<S>& BodySet<S>::operator=(BodySet&& other) noexcept {
  std::swap(links_, other.links_);
  return *this;
}

template <typename S>
std::size_t BodySet<S>::addLink(std::shared_ptr<fcl::CollisionGeometry<S>> geometry, S margin,
                                std::uint64_t category, std::uint64_t mask) {
  if (links_ == nullptr) links_ = std::make_unique<Links>();  // a moved-from set
  const char* where = "BodySet::addLink";
  if (geometry == nullptr) batchError(where, "null geometry");
  const fcl::NODE_TYPE type = geometry->getNodeType();
  if (type == fcl::GEOM_PLANE || type == fcl::GEOM_HALFSPACE)
    batchError(where, "a plane or halfspace cannot be a link (unbounded)");
  if (!(margin >= S(0)) || !std::isfinite(margin))
    batchError(where, "the margin must be finite and >= 0");
  geometry->computeLocalAABB();
  const fcl::AABB<S>& local = geometry->aabb_local;
  if (!local.min_.allFinite() || !local.max_.allFinite() ||
      !(local.min_.array() <= local.max_.array()).all())
    batchError(where, "the geometry's local AABB is not finite");
  Links& l = *links_;
  const std::size_t n = l.size();
  detail::VolumeSource source;
  detail::VolumeSphere sphere;
  detail::VolumeShape shape;
  const fcl::CollisionObject<S> at_origin(geometry);
  detail::rebuildVolume(at_origin, source, sphere, shape);
  std::vector<std::uint8_t> excluded((n + 1) * (n + 1), 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) excluded[i * (n + 1) + j] = l.excluded[i * n + j];
  detail::BodyView<S> view(std::uint32_t(n + 1));
  // Nothing can throw from here on but allocation, before any member changes.
  l.geometry.reserve(n + 1);
  l.margin.reserve(n + 1);
  l.bits.reserve(n + 1);
  for (int d = 0; d < 3; ++d) {
    l.mid_of[d].reserve(n + 1);
    l.half_of[d].reserve(n + 1);
  }
  l.source.reserve(n + 1);
  l.reach.reserve(n + 1);
  l.geometry.push_back(std::move(geometry));
  l.margin.push_back(margin);
  l.bits.push_back(detail::Filter{category, mask});
  const fcl::Vector3<S> mid = local.center(), half = (local.max_ - local.min_) / S(2);
  for (int d = 0; d < 3; ++d) {
    l.mid_of[d].push_back(mid[d]);
    l.half_of[d].push_back(half[d]);
  }
  l.reach.push_back(mid.norm() + half.norm());
  l.source.push_back(source);
  l.excluded = std::move(excluded);
  l.any_bits = l.any_bits || !l.bits.back().isDefault();
  l.view = std::move(view);
  l.listPairs();
  l.generation = detail::newBodyGeneration();
  return n;
}

template <typename S>
void BodySet<S>::excludePair(std::size_t i, std::size_t j) {
  const std::size_t n = size();
  if (i >= n || j >= n) batchError("BodySet::excludePair", "unknown link index");
  if (i == j) batchError("BodySet::excludePair", "a link is never checked against itself");
  links_->excluded[i * n + j] = links_->excluded[j * n + i] = 1;
  links_->listPairs();
  links_->generation = detail::newBodyGeneration();
}

template <typename S>
bool BodySet<S>::checked(std::size_t i, std::size_t j) const {
  const std::size_t n = size();
  return i < n && j < n && i != j && !links_->excluded[i * n + j];
}

template <typename S>
std::size_t BodySet<S>::size() const {
  return links_ == nullptr ? 0 : links_->size();
}

template <typename S>
const std::shared_ptr<fcl::CollisionGeometry<S>>& BodySet<S>::geometry(std::size_t i) const {
  return links_->geometry.at(i);
}

template <typename S>
S BodySet<S>::margin(std::size_t i) const {
  return links_->margin.at(i);
}

template class BodySet<double>;
template class BodySet<float>;

}  // namespace cube
