#pragma once

// Any callable as an FCL callback, without std::function: the callable's address travels as FCL's
// `void* cdata` and one function pointer calls it. CubeCollisionManager's callable overloads are
// built on these; they work with any fcl::BroadPhaseCollisionManager, e.g.
//   manager.collide(obj, cube::callable::erase(f), &cube::callable::collideThunk<double, F>);

#include <fcl/narrowphase/collision_object.h>

#include <memory>
#include <type_traits>

namespace cube::callable {

/// The address of `f` as FCL's `void* cdata`, for collideThunk or distanceThunk of its type. `f`
/// must outlive the query.
template <class F>
void* erase(F& f) noexcept {
  return const_cast<void*>(static_cast<const void*>(std::addressof(f)));
}

/// An fcl::CollisionCallBack<S> whose cdata is erase(f) of an F (or F&): returns f(a, b) as a bool
/// (true stops the query), or false if f returns void.
template <class S, class F>
bool collideThunk(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* f) {
  using Fn = std::remove_reference_t<F>;
  using Object = fcl::CollisionObject<S>;
  if constexpr (std::is_void_v<std::invoke_result_t<Fn&, Object*, Object*>>) {
    (*static_cast<Fn*>(f))(a, b);
    return false;
  } else {
    return static_cast<bool>((*static_cast<Fn*>(f))(a, b));
  }
}

/// An fcl::DistanceCallBack<S> whose cdata is erase(f) of an F (or F&): returns f(a, b, dist) as a
/// bool (true stops the query), or false if f returns void; f lowers dist to prune the search.
template <class S, class F>
bool distanceThunk(fcl::CollisionObject<S>* a, fcl::CollisionObject<S>* b, void* f, S& dist) {
  using Fn = std::remove_reference_t<F>;
  using Object = fcl::CollisionObject<S>;
  if constexpr (std::is_void_v<std::invoke_result_t<Fn&, Object*, Object*, S&>>) {
    (*static_cast<Fn*>(f))(a, b, dist);
    return false;
  } else {
    return static_cast<bool>((*static_cast<Fn*>(f))(a, b, dist));
  }
}

}  // namespace cube::callable
