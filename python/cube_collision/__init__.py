"""cube_collision: collision checking for many objects, in C++, with trimesh's vocabulary.

    import cube_collision
    m = cube_collision.CollisionManager()            # was: trimesh.collision.CollisionManager()
    m.add_object("a", mesh, transform)               # a Trimesh (convex if mesh.is_convex), or
                                                     # cube_collision.mesh(v, f)
    hit, names = m.in_collision_internal(return_names=True)

Geometry: mesh, convex, box, sphere, ellipsoid, cylinder, capsule, cone, plane, halfspace (each
returns a Geometry).
The manager (CollisionManager) runs every query in C++ (broadphase, culling, FCL's narrow phase)
with the GIL released; backend="fcl" builds it on FCL's DynamicAABBTreeCollisionManager instead.
Batched planner checks: Body and CollisionManager.check_states / check_motions. Everything
pickles. python-fcl's API (for code written for it, and trimesh's CollisionManager):
`import cube_collision.fcl as fcl`. See docs/python.md.
"""

from ._core import (  # noqa: F401
    ALL_BITS,
    Body,
    CollisionManager,
    Geometry,
    UnknownNameError,
    box,
    capsule,
    cone,
    convex,
    cylinder,
    ellipsoid,
    halfspace,
    mesh,
    pair_distance,
    pair_in_collision,
    plane,
    sphere,
)

__version__ = "0.1.0"

__all__ = [
    "ALL_BITS", "Body", "CollisionManager", "Geometry", "UnknownNameError", "box", "capsule",
    "cone", "convex", "cylinder", "ellipsoid", "halfspace", "mesh", "pair_distance",
    "pair_in_collision", "plane", "sphere",
]
