"""python-fcl's module as python-fcl runs a manager's query, for trimesh_collision.py: the
benchmark's stand-in for `import fcl` where python-fcl is not installable.

The manager is FCL's DynamicAABBTreeCollisionManager (CollisionManager(backend="fcl",
threads=1)), and its collide / distance are python-fcl's: FCL's tree calls the Python callback
given (python-fcl's defaultCollisionCallback / defaultDistanceCallback, in Python below as in
python-fcl's .pyx) for every candidate pair with a new Python object per side
(_collide_python / _distance_python), and the callback calls collide / distance, compiled as in
python-fcl (C++ here, cube_collision_bench.fcl_collide / fcl_distance: the request read from
its Python attributes, FCL's narrow phase, each contact a Python Contact naming the user's
geometry objects, which python-fcl reads from the FCL object's user data).

Only what trimesh's CollisionManager calls is here: Transform, BVHModel, Convex, CollisionObject,
the request / result / data classes, DynamicAABBTreeCollisionManager, the default callbacks.
Building is not timed and is done the simple way (update() passes the moved objects only).
"""

import itertools

import numpy as np

import cube_collision as cc
import cube_collision_bench as bench
from cube_collision.fcl import Transform, _triangulate  # noqa: F401  (trimesh's Transform)
from trimesh_way import (CollisionData, CollisionRequest, CollisionResult, Contact,  # noqa: F401
                         DistanceData, DistanceRequest, DistanceResult)

# The package's Geometry of each geometry object -> that object (python-fcl: the user data);
# None -> the query object's geometry during a query with one.
_owners = {}
_serial = itertools.count()


def forget():
    """Lets go of every geometry made so far (their managers no longer in use)."""
    _owners.clear()


class BVHModel:
    def __init__(self):
        self._g = None
        self._parts = []
        self._n = 0

    def beginModel(self, num_tris_=0, num_vertices_=0):
        self._parts, self._n = [], 0
        return 0

    def addSubModel(self, verts, triangles):
        v = np.asarray(verts, dtype=np.float64).reshape(-1, 3)
        self._parts.append((v, np.asarray(triangles, dtype=np.int64).reshape(-1, 3) + self._n))
        self._n += len(v)
        return True

    def endModel(self):
        self._g = cc.mesh(np.concatenate([p[0] for p in self._parts]),
                          np.concatenate([p[1] for p in self._parts]))
        _owners[self._g] = self
        return 0


class Convex:
    def __init__(self, vertices, num_faces, faces):
        self._g = cc.convex(np.asarray(vertices, dtype=np.float64).reshape(-1, 3),
                            _triangulate(num_faces, faces))
        _owners[self._g] = self


class CollisionObject:
    def __init__(self, geom, tf=None):
        self._geom = geom
        self._name = "o%d" % next(_serial)
        self._tf = np.eye(4)
        if tf is not None:
            self._tf[:3, :3] = tf.getRotation()
            self._tf[:3, 3] = tf.getTranslation()
        self._moved = True

    def setRotation(self, R):
        self._tf[:3, :3] = R
        self._moved = True

    def setTranslation(self, t):
        self._tf[:3, 3] = t
        self._moved = True


class DynamicAABBTreeCollisionManager:
    def __init__(self):
        self._m = cc.CollisionManager(backend="fcl", threads=1)
        self._objs = {}

    def setup(self):
        pass

    def registerObject(self, obj):
        self._m.add_object(obj._name, obj._geom._g, obj._tf)
        self._objs[obj._name] = obj
        obj._moved = False

    def unregisterObject(self, obj):
        name = getattr(obj, "_name", None)
        if name in self._objs:
            self._m.remove_object(name)
            del self._objs[name]

    def update(self, arg=None):
        objs = self._objs.values() if arg is None else [arg]
        for o in objs:
            if o._moved and getattr(o, "_name", None) in self._objs:
                self._m.set_transform(o._name, o._tf)
                o._moved = False

    def _target(self, args):
        if len(args) == 2:
            return None, args[0], args[1]
        if isinstance(args[0], DynamicAABBTreeCollisionManager):
            return args[0]._m, args[1], args[2]
        _owners[None] = args[0]._geom
        return (args[0]._geom._g, args[0]._tf), args[1], args[2]

    def collide(self, *args):
        target, cdata, callback = self._target(args)
        self._m._collide_python(lambda a, b: callback(a, b, cdata), target)

    def distance(self, *args):
        target, ddata, callback = self._target(args)
        self._m._distance_python(lambda a, b: callback(a, b, ddata), target)


def collide(o1, o2, request=None, result=None):
    if request is None:
        request = CollisionRequest()
    if result is None:
        result = CollisionResult()
    return bench.fcl_collide(o1, o2, request, result, Contact, _owners)


def distance(o1, o2, request=None, result=None):
    if request is None:
        request = DistanceRequest()
    if result is None:
        result = DistanceResult()
    return bench.fcl_distance(o1, o2, request, result, _owners)


def defaultCollisionCallback(o1, o2, cdata):
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
    request = cdata.request
    result = cdata.result
    if cdata.done:
        return True, result.min_distance
    distance(o1, o2, request, result)
    dist = result.min_distance
    if dist <= 0:
        return True, dist
    return cdata.done, dist
