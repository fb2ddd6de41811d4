"""Type stubs of cube_collision._core (the pybind11 module); docstrings are on the objects."""

from typing import Any, Callable, Dict, List, Optional, Protocol, Sequence, Set, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Transform = Optional[npt.ArrayLike]  # 4x4 rigid; None: identity

ALL_BITS: int

class _HasMesh(Protocol):
    """A trimesh.Trimesh or alike: a convex() if it has a true `is_convex`, else a mesh()."""
    vertices: Any
    faces: Any

GeometryLike = Union["Geometry", _HasMesh]

class UnknownNameError(KeyError, ValueError):
    """No object has this name (a KeyError, and a ValueError as trimesh raises)."""

class Geometry:
    """A collision shape in its own frame (mesh, convex, box, sphere, ellipsoid, cylinder, capsule,
    cone, plane, halfspace)."""
    @property
    def kind(self) -> str: ...
    @property
    def params(self) -> List[float]: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def aabb(self) -> npt.NDArray[np.float64]: ...
    def __getstate__(self) -> tuple: ...
    def __setstate__(self, state: tuple) -> None: ...

def mesh(vertices: ArrayLike, faces: ArrayLike) -> Geometry:
    """A triangle mesh (FCL's OBBRSS BVH). ValueError / TypeError on bad arrays."""
def convex(vertices: ArrayLike, faces: ArrayLike) -> Geometry:
    """A convex polyhedron (FCL's Convex), e.g. a convex hull's vertices and triangles."""
def box(x: float, y: float, z: float) -> Geometry:
    """A box of these full side lengths, centred on the origin."""
def sphere(radius: float) -> Geometry:
    """A sphere centred on the origin."""
def halfspace(normal: ArrayLike, offset: float = 0.0) -> Geometry:
    """The solid half-space n . x <= offset (unbounded: 'cube' backend only)."""
def ellipsoid(a: float, b: float, c: float) -> Geometry:
    """An ellipsoid of these radii along x, y and z, centred on the origin."""
def cylinder(radius: float, height: float) -> Geometry:
    """A cylinder along z, centred on the origin."""
def capsule(radius: float, height: float) -> Geometry:
    """A capsule along z: the segment of this height grown by radius."""
def cone(radius: float, height: float) -> Geometry:
    """A cone along z, base at -height/2, apex at height/2."""
def plane(normal: ArrayLike, offset: float = 0.0) -> Geometry:
    """The plane n . x = offset (cube backend only)."""

def pair_in_collision(geometry_a: GeometryLike, transform_a: Transform,
                      geometry_b: GeometryLike, transform_b: Transform) -> bool:
    """FCL's own fcl::collide on two placed geometries, its defects included."""
def pair_distance(geometry_a: GeometryLike, transform_a: Transform,
                  geometry_b: GeometryLike, transform_b: Transform) -> float:
    """fcl::distance on two placed geometries (<= 0 when they touch); ValueError for a plane
    (FCL 0.7's fcl::distance crashes on it)."""

Contacts = Dict[str, npt.NDArray[Any]]  # 'names' (n, 2) object, 'points' (n, 3), 'normals' (n, 3), 'depths' (n,)
DistanceData = Dict[str, Any]           # 'distance', 'names' (a, b) or None, 'points' (2, 3) or None
StateAnswers = Dict[str, npt.NDArray[Any]]  # 'colliding', 'link', 'object', 'other_link', 'clearance'

class Body:
    """The moving bodies (a robot's links) of check_states / check_motions."""
    def __init__(self) -> None: ...
    def add_link(self, geometry: GeometryLike, *, margin: float = 0.0, category: int = 1,
                 mask: int = ...) -> int:
        """Adds a link; returns its index."""
    def exclude_pair(self, i: int, j: int) -> None:
        """Links i and j are never checked against each other."""
    def allow_pair(self, i: int, j: int) -> None:
        """Alias of exclude_pair (the former name)."""
    def __len__(self) -> int: ...
    @property
    def excluded_pairs(self) -> List[Tuple[int, int]]: ...
    @property
    def allowed_pairs(self) -> List[Tuple[int, int]]:
        """Alias of excluded_pairs (the former name)."""

class CollisionManager:
    """Named collision objects with trimesh.collision.CollisionManager's calls, in C++."""
    def __init__(self, backend: str = "cube", threads: int = 0) -> None: ...
    @property
    def backend(self) -> str: ...
    @property
    def threads(self) -> int: ...
    @property
    def names(self) -> List[str]: ...
    @property
    def excluded_pairs(self) -> List[Tuple[str, str]]: ...
    @property
    def ignored_pairs(self) -> List[Tuple[str, str]]:
        """Alias of excluded_pairs."""
    def __len__(self) -> int: ...
    def __contains__(self, name: object) -> bool: ...

    def add_object(self, name: str, geometry: Optional[GeometryLike] = None,
                   transform: Transform = None, *, mesh: Optional[GeometryLike] = None,
                   category: int = 1, mask: int = ..., margin: Optional[float] = None) -> Geometry:
        """Adds an object (geometry, or trimesh's keyword mesh); returns its Geometry.
        ValueError for an existing name or a bad transform."""
    def add_objects(self, names: Sequence[str], geometries: Sequence[GeometryLike],
                    transforms: Optional[ArrayLike] = None) -> None:
        """Adds many objects in one build of the tree; all checked first."""
    def remove_object(self, name: str) -> None:
        """Removes an object. UnknownNameError (KeyError and ValueError) if unknown."""
    def set_transform(self, name: str, transform: ArrayLike) -> None:
        """Moves one object. TypeError for a None transform (no default: not the identity)."""
    def set_transforms(self, names: Sequence[str], transforms: ArrayLike) -> None:
        """Moves many objects ((n, 4, 4) transforms) in one tree update; all checked first."""
    def get_transform(self, name: str) -> npt.NDArray[np.float64]: ...
    def get_geometry(self, name: str) -> Geometry: ...
    def set_filter(self, name: str, category: int, mask: int) -> None:
        """Filter bits: a pair is tested if a.category & b.mask and b.category & a.mask."""
    def get_filter(self, name: str) -> Tuple[int, int]: ...
    def exclude_pair(self, name_a: str, name_b: str) -> None:
        """Never test or report this pair."""
    def include_pair(self, name_a: str, name_b: str) -> None:
        """Undoes exclude_pair."""
    def clear_excluded(self) -> None: ...
    def pair_passes(self, name_a: str, name_b: str) -> bool:
        """Whether the internal queries test and report this pair once the boxes overlap."""
    def ignore_pair(self, name_a: str, name_b: str) -> None:
        """Alias of exclude_pair."""
    def unignore_pair(self, name_a: str, name_b: str) -> None:
        """Alias of include_pair."""
    def clear_ignored(self) -> None:
        """Alias of clear_excluded."""
    def set_margin(self, margin: float, name: Optional[str] = None) -> None:
        """Contact margin of one object or of the manager."""
    def get_margin(self, name: Optional[str] = None) -> float: ...

    def in_collision_internal(self, return_names: bool = False, return_data: bool = False,
                              max_contacts: int = 100000) -> Union[
                                  bool, Tuple[bool, Set[Tuple[str, str]]], Tuple[bool, Contacts],
                                  Tuple[bool, Set[Tuple[str, str]], Contacts]]:
        """is_collision[, set of sorted name pairs][, contacts]."""
    def in_collision_single(self, geometry: Optional[GeometryLike] = None,
                            transform: Transform = None, return_names: bool = False,
                            return_data: bool = False, max_contacts: int = 100000, *,
                            mesh: Optional[GeometryLike] = None) -> Union[
                                bool, Tuple[bool, Set[str]], Tuple[bool, Contacts],
                                Tuple[bool, Set[str], Contacts], npt.NDArray[np.bool_]]:
        """is_collision[, set of names][, contacts]; with an (n, 4, 4) transform, a numpy bool
        array of n (one answer per pose)."""
    def in_collision_other(self, other_manager: "CollisionManager", return_names: bool = False,
                           return_data: bool = False, max_contacts: int = 100000) -> Union[
                               bool, Tuple[bool, Set[Tuple[str, str]]], Tuple[bool, Contacts],
                               Tuple[bool, Set[Tuple[str, str]], Contacts]]:
        """is_collision[, set of (name here, name there)][, contacts]."""
    def min_distance_internal(self, return_names: bool = False, return_data: bool = False,
                              name: Optional[str] = None) -> Union[
                                  float, Tuple[float, Optional[Tuple[str, str]]],
                                  Tuple[float, DistanceData],
                                  Tuple[float, Optional[Tuple[str, str]], DistanceData]]:
        """distance[, sorted name pair][, data]; with name, from that object to the others. A pair
        with a plane (cube backend): its exact distance, -1 when they meet."""
    def min_distance_single(self, geometry: Optional[GeometryLike] = None,
                            transform: Transform = None, return_name: bool = False,
                            return_data: bool = False, *,
                            mesh: Optional[GeometryLike] = None) -> Union[
                                float, Tuple[float, Optional[str]], Tuple[float, DistanceData],
                                Tuple[float, Optional[str], DistanceData]]:
        """distance[, name][, data]. A plane (cube backend): its exact distance, -1 when they
        meet."""
    def min_distance_other(self, other_manager: "CollisionManager", return_names: bool = False,
                           return_data: bool = False
                           ) -> Union[float, Tuple[float, Optional[Tuple[str, str]]],
                                      Tuple[float, DistanceData],
                                      Tuple[float, Optional[Tuple[str, str]], DistanceData]]:
        """distance[, (name here, name there)][, data]. A plane with a cube manager taking part:
        its exact distance, -1 when they meet."""

    def ray_first(self, origins: ArrayLike, ends: ArrayLike, narrow_phase: bool = True,
                  tolerance: float = 1e-6, *, filter: Optional[Tuple[int, int]] = None
                  ) -> Tuple[npt.NDArray[np.object_], npt.NDArray[np.float64],
                             npt.NDArray[np.float64]]:
        """(names or None, t or NaN, points) of the first hit of each segment; filter: the
        query's (category, mask) bits (None: every object)."""
    def ray_all(self, origin: ArrayLike, end: ArrayLike, narrow_phase: bool = True,
                tolerance: float = 1e-6, *, filter: Optional[Tuple[int, int]] = None
                ) -> Tuple[List[str], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(names, t, points) of every hit of one segment, by t."""
    def objects_in_box(self, lower: ArrayLike, upper: ArrayLike, *,
                       filter: Optional[Tuple[int, int]] = None) -> List[str]: ...
    def objects_near(self, point: ArrayLike, radius: float, *,
                     filter: Optional[Tuple[int, int]] = None) -> List[str]: ...
    def objects_in_capsule(self, a: ArrayLike, b: ArrayLike, radius: float, *,
                           filter: Optional[Tuple[int, int]] = None) -> List[str]: ...

    def check_states(self, body: Body, poses: ArrayLike, *, self_collision: bool = False,
                     first_pair: bool = False, clearance: bool = False,
                     threads: Optional[int] = None) -> StateAnswers:
        """Many states (poses (states, links, 4, 4)) of body against this world."""
    def check_motions(self, body: Body, poses: ArrayLike, edge_starts: ArrayLike, *,
                      order: str = "path", self_collision: bool = False,
                      continuous: bool = False, motion_bounds: Optional[ArrayLike] = None,
                      threads: Optional[int] = None) -> npt.NDArray[np.int64]:
        """Per edge, the first colliding state's index within it, or -1. continuous=True (SE(3)
        bounds from the poses) or motion_bounds (states, links): -1 only if nothing can be
        touched between consecutive states either."""

    def _collide_python(self, callback: Callable[["_Handle", "_Handle"], bool],
                        target: Any = None) -> None: ...
    def _distance_python(self, callback: Callable[["_Handle", "_Handle"], Tuple[bool, float]],
                         target: Any = None) -> None: ...
    def _fcl_collide_all(self, target: Any, request: Any, result: Any, contact_type: Any,
                         geoms: Dict[str, Any], other_geoms: Optional[Dict[str, Any]],
                         query_geom: Any) -> bool: ...
    def _fcl_distance_all(self, target: Any, request: Any, result: Any, geoms: Dict[str, Any],
                          other_geoms: Optional[Dict[str, Any]], query_geom: Any) -> None: ...
    def __getstate__(self) -> dict: ...
    def __setstate__(self, state: dict) -> None: ...

class _Handle:
    name: str
    geometry: Optional[Geometry]

def _fcl_pair_collide(geometry_a: GeometryLike, transform_a: Transform, geometry_b: GeometryLike,
                      transform_b: Transform, request: Any, result: Any, contact_type: Any,
                      o1: Any, o2: Any) -> int: ...
def _fcl_pair_distance(geometry_a: GeometryLike, transform_a: Transform,
                       geometry_b: GeometryLike, transform_b: Transform, request: Any,
                       result: Any, o1: Any, o2: Any) -> float: ...
