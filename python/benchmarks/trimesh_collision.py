"""trimesh's CollisionManager (trimesh/collision.py), re-written call for call over a
python-fcl-compatible module given to it (trimesh is not a Debian package here).

Every call into `fcl` is the one trimesh makes, with trimesh's arguments: meshes become
fcl.Convex when mesh.is_convex (trimesh's mesh_to_convex) and fcl.BVHModel otherwise
(mesh_to_BVH), a name is found from id(geometry) of a contact's or a result's o1 / o2, and
in_collision_* asks for every contact (num_max_contacts=100000, enable_contact=True) as soon as
names or data are wanted. Shared by the tests (over cube_collision.fcl) and the benchmark
(over cube_collision.fcl and over python-fcl's way, pyfcl_way.py).

The one addition is `max_contacts` (trimesh's 100,000 by default): that budget counts contacts
over the whole query, so a query whose contacts exceed it stops early, with the pairs found by
then; the benchmark raises it where it compares complete answers. Return values are trimesh's
tuples, except that in_collision_* return (hit, names, data) whatever is asked, data as
(names, ...) tuples instead of trimesh's ContactData objects.
"""

import collections

import numpy as np


class Mesh:
    """The parts of a trimesh.Trimesh that trimesh's collision module reads."""

    def __init__(self, vertices, faces, is_convex):
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.is_convex = is_convex


def mesh_to_BVH(fcl, mesh):
    bvh = fcl.BVHModel()
    bvh.beginModel(num_tris_=len(mesh.faces), num_vertices_=len(mesh.vertices))
    bvh.addSubModel(verts=mesh.vertices, triangles=mesh.faces)
    bvh.endModel()
    return bvh


def mesh_to_convex(fcl, mesh):
    fs = np.concatenate((3 * np.ones((len(mesh.faces), 1), dtype=np.int64), mesh.faces), axis=1)
    return fcl.Convex(mesh.vertices, len(fs), fs.flatten())


class CollisionManager:
    """trimesh.collision.CollisionManager over the python-fcl-compatible module `fcl`."""

    def __init__(self, fcl, max_contacts=100000):
        self._fcl = fcl
        self._max_contacts = max_contacts
        self._objs = {}
        self._names = collections.defaultdict(lambda: None)
        self._manager = fcl.DynamicAABBTreeCollisionManager()
        self._manager.setup()

    def _geometry(self, mesh):
        return mesh_to_convex(self._fcl, mesh) if mesh.is_convex else mesh_to_BVH(self._fcl, mesh)

    def add_object(self, name, mesh, transform=None):
        fcl = self._fcl
        if transform is None:
            transform = np.eye(4)
        transform = np.asanyarray(transform, dtype=np.float32)
        if transform.shape != (4, 4):
            raise ValueError("transform must be (4,4)!")
        geom = self._geometry(mesh)
        t = fcl.Transform(transform[:3, :3], transform[:3, 3])
        o = fcl.CollisionObject(geom, t)
        # trimesh hands its {"obj", "geom"} dict here, which python-fcl ignores
        if name in self._objs:
            self._manager.unregisterObject(self._objs[name])
        self._objs[name] = {"obj": o, "geom": geom}
        self._names[id(geom)] = name
        self._manager.registerObject(o)
        self._manager.update()
        return o

    def remove_object(self, name):
        if name not in self._objs:
            raise ValueError(f"{name} not in collision manager!")
        self._manager.unregisterObject(self._objs[name]["obj"])
        self._manager.update(self._objs[name]["obj"])
        self._names.pop(id(self._objs.pop(name)["geom"]))

    def set_transform(self, name, transform):
        if name not in self._objs:
            raise ValueError(f"{name} not in collision manager!")
        o = self._objs[name]["obj"]
        o.setRotation(transform[:3, :3])
        o.setTranslation(transform[:3, 3])
        self._manager.update(o)

    def _request(self, return_names, return_data):
        fcl = self._fcl
        if return_names or return_data:
            return fcl.CollisionData(request=fcl.CollisionRequest(
                num_max_contacts=self._max_contacts, enable_contact=True))
        return fcl.CollisionData()

    def _extract_name(self, geom):
        return self._names[id(geom)]

    def in_collision_single(self, mesh, transform=None, return_names=False, return_data=False):
        fcl = self._fcl
        if transform is None:
            transform = np.eye(4)
        geom = self._geometry(mesh)
        o = fcl.CollisionObject(geom, fcl.Transform(transform[:3, :3], transform[:3, 3]))
        cdata = self._request(return_names, return_data)
        self._manager.collide(o, cdata, fcl.defaultCollisionCallback)
        names, data = set(), []
        if return_names or return_data:
            for contact in cdata.result.contacts:
                cg = contact.o1
                if cg == geom:
                    cg = contact.o2
                name = self._extract_name(cg)
                if return_names:
                    names.add(name)
                if return_data:
                    data.append((name, contact.pos, contact.normal, contact.penetration_depth))
        return cdata.result.is_collision, names, data

    def in_collision_internal(self, return_names=False, return_data=False):
        cdata = self._request(return_names, return_data)
        self._manager.collide(cdata, self._fcl.defaultCollisionCallback)
        names, data = set(), []
        if return_names or return_data:
            for contact in cdata.result.contacts:
                coll_names = (self._extract_name(contact.o1), self._extract_name(contact.o2))
                if return_names:
                    names.add(tuple(sorted(coll_names)))
                if return_data:
                    data.append((coll_names, contact.b1, contact.b2, contact.penetration_depth))
        return cdata.result.is_collision, names, data

    def in_collision_other(self, other_manager, return_names=False, return_data=False):
        cdata = self._request(return_names, return_data)
        self._manager.collide(other_manager._manager, cdata, self._fcl.defaultCollisionCallback)
        names = set()
        if return_names or return_data:
            for contact in cdata.result.contacts:
                pair = (self._extract_name(contact.o1),
                        other_manager._extract_name(contact.o2))
                if pair[0] is None:
                    pair = (self._extract_name(contact.o2),
                            other_manager._extract_name(contact.o1))
                names.add(pair)
        return cdata.result.is_collision, names

    def _distance_result(self, ddata, geom=None):
        r = ddata.result
        if geom is None:
            return r.min_distance, (self._extract_name(r.o1), self._extract_name(r.o2)), r
        cg = r.o1 if r.o1 != geom else r.o2
        return r.min_distance, self._extract_name(cg), r

    def min_distance_single(self, mesh, transform=None):
        fcl = self._fcl
        if transform is None:
            transform = np.eye(4)
        geom = self._geometry(mesh)
        o = fcl.CollisionObject(geom, fcl.Transform(transform[:3, :3], transform[:3, 3]))
        ddata = fcl.DistanceData(fcl.DistanceRequest(enable_nearest_points=True,
                                                     enable_signed_distance=True))
        self._manager.distance(o, ddata, fcl.defaultDistanceCallback)
        return self._distance_result(ddata, geom)

    def min_distance_internal(self):
        fcl = self._fcl
        ddata = fcl.DistanceData(fcl.DistanceRequest(enable_nearest_points=True),
                                 fcl.DistanceResult())
        self._manager.distance(ddata, fcl.defaultDistanceCallback)
        return self._distance_result(ddata)

    def min_distance_other(self, other_manager):
        fcl = self._fcl
        ddata = fcl.DistanceData(fcl.DistanceRequest(enable_nearest_points=True),
                                 fcl.DistanceResult())
        self._manager.distance(other_manager._manager, ddata, fcl.defaultDistanceCallback)
        r = ddata.result
        pair = (self._extract_name(r.o1), other_manager._extract_name(r.o2))
        if pair[0] is None:
            pair = (self._extract_name(r.o2), other_manager._extract_name(r.o1))
        return r.min_distance, pair, r
