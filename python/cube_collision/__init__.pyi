from ._core import (
    ALL_BITS as ALL_BITS,
    Body as Body,
    CollisionManager as CollisionManager,
    Geometry as Geometry,
    UnknownNameError as UnknownNameError,
    box as box,
    capsule as capsule,
    cone as cone,
    convex as convex,
    cylinder as cylinder,
    ellipsoid as ellipsoid,
    halfspace as halfspace,
    mesh as mesh,
    pair_distance as pair_distance,
    pair_in_collision as pair_in_collision,
    plane as plane,
    sphere as sphere,
)

__version__: str
__all__: list[str]
