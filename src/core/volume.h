#pragma once

// An object's tight volumes as the object table keeps them per id, so that the cull (cull.h)
// reads two small records a pair instead of two FCL objects and their geometries. Floats, built
// in the objects' scalar type and rounded outward (inward for the inscribed ball), so that each
// record holds the object's true volumes; the cull's margin covers its own float arithmetic. No
// FCL or Eigen types: the table lives in the core.

#include <cstdint>

namespace fcl {
template <typename S>
class CollisionObject;
template <typename S>
class CollisionGeometry;
}  // namespace fcl

namespace cube {
namespace detail {

/// The bounding sphere: centre c, radius r. r < 0: the object has no volumes the cull may use
/// (a plane, a halfspace, an octree, no geometry, a non-finite size or pose, or a centre or size
/// beyond kVolumeMaxScale).
struct VolumeSphere {
  float c[3];
  float r;
};
static_assert(sizeof(VolumeSphere) == 16, "four spheres per cache line");
/// No volumes: the cull leaves the pair to FCL.
inline constexpr VolumeSphere kNoVolume{{0.f, 0.f, 0.f}, -1.f};
/// A kept record whose object moved since it was built (ObjectTable, below
/// kVolumeRebuildMinObjects): its radius. Negative, so that a reader that does not look for it
/// sees a record without volumes and leaves the pair to FCL.
inline constexpr float kStaleRadius = -2.f;
inline bool isStale(const VolumeSphere& s) {
  return s.r == kStaleRadius;
}
/// The largest coordinate or size (VolumeShape::scale) of an object with volumes: the cull's float
/// arithmetic squares differences of coordinates, which must stay below float's range.
inline constexpr float kVolumeMaxScale = 1e18f;

/// The rest, read only when the spheres settle nothing: the oriented box of the geometry's local
/// AABB about the sphere's centre (axes the columns of the row-major R, half extents e), the
/// scale of the record's coordinates (max |c|, r: the cull's margin grows with it), and a ball
/// inside the shape (centre c + inner_z along R's third column, radius inner_r; 0: none).
struct VolumeShape {
  float R[9];
  float e[3];
  float scale;
  float inner_r;
  float inner_z;
  /// kVolumeSphere: the geometry is a sphere (r exact, no box needed); kVolumeBox,
  /// kVolumeRound, kVolumeHeavy: its kind, as the cost of FCL's call on a pair sees it;
  /// kVolumeCapsule, kVolumeCylinder, kVolumeCone: the primitive, for the cull's round bounds
  std::uint32_t flags;
};
static_assert(sizeof(VolumeShape) == 64, "one record per cache line");

inline constexpr std::uint32_t kVolumeSphere = 1u;
/// The kinds FCL 0.7 answers in closed form with a sphere (kVolumeRound: capsules, cylinders)
/// or, for boxes, with a box too; kVolumeHeavy: a mesh (its call walks a BVH).
inline constexpr std::uint32_t kVolumeBox = 4u;
inline constexpr std::uint32_t kVolumeRound = 8u;
inline constexpr std::uint32_t kVolumeHeavy = 16u;
/// The primitive, for the cull's round and inner bounds (cull.h): set only for FCL's capsules,
/// cylinders and cones centred on their frame's origin with finite sizes >= 0 (every one FCL
/// builds), whose local AABB then gives their sizes: (r, r, lz / 2 + r) for a capsule, (r, r,
/// lz / 2) for a cylinder and a cone (base at -lz / 2).
inline constexpr std::uint32_t kVolumeCapsule = 32u;
inline constexpr std::uint32_t kVolumeCylinder = 64u;
inline constexpr std::uint32_t kVolumeCone = 128u;
inline constexpr std::uint32_t kVolumeKinds = kVolumeSphere | kVolumeBox | kVolumeRound |
                                              kVolumeHeavy | kVolumeCapsule | kVolumeCylinder |
                                              kVolumeCone;

/// Builds `o`'s records from its transform and geometry (local AABB, kind, size): the inscribed
/// ball only for occupied spheres, boxes, capsules, cylinders, cones and ellipsoids.
template <typename S>
void buildVolume(const fcl::CollisionObject<S>& o, VolumeSphere& sphere, VolumeShape& shape);

/// The records of an object of no table as the cull builds them on the fly, level by level, each
/// only where the last leaves the pair open. First the sphere: the bounding sphere FCL keeps per
/// geometry (aabb_center and aabb_radius; a sphere's own centre and radius), placed by the
/// object's transform and rounded outward as buildVolume's, and the scale of its coordinates
/// (VolumeShape::scale). sphere.r < 0 where buildVolume gives no volumes. `exact`: the geometry is
/// a sphere (its sphere is all its records say about distance). `geometry`, `pose`: the
/// object's geometry and transform (4x4, by columns), which the next levels read.
template <typename S>
struct VolumeBall {
  VolumeSphere sphere;
  float scale;
  bool exact;
  const fcl::CollisionGeometry<S>* geometry;
  const S* pose;
};
template <typename S>
void buildBall(const fcl::CollisionObject<S>& o, VolumeBall<S>& ball);
/// The next level, for an object whose `ball` (buildBall's) has volumes: the oriented box of
/// the geometry's local AABB about the ball's centre, rounded outward, and the ball's scale; for
/// a sphere its flag kVolumeSphere alone. No inner ball, kind or round primitive: what
/// separationOf reads. False where the box is not about the ball's centre (a local AABB changed
/// without computeLocalAABB) or is not finite.
template <typename S>
bool buildBox(const VolumeBall<S>& ball, VolumeShape& shape);
/// The last level, on buildBox's `shape` of the same object: the ball inside the geometry that
/// buildVolume keeps (occupied spheres, boxes, capsules, cylinders, cones and ellipsoids centred
/// on their frame's origin), rounded inward; false, and `shape` as it was, for the others.
template <typename S>
bool buildInner(const VolumeBall<S>& ball, VolumeShape& shape);

/// What an object's records are built from: its geometry's part (the local AABB's centre and
/// half extents, the bounding radius, the inscribed ball, the kind), read from the geometry at
/// registration and by rebuildVolume only, and the translation of the last transform placed,
/// rounded to floats (its rotation is VolumeShape::R). Records are kept while the object's
/// transform rounds to the same floats: the slack of placeVolume covers what such a transform
/// moves them by.
struct VolumeSource {
  float mid[3];
  float e[3];
  float r;
  float inner_r;  ///< 0: none
  float inner_z;
  std::uint32_t flags;  ///< kVolumeSphere, kVolumeNone
  float t[3];
  float unused = 0.f;
};
static_assert(sizeof(VolumeSource) == 56, "14 floats");

/// The geometry has no volumes the cull may use.
inline constexpr std::uint32_t kVolumeNone = 2u;

/// The records from the object's geometry and transform (both read).
template <typename S>
void rebuildVolume(const fcl::CollisionObject<S>& o, VolumeSource& source, VolumeSphere& sphere,
                   VolumeShape& shape);

/// The records for an object that moved: the geometry's part in `source` (read again from the
/// geometry only if its local AABB no longer rounds to it) and the object's transform.
template <typename S>
void moveVolume(const fcl::CollisionObject<S>& o, VolumeSource& source, VolumeSphere& sphere,
                VolumeShape& shape);

/// moveVolume unless `o`'s transform rounds to the floats the records were built from;
/// returns whether it moved them. For an
/// object whose box did not change: a rotation may leave FCL's box of an object as it was. Reads
/// the object only, not its geometry, so that an update() of a still world costs a compare.
template <typename S>
bool refreshVolume(const fcl::CollisionObject<S>& o, VolumeSource& source, VolumeSphere& sphere,
                   VolumeShape& shape);

extern template void buildVolume<double>(const fcl::CollisionObject<double>&, VolumeSphere&,
                                         VolumeShape&);
extern template void buildVolume<float>(const fcl::CollisionObject<float>&, VolumeSphere&,
                                        VolumeShape&);
extern template void buildBall<double>(const fcl::CollisionObject<double>&, VolumeBall<double>&);
extern template void buildBall<float>(const fcl::CollisionObject<float>&, VolumeBall<float>&);
extern template bool buildBox<double>(const VolumeBall<double>&, VolumeShape&);
extern template bool buildBox<float>(const VolumeBall<float>&, VolumeShape&);
extern template bool buildInner<double>(const VolumeBall<double>&, VolumeShape&);
extern template bool buildInner<float>(const VolumeBall<float>&, VolumeShape&);
extern template void moveVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&,
                                        VolumeSphere&, VolumeShape&);
extern template void moveVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&,
                                       VolumeSphere&, VolumeShape&);
extern template void rebuildVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&,
                                           VolumeSphere&, VolumeShape&);
extern template void rebuildVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&,
                                          VolumeSphere&, VolumeShape&);
extern template bool refreshVolume<double>(const fcl::CollisionObject<double>&, VolumeSource&,
                                           VolumeSphere&, VolumeShape&);
extern template bool refreshVolume<float>(const fcl::CollisionObject<float>&, VolumeSource&,
                                          VolumeSphere&, VolumeShape&);

}  // namespace detail
}  // namespace cube
