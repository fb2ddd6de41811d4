"""trimesh.collision.CollisionManager over python-fcl, re-created on the FCL backend.

Neither trimesh nor python-fcl is a Debian package, so the benchmark re-creates the per-pair
path they take today, step for step, over the same FCL manager (backend="fcl"):
- python-fcl's manager calls a Python callback for every candidate pair, with a new Python
  object for each side (CollisionManager._collide_python / _distance_python);
- the callback is python-fcl's defaultCollisionCallback / defaultDistanceCallback (below, in
  Python as in python-fcl), reading cdata.request / result / done;
- it calls fcl.collide / fcl.distance, compiled in python-fcl (Cython) and here (C++: the
  benchmark-only module cube_collision_bench, python/benchmarks/fcl_way.cpp, built beside the
  package and never installed): the request read from the Python request's
  attributes, FCL's narrow phase, each contact made a Python Contact with numpy arrays;
- trimesh then maps each contact's geometry to a name with a dict keyed by id(geometry).
The request is trimesh's: in_collision_internal(return_names=True) asks for every contact
(num_max_contacts=100000, enable_contact=True). That budget counts contacts over the whole query:
once 100,000 triangle contacts are collected the callback stops, and the pairs after it are not
reported (on the benchmark's clash model of 5,000 meshes trimesh's way found about a third of
the 1,019 colliding pairs); TrimeshManager(max_contacts=...) raises it for complete answers.
"""

import numpy as np

import cube_collision_bench as bench


class CollisionRequest:
    def __init__(self, num_max_contacts=1, enable_contact=False, num_max_cost_sources=1,
                 enable_cost=False, use_approximate_cost=True, gjk_solver_type=0):
        self.num_max_contacts = num_max_contacts
        self.enable_contact = enable_contact
        self.num_max_cost_sources = num_max_cost_sources
        self.enable_cost = enable_cost
        self.use_approximate_cost = use_approximate_cost
        self.gjk_solver_type = gjk_solver_type


class Contact:
    def __init__(self, o1=None, o2=None, b1=0, b2=0, normal=np.zeros(3), pos=np.zeros(3),
                 penetration_depth=0.0):
        self.o1, self.o2, self.b1, self.b2 = o1, o2, b1, b2
        self.normal, self.pos, self.penetration_depth = normal, pos, penetration_depth


class CollisionResult:
    def __init__(self):
        self.contacts = []
        self.cost_sources = []
        self.is_collision = False


class CollisionData:
    def __init__(self, request=None, result=None):
        self.request = request if request is not None else CollisionRequest()
        self.result = result if result is not None else CollisionResult()
        self.done = False


class DistanceRequest:
    def __init__(self, enable_nearest_points=False, enable_signed_distance=False,
                 gjk_solver_type=0):
        self.enable_nearest_points = enable_nearest_points
        self.enable_signed_distance = enable_signed_distance
        self.gjk_solver_type = gjk_solver_type


class DistanceResult:
    def __init__(self, min_distance=float("inf")):
        self.min_distance = min_distance
        self.nearest_points = [np.zeros(3), np.zeros(3)]
        self.o1 = self.o2 = None
        self.b1 = self.b2 = -1


class DistanceData:
    def __init__(self, request=None, result=None):
        self.request = request if request is not None else DistanceRequest()
        self.result = result if result is not None else DistanceResult()
        self.done = False


def collide(o1, o2, request=None, result=None):
    if request is None:
        request = CollisionRequest()
    if result is None:
        result = CollisionResult()
    return bench.fcl_collide(o1, o2, request, result, Contact)


def distance(o1, o2, request=None, result=None):
    if request is None:
        request = DistanceRequest()
    if result is None:
        result = DistanceResult()
    return bench.fcl_distance(o1, o2, request, result)


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


class TrimeshManager:
    """trimesh's CollisionManager calls, over an FCL-backend manager it is given."""

    def __init__(self, manager, max_contacts=100000):
        self._manager = manager
        self._max_contacts = max_contacts  # trimesh's; raised only to compare complete answers
        # trimesh: self._names[id(geometry)] = name at add_object
        self._names = {id(manager.get_geometry(n)): n for n in manager.names}

    def _extract_name(self, geom):
        return self._names[id(geom)]

    def in_collision_internal(self, return_names=False):
        cdata = CollisionData()
        if return_names:
            cdata = CollisionData(request=CollisionRequest(num_max_contacts=self._max_contacts,
                                                           enable_contact=True))
        self._manager._collide_python(lambda a, b: defaultCollisionCallback(a, b, cdata))
        result = cdata.result.is_collision
        if not return_names:
            return result
        objs_in_collision = set()
        for contact in cdata.result.contacts:
            names = (self._extract_name(contact.o1), self._extract_name(contact.o2))
            objs_in_collision.add(tuple(sorted(names)))
        return result, objs_in_collision

    def min_distance_internal(self, return_names=False, return_data=False):
        ddata = DistanceData()
        if return_data:  # trimesh asks for nearest points only with the data
            ddata = DistanceData(DistanceRequest(enable_nearest_points=True))
        self._manager._distance_python(lambda a, b: defaultDistanceCallback(a, b, ddata))
        distance_ = ddata.result.min_distance
        if not return_names:
            return distance_
        names = tuple(sorted((self._extract_name(ddata.result.o1),
                              self._extract_name(ddata.result.o2))))
        return distance_, names
