// NarrowPhaseCache's own members (include/cube_collision/narrow_phase.h); its tables are in
// cache.h.

#include "pipeline/cache.h"

#include <cstddef>
#include <memory>

namespace cube {

template <typename S>
NarrowPhaseCache<S>::NarrowPhaseCache() : impl_(std::make_unique<Impl>()) {}
template <typename S>
NarrowPhaseCache<S>::~NarrowPhaseCache() = default;
template <typename S>
NarrowPhaseCache<S>::NarrowPhaseCache(NarrowPhaseCache&&) noexcept = default;
template <typename S>
NarrowPhaseCache<S>& NarrowPhaseCache<S>::operator=(NarrowPhaseCache&&) noexcept = default;

template <typename S>
void NarrowPhaseCache<S>::clear() {
  impl_->collide.clear();
  impl_->distance.clear();
  impl_->seen.clear();
  impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
void NarrowPhaseCache<S>::forget(const fcl::CollisionObject<S>* obj) {
  impl_->forget(obj);
  if (impl_->last_hit.first == obj || impl_->last_hit.second == obj)
    impl_->last_hit = {nullptr, nullptr};
}

template <typename S>
std::size_t NarrowPhaseCache<S>::size() const {
  return impl_->collide.size() + impl_->distance.size();
}

template class NarrowPhaseCache<double>;
template class NarrowPhaseCache<float>;

}  // namespace cube
