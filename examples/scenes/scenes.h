#pragma once

// Scene generators shared by the tests, the benchmarks and the demo: FCL-style random worlds of
// boxes, spheres and cylinders (or the same as meshes), deterministic from a seed.

#include <cstdint>
#include <memory>
#include <vector>

#include <fcl/narrowphase/collision_object.h>

namespace cube {
namespace scenes {

/// How objects are spread in the world.
enum class Layout {
  uniform,    ///< uniformly in a cube of half-size `half_extent`
  clustered,  ///< in a few dense Gaussian blobs
  thin,       ///< long thin rods (aspect about 20:1) in random orientations
};

/// What to generate. Sizes scale with n so that each object overlaps about
/// `overlaps_per_object` others (AABB overlaps) in the uniform layout.
struct SceneOptions {
  std::size_t n = 1000;
  Layout layout = Layout::uniform;
  bool meshes = false;  ///< BVHModel<OBBRSS> triangle meshes instead of primitive shapes
  std::uint32_t seed = 1;
  double half_extent = 2000;
  double overlaps_per_object = 1.0;
  /// Scale on object sizes: 0 makes zero-size boxes, small values give scenes where nothing
  /// touches (for distance queries).
  double size_scale = 1.0;
};

/// Owns the objects of a scene.
template <typename S>
struct Scene {
  std::vector<std::unique_ptr<fcl::CollisionObject<S>>> objects;
  /// Raw pointers in creation order, as managers take them.
  std::vector<fcl::CollisionObject<S>*> pointers() const;
};

/// Builds a scene; every object's AABB is computed.
template <typename S>
Scene<S> makeScene(const SceneOptions& options);

/// Typical object size (AABB side) that the options produce.
double typicalSize(const SceneOptions& options);

/// Moves `fraction` of the objects (chosen from `seed`) by up to `step` in each axis and
/// optionally rotates them; recomputes their AABBs and returns the moved objects.
template <typename S>
std::vector<fcl::CollisionObject<S>*> jitter(Scene<S>& scene, double fraction, double step,
                                             bool rotate, std::uint32_t seed);

}  // namespace scenes
}  // namespace cube
