"""python-fcl's API over cube_collision: ``import cube_collision.fcl as fcl``.

The names and signatures of python-fcl (BerkeleyAutomation/python-fcl), so that code written for
it, and trimesh's CollisionManager (trimesh/collision.py), run unchanged: geometries, Transform,
CollisionObject, the request / result / data classes, collide() and distance(), and
DynamicAABBTreeCollisionManager (python-fcl's only manager), backed by the package's cube manager.

A manager's collide() / distance() given defaultCollisionCallback / defaultDistanceCallback runs
the whole query in C++ (the package's broadphase and FCL's narrow phase, no Python call per
pair) and fills cdata.result as python-fcl's would: contacts whose o1 / o2 are the user's
geometry objects. Any other callable is called per candidate pair, as python-fcl does, with the
user's own CollisionObjects.

continuousCollide runs FCL's continuous collision of the two objects through the library's
(CCDM_TRANS and CCDM_SCREW motions). Not available (NotImplementedError, see UNSUPPORTED):
TriangleP, OcTree (the package cannot make these shapes). See docs/python.md.
"""

import itertools
import sys
import weakref

import numpy as np

from . import _core

__all__ = [
    "OBJECT_TYPE", "NODE_TYPE", "CCDMotionType", "CCDSolverType", "GJKSolverType",
    "Contact", "CostSource", "CollisionRequest", "CollisionResult", "ContinuousCollisionRequest",
    "ContinuousCollisionResult", "DistanceRequest", "DistanceResult", "CollisionData",
    "DistanceData", "Transform", "CollisionGeometry", "TriangleP", "Box", "Sphere", "Ellipsoid",
    "Capsule", "Cone", "Cylinder", "Convex", "Halfspace", "Plane", "BVHModel", "OcTree",
    "CollisionObject", "DynamicAABBTreeCollisionManager", "collide", "continuousCollide",
    "distance", "defaultCollisionCallback", "defaultDistanceCallback", "UNSUPPORTED",
]

#: python-fcl names that exist here but raise NotImplementedError, and why.
UNSUPPORTED = {
    "TriangleP": "cube_collision cannot make a single-triangle shape (use a BVHModel)",
    "OcTree": "cube_collision has no octrees (python-fcl's octomap build)",
}


def _unsupported(name):
    raise NotImplementedError("cube_collision.fcl.%s: %s" % (name, UNSUPPORTED[name]))


# ---------------------------------------------------------------------------------------------
# Enumerations and data classes (python-fcl's collision_data)


class OBJECT_TYPE:
    OT_UNKNOWN, OT_BVH, OT_GEOM, OT_OCTREE, OT_COUNT = range(5)


class NODE_TYPE:
    (BV_UNKNOWN, BV_AABB, BV_OBB, BV_RSS, BV_kIOS, BV_OBBRSS, BV_KDOP16, BV_KDOP18, BV_KDOP24,
     GEOM_BOX, GEOM_SPHERE, GEOM_ELLIPSOID, GEOM_CAPSULE, GEOM_CONE, GEOM_CYLINDER, GEOM_CONVEX,
     GEOM_PLANE, GEOM_HALFSPACE, GEOM_TRIANGLE, GEOM_OCTREE, NODE_COUNT) = range(21)


class CCDMotionType:
    CCDM_TRANS, CCDM_LINEAR, CCDM_SCREW, CCDM_SPLINE = range(4)


class CCDSolverType:
    CCDC_NAIVE, CCDC_CONSERVATIVE_ADVANCEMENT, CCDC_RAY_SHOOTING, CCDC_POLYNOMIAL_SOLVER = range(4)


class GJKSolverType:
    GST_LIBCCD, GST_INDEP = range(2)


class Contact:
    def __init__(self, o1=None, o2=None, b1=0, b2=0, normal=None, pos=None,
                 penetration_depth=0.0):
        self.o1 = o1
        self.o2 = o2
        self.b1 = b1
        self.b2 = b2
        self.normal = np.zeros(3) if normal is None else normal
        self.pos = np.zeros(3) if pos is None else pos
        self.penetration_depth = penetration_depth


class CostSource:
    def __init__(self, aabb_min=None, aabb_max=None, cost_density=0.0, total_cost=0.0):
        self.aabb_min = np.zeros(3) if aabb_min is None else aabb_min
        self.aabb_max = np.zeros(3) if aabb_max is None else aabb_max
        self.cost_density = cost_density
        self.total_cost = total_cost


class CollisionRequest:
    def __init__(self, num_max_contacts=1, enable_contact=False, num_max_cost_sources=1,
                 enable_cost=False, use_approximate_cost=True,
                 gjk_solver_type=GJKSolverType.GST_LIBCCD):
        self.num_max_contacts = num_max_contacts
        self.enable_contact = enable_contact
        self.num_max_cost_sources = num_max_cost_sources
        self.enable_cost = enable_cost
        self.use_approximate_cost = use_approximate_cost
        self.gjk_solver_type = gjk_solver_type


class CollisionResult:
    def __init__(self):
        self.contacts = []
        self.cost_sources = []
        self.is_collision = False


class ContinuousCollisionRequest:
    def __init__(self, num_max_iterations=10, toc_err=0.0001,
                 ccd_motion_type=CCDMotionType.CCDM_TRANS,
                 gjk_solver_type=GJKSolverType.GST_LIBCCD,
                 ccd_solver_type=CCDSolverType.CCDC_NAIVE):
        self.num_max_iterations = num_max_iterations
        self.toc_err = toc_err
        self.ccd_motion_type = ccd_motion_type
        self.gjk_solver_type = gjk_solver_type
        self.ccd_solver_type = ccd_solver_type


class ContinuousCollisionResult:
    def __init__(self, is_collide=False, time_of_contact=1.0):
        self.is_collide = is_collide
        self.time_of_contact = time_of_contact
        self.contact_tf1 = None
        self.contact_tf2 = None


class DistanceRequest:
    def __init__(self, enable_nearest_points=False, enable_signed_distance=False,
                 gjk_solver_type=GJKSolverType.GST_LIBCCD):
        self.enable_nearest_points = enable_nearest_points
        self.enable_signed_distance = enable_signed_distance
        self.gjk_solver_type = gjk_solver_type


class DistanceResult:
    def __init__(self, min_distance=sys.float_info.max):
        self.min_distance = min_distance
        self.nearest_points = [np.zeros(3), np.zeros(3)]
        self.o1 = None
        self.o2 = None
        self.b1 = -1
        self.b2 = -1


class CollisionData:
    def __init__(self, request=None, result=None):
        self.request = CollisionRequest() if request is None else request
        self.result = CollisionResult() if result is None else result
        self.done = False


class DistanceData:
    def __init__(self, request=None, result=None):
        self.request = DistanceRequest() if request is None else request
        self.result = DistanceResult() if result is None else result
        self.done = False


# ---------------------------------------------------------------------------------------------
# Transforms


def _vec3(v, what):
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise ValueError("%s must have 3 entries" % what)
    return a.copy()


def _mat3(m):
    a = np.array(m, dtype=np.float64)
    if a.shape != (3, 3):
        raise ValueError("a rotation must be 3x3")
    return a


def _quat_to_mat(q):
    q = np.asarray(q, dtype=np.float64).reshape(-1)
    if q.shape != (4,):
        raise ValueError("a quaternion must be (w, x, y, z)")
    n = np.linalg.norm(q)
    if not n > 0:
        raise ValueError("a quaternion must not be zero")
    w, x, y, z = q / n  # unit, as FCL's rotation from it assumes
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _mat_to_quat(m):
    # Eigen's conversion (Shepperd's method): (w, x, y, z).
    t = m[0, 0] + m[1, 1] + m[2, 2]
    if t > 0:
        s = np.sqrt(t + 1.0)
        w = 0.5 * s
        s = 0.5 / s
        return np.array([w, (m[2, 1] - m[1, 2]) * s, (m[0, 2] - m[2, 0]) * s,
                         (m[1, 0] - m[0, 1]) * s])
    i = int(np.argmax([m[0, 0], m[1, 1], m[2, 2]]))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = np.sqrt(m[i, i] - m[j, j] - m[k, k] + 1.0)
    q = np.zeros(4)
    q[1 + i] = 0.5 * s
    s = 0.5 / s
    q[0] = (m[k, j] - m[j, k]) * s
    q[1 + j] = (m[j, i] + m[i, j]) * s
    q[1 + k] = (m[k, i] + m[i, k]) * s
    return q


def _rotation_of(rot):
    a = np.asarray(rot, dtype=np.float64)
    if a.shape == (3, 3):
        return a.copy()
    if a.shape == (4,):
        return _quat_to_mat(a)
    raise ValueError("Invalid input to Transform().")


class Transform:
    """A rigid transform: Transform(), (R), (t), (q), (R, t), (q, t); q is (w, x, y, z)."""

    def __init__(self, *args):
        self._R = np.eye(3)
        self._t = np.zeros(3)
        if len(args) == 1:
            a = args[0]
            if isinstance(a, Transform):
                self._R, self._t = a._R.copy(), a._t.copy()
                return
            data = np.asarray(a, dtype=np.float64)
            if data.shape == (3, 3):
                self._R = data.copy()
            elif data.shape == (4,):
                self._R = _quat_to_mat(data)
            elif data.shape == (3,):
                self._t = data.copy()
            else:
                raise ValueError("Invalid input to Transform().")
        elif len(args) == 2:
            t = np.asarray(args[1], dtype=np.float64).squeeze()
            if t.shape != (3,):
                raise ValueError("Translation must be (3,).")
            self._R = _rotation_of(args[0])
            self._t = t.copy()
        elif len(args) > 2:
            raise ValueError("Too many arguments to Transform().")

    def getRotation(self):
        return self._R.copy()

    def getTranslation(self):
        return self._t.copy()

    def getQuatRotation(self):
        return _mat_to_quat(self._R)

    def setRotation(self, R):
        self._R = _mat3(R)

    def setTranslation(self, T):
        self._t = _vec3(T, "a translation")

    def setQuatRotation(self, q):
        self._R = _quat_to_mat(q)

    def __repr__(self):
        return "Transform(R=%r, t=%r)" % (self._R.tolist(), self._t.tolist())


# ---------------------------------------------------------------------------------------------
# Geometries: each holds a cube_collision Geometry (self._g) made once.


class CollisionGeometry:
    _node_type = NODE_TYPE.BV_UNKNOWN
    _object_type = OBJECT_TYPE.OT_GEOM

    def __init__(self):
        self._g = None

    def _geometry(self):
        if self._g is None:
            raise ValueError("%s: the geometry is not built (a BVHModel needs endModel())"
                             % type(self).__name__)
        return self._g

    def getNodeType(self):
        return self._node_type

    def computeLocalAABB(self):
        pass

    @property
    def aabb_center(self):
        box = np.asarray(self._geometry().aabb)
        return (box[0] + box[1]) / 2

    @property
    def aabb_radius(self):
        box = np.asarray(self._geometry().aabb)
        return float(np.linalg.norm(box[1] - box[0]) / 2)


class TriangleP(CollisionGeometry):
    def __init__(self, a, b, c):
        _unsupported("TriangleP")


class Ellipsoid(CollisionGeometry):
    """The ellipsoid of radii a, b, c along x, y, z."""
    _node_type = NODE_TYPE.GEOM_ELLIPSOID

    def __init__(self, a, b, c):
        self._g = _core.ellipsoid(float(a), float(b), float(c))

    @property
    def radii(self):
        return np.array(self._g.params[:3])


class Halfspace(CollisionGeometry):
    """The half-space n . x <= d (FCL normalises n and scales d with it)."""
    _node_type = NODE_TYPE.GEOM_HALFSPACE

    def __init__(self, n, d):
        self._g = _core.halfspace(_vec3(n, "Halfspace's n"), float(d))

    @property
    def n(self):
        return np.array(self._g.params[:3])

    @property
    def d(self):
        return self._g.params[3]


class OcTree(CollisionGeometry):
    def __init__(self, *args, **kwargs):
        _unsupported("OcTree")


class Box(CollisionGeometry):
    _node_type = NODE_TYPE.GEOM_BOX

    def __init__(self, x, y, z):
        self._g = _core.box(float(x), float(y), float(z))

    @property
    def side(self):
        return np.array(self._g.params[:3])


class Sphere(CollisionGeometry):
    _node_type = NODE_TYPE.GEOM_SPHERE

    def __init__(self, radius):
        self._g = _core.sphere(float(radius))

    @property
    def radius(self):
        return self._g.params[0]


class _RadiusLength(CollisionGeometry):
    _make = None

    def __init__(self, radius, lz):
        self._g = type(self)._make(float(radius), float(lz))

    @property
    def radius(self):
        return self._g.params[0]

    @property
    def lz(self):
        return self._g.params[1]


class Capsule(_RadiusLength):
    _node_type = NODE_TYPE.GEOM_CAPSULE
    _make = staticmethod(_core.capsule)


class Cone(_RadiusLength):
    _node_type = NODE_TYPE.GEOM_CONE
    _make = staticmethod(_core.cone)


class Cylinder(_RadiusLength):
    _node_type = NODE_TYPE.GEOM_CYLINDER
    _make = staticmethod(_core.cylinder)


class Plane(CollisionGeometry):
    """The plane n . x = d (FCL normalises n and scales d with it)."""
    _node_type = NODE_TYPE.GEOM_PLANE

    def __init__(self, n, d):
        self._g = _core.plane(_vec3(n, "Plane's n"), float(d))

    @property
    def n(self):
        return np.array(self._g.params[:3])

    @property
    def d(self):
        return self._g.params[3]


def _triangulate(num_faces, faces):
    """python-fcl's flattened faces [n, i0, .., i(n-1), n, ...] as triangles (fans)."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1)
    num_faces = int(num_faces)
    if num_faces > 0 and f.size == 4 * num_faces and np.all(f[::4] == 3):
        return f.reshape(-1, 4)[:, 1:]
    tris = []
    i = 0
    for _ in range(num_faces):
        if i >= f.size:
            raise ValueError("Convex: faces hold fewer than num_faces faces")
        n = int(f[i])
        idx = f[i + 1:i + 1 + n]
        if n < 3 or idx.size != n:
            raise ValueError("Convex: a face needs at least 3 vertex indices")
        tris.extend((idx[0], idx[k], idx[k + 1]) for k in range(1, n - 1))
        i += 1 + n
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


class Convex(CollisionGeometry):
    """Convex(vertices, num_faces, faces) with python-fcl's flattened face list; polygons are
    split into triangle fans (the same solid)."""
    _node_type = NODE_TYPE.GEOM_CONVEX

    def __init__(self, vertices, num_faces, faces):
        self._num_faces = int(num_faces)
        self._g = _core.convex(np.asarray(vertices, dtype=np.float64).reshape(-1, 3),
                               _triangulate(num_faces, faces))

    @property
    def num_faces(self):
        return self._num_faces


class BVHModel(CollisionGeometry):
    """A triangle mesh (FCL's OBBRSS BVH), built between beginModel() and endModel()."""
    _node_type = NODE_TYPE.BV_OBBRSS
    _object_type = OBJECT_TYPE.OT_BVH
    # FCL's BVHBuildState
    _EMPTY, _BEGUN, _PROCESSED = 0, 1, 2

    def __init__(self):
        self._g = None
        self._state = self._EMPTY
        self._verts = []
        self._tris = []
        self._nv = 0
        self._nt = 0

    def num_tries_(self):
        return self._nt

    def buildState(self):
        return self._state

    def beginModel(self, num_tris_=0, num_vertices_=0):
        self._g = None
        self._verts, self._tris, self._nv, self._nt = [], [], 0, 0
        self._state = self._BEGUN
        return 0

    def _building(self):
        if self._state != self._BEGUN:
            raise ValueError("BVH construction does not follow correct sequence")

    def addVertex(self, x, y, z):
        self._building()
        self._verts.append(np.array([[x, y, z]], dtype=np.float64))
        self._nv += 1
        return True

    def addTriangle(self, v1, v2, v3):
        self._building()
        self._verts.append(np.array([_vec3(v1, "v1"), _vec3(v2, "v2"), _vec3(v3, "v3")]))
        self._tris.append(np.arange(self._nv, self._nv + 3, dtype=np.int64).reshape(1, 3))
        self._nv += 3
        self._nt += 1
        return True

    def addSubModel(self, verts, triangles):
        self._building()
        v = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
        t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
        self._verts.append(v)
        self._tris.append(t + self._nv)
        self._nv += len(v)
        self._nt += len(t)
        return True

    def endModel(self):
        self._building()
        v = np.concatenate(self._verts) if self._verts else np.zeros((0, 3))
        t = np.concatenate(self._tris) if self._tris else np.zeros((0, 3), dtype=np.int64)
        self._g = _core.mesh(v, t)
        self._verts, self._tris = [], []
        self._state = self._PROCESSED
        return 0


# ---------------------------------------------------------------------------------------------
# Collision objects

_serial = itertools.count()


class CollisionObject:
    """A geometry placed by a transform. The managers it is registered with follow its moves
    (python-fcl's users call manager.update() after moving it; queries here also catch up)."""

    def __init__(self, geom=None, tf=None, _no_instance=False):
        if not isinstance(geom, CollisionGeometry):
            raise ValueError("CollisionObject needs a geometry (a CollisionGeometry)")
        self._geom = geom
        self._g = geom._geometry()
        self._name = "o%d" % next(_serial)
        self._managers = weakref.WeakSet()
        if tf is None:
            self._R, self._t = np.eye(3), np.zeros(3)
        else:
            self._R, self._t = tf._R.copy(), tf._t.copy()
        self._tf = None

    def _moved(self):
        self._tf = None
        for m in self._managers:
            m._dirty[self._name] = self

    def _matrix(self):
        if self._tf is None:
            tf = np.eye(4)
            tf[:3, :3] = self._R
            tf[:3, 3] = self._t
            self._tf = tf
        return self._tf

    def getObjectType(self):
        return self._geom._object_type

    def getNodeType(self):
        return self._geom.getNodeType()

    def getTranslation(self):
        return self._t.copy()

    def setTranslation(self, vec):
        self._t = _vec3(vec, "a translation")
        self._moved()

    def getRotation(self):
        return self._R.copy()

    def setRotation(self, mat):
        self._R = _mat3(mat)
        self._moved()

    def getQuatRotation(self):
        return _mat_to_quat(self._R)

    def setQuatRotation(self, q):
        self._R = _quat_to_mat(q)
        self._moved()

    def getTransform(self):
        return Transform(self._R, self._t)

    def setTransform(self, tf):
        self._R, self._t = tf._R.copy(), tf._t.copy()
        self._moved()

    def isOK(self):
        return True

    def isOccupied(self):
        return True

    def isFree(self):
        return False

    def isUncertain(self):
        return False


# ---------------------------------------------------------------------------------------------
# Pairwise queries and python-fcl's default callbacks


def collide(o1, o2, request=None, result=None):
    """fcl::collide on two objects; contacts appended to result; returns their number."""
    if request is None:
        request = CollisionRequest()
    if result is None:
        result = CollisionResult()
    return _core._fcl_pair_collide(o1._g, o1._matrix(), o2._g, o2._matrix(), request, result,
                                   Contact, o1._geom, o2._geom)


def distance(o1, o2, request=None, result=None):
    """fcl::distance on two objects; result updated if closer; returns the distance.
    ValueError for a Plane (FCL 0.7's fcl::distance crashes on it)."""
    if request is None:
        request = DistanceRequest()
    if result is None:
        result = DistanceResult()
    return _core._fcl_pair_distance(o1._g, o1._matrix(), o2._g, o2._matrix(), request, result,
                                    o1._geom, o2._geom)


def _matrix_of(tf):
    m = np.eye(4)
    m[:3, :3] = tf._R
    m[:3, 3] = tf._t
    return m


def continuousCollide(o1, tf1_end, o2, tf2_end, request=None, result=None):
    """fcl::continuousCollide of o1 and o2 moving from their transforms to tf1_end / tf2_end;
    result updated as python-fcl's (is_collide or-ed, the earliest time of contact kept, and
    here the transforms at that time as Transforms); returns the time of contact (1.0 if
    none). ValueError for CCDM_LINEAR or CCDM_SPLINE motions, which the library refuses."""
    if request is None:
        request = ContinuousCollisionRequest()
    if result is None:
        result = ContinuousCollisionResult()
    hit, toc, tf1, tf2 = _core._fcl_pair_continuous(o1._g, o1._matrix(), _matrix_of(tf1_end),
                                                    o2._g, o2._matrix(), _matrix_of(tf2_end),
                                                    request)
    result.is_collide = result.is_collide or hit
    if hit and toc < result.time_of_contact:
        result.contact_tf1 = Transform(tf1[:3, :3], tf1[:3, 3])
        result.contact_tf2 = Transform(tf2[:3, :3], tf2[:3, 3])
    result.time_of_contact = min(toc, result.time_of_contact)
    return toc


def defaultCollisionCallback(o1, o2, cdata):
    """python-fcl's: collide the pair into cdata.result; done once it holds more than
    num_max_contacts contacts. A manager given this function runs the query in C++."""
    request = cdata.request
    result = cdata.result
    if cdata.done:
        return True
    collide(o1, o2, request, result)
    if (not request.enable_cost and result.is_collision
            and len(result.contacts) > request.num_max_contacts):
        cdata.done = True
    return cdata.done


def defaultDistanceCallback(o1, o2, cdata):
    """python-fcl's: distance of the pair into cdata.result; stops at a distance <= 0. A manager
    given this function runs the query in C++."""
    request = cdata.request
    result = cdata.result
    if cdata.done:
        return True, result.min_distance
    distance(o1, o2, request, result)
    dist = result.min_distance
    if dist <= 0:
        return True, dist
    return cdata.done, dist


# ---------------------------------------------------------------------------------------------
# The manager


class DynamicAABBTreeCollisionManager:
    """python-fcl's manager, backed by cube_collision's cube manager (CollisionManager)."""

    def __init__(self, threads=1):
        # threads: the narrow phase's (python-fcl's manager has one); 0 = every core.
        self._threads = threads
        self._m = _core.CollisionManager(threads=threads)
        self._objs = {}   # name -> CollisionObject, in registration order
        self._geoms = {}  # name -> the object's geometry (what results name)
        self._dirty = {}  # name -> object moved since it was last passed to the cube manager
        # python-fcl's tuning properties of FCL's tree: kept, not used by the cube manager.
        self.max_tree_nonbalanced_level = 10
        self.tree_incremental_balance_pass = 10
        self.tree_topdown_balance_threshold = 2
        self.tree_topdown_level = 0
        self.tree_init_level = 0
        self.octree_as_geometry_collide = True
        self.octree_as_geometry_distance = False

    # -- registration

    def registerObjects(self, other_objs):
        objs = list(dict.fromkeys(other_objs))
        if not all(isinstance(o, CollisionObject) for o in objs):
            raise TypeError("registerObjects: CollisionObjects only")
        objs = [o for o in objs if o._name not in self._objs]
        if not objs:
            return
        self._m.add_objects([o._name for o in objs], [o._g for o in objs],
                            np.array([o._matrix() for o in objs]))
        for o in objs:
            self._took(o)

    def registerObject(self, obj):
        if not isinstance(obj, CollisionObject):
            raise TypeError("registerObject: a CollisionObject")
        if obj._name in self._objs:
            return
        self._m.add_object(obj._name, obj._g, obj._matrix())
        self._took(obj)

    def _took(self, obj):
        self._objs[obj._name] = obj
        self._geoms[obj._name] = obj._geom
        obj._managers.add(self)

    def unregisterObject(self, obj):
        name = getattr(obj, "_name", None)
        if name not in self._objs:
            return
        self._m.remove_object(name)
        del self._objs[name]
        del self._geoms[name]
        self._dirty.pop(name, None)
        obj._managers.discard(self)

    def setup(self):
        self._flush()

    def update(self, arg=None):
        """Passes moved objects to the broadphase: all of them (no argument), one, or a list.
        Objects not registered here are ignored, as FCL's tree ignores them."""
        if arg is None:
            self._flush()
            return
        objs = arg if hasattr(arg, "__len__") else [arg]
        names = [o._name for o in objs if getattr(o, "_name", None) in self._objs]
        if names:
            self._m.set_transforms(names, np.array([self._objs[n]._matrix() for n in names]))
            for n in names:
                self._dirty.pop(n, None)

    def _flush(self):
        if self._dirty:
            names = list(self._dirty)
            self._m.set_transforms(names, np.array([self._dirty[n]._matrix() for n in names]))
            self._dirty.clear()

    def getObjects(self):
        return list(self._objs.values())

    def clear(self):
        for o in self._objs.values():
            o._managers.discard(self)
        self._m = _core.CollisionManager(threads=self._threads)
        self._objs.clear()
        self._geoms.clear()
        self._dirty.clear()

    def empty(self):
        return not self._objs

    def size(self):
        return len(self._objs)

    # -- queries

    def _target(self, args, what):
        """(target for the core, other manager's geometries, query object, cdata, callback)."""
        if len(args) == 2 and callable(args[1]):
            return None, None, None, args[0], args[1]
        if len(args) == 3 and callable(args[2]):
            if isinstance(args[0], DynamicAABBTreeCollisionManager):
                other = args[0]
                other._flush()
                if other is self:
                    return None, None, None, args[1], args[2]
                return other._m, other._geoms, None, args[1], args[2]
            if isinstance(args[0], CollisionObject):
                q = args[0]
                return (q._g, q._matrix()), None, q, args[1], args[2]
        raise ValueError("%s: (cdata, callback), (CollisionObject, cdata, callback) or "
                         "(DynamicAABBTreeCollisionManager, cdata, callback)" % what)

    def _python_walk(self, hook, target, other_objs, query, cdata, callback, distance):
        # A user's callback, per candidate pair, with the user's CollisionObjects.
        get = self._objs.get
        oget = other_objs.get if other_objs is not None else (lambda name, default: default)

        def obj(h):
            o = get(h.name)
            return oget(h.name, query) if o is None else o

        if distance:
            def fn(a, b):
                stop, dist = callback(obj(a), obj(b), cdata)
                return bool(stop), float(dist)
        else:
            def fn(a, b):
                return bool(callback(obj(a), obj(b), cdata))
        hook(fn, target)

    def collide(self, *args):
        """collide(cdata, callback), collide(obj, cdata, callback) or
        collide(other_manager, cdata, callback), as python-fcl's."""
        target, other_geoms, query, cdata, callback = self._target(args, "collide")
        self._flush()
        if callback is defaultCollisionCallback:
            if cdata.done:
                return
            if self._m._fcl_collide_all(target, cdata.request, cdata.result, Contact,
                                        self._geoms, other_geoms,
                                        None if query is None else query._geom):
                cdata.done = True
            return
        self._python_walk(self._m._collide_python, target,
                          args[0]._objs if other_geoms is not None else None, query, cdata,
                          callback, False)

    def distance(self, *args):
        """distance(cdata, callback), distance(obj, cdata, callback) or
        distance(other_manager, cdata, callback), as python-fcl's."""
        target, other_geoms, query, cdata, callback = self._target(args, "distance")
        self._flush()
        if callback is defaultDistanceCallback:
            if cdata.done:
                return
            self._m._fcl_distance_all(target, cdata.request, cdata.result, self._geoms,
                                      other_geoms, None if query is None else query._geom)
            return
        self._python_walk(self._m._distance_python, target,
                          args[0]._objs if other_geoms is not None else None, query, cdata,
                          callback, True)
