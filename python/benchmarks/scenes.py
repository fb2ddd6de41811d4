"""Scene generators for the benchmark, the examples and the tests (numpy only, seeded).

primitives_and_convex(n): boxes, spheres, cylinders, capsules, cones and convex polytopes of
size about 1 at random poses in a cube sized for about two overlapping boxes per object.
clash(n): a clash-detection model: n triangle meshes of 100-2,000 triangles (log-uniform), pipes
(tessellated cylinders), beams and slabs (subdivided boxes) and equipment (tessellated spheres),
axis-aligned as building elements are, at a density where some cross (the clashes).
Each returns a list of (name, geometry, 4x4 transform).
"""

import math

import numpy as np

import cube_collision as cc


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def pose(rotation, translation):
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def icosahedron():
    p = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p],
                  [0, -1, -p], [0, 1, -p], [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]],
                 dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]])
    return v / np.linalg.norm(v[0]), f


def random_convex(rng, size):
    """An icosahedron stretched by a random linear map: still convex, faces still its hull's."""
    v, f = icosahedron()
    a = np.diag(rng.uniform(0.5, 1.0, 3) * size / 2) @ random_rotation(rng)
    v = v @ a.T
    # A map with negative determinant would turn the faces inside out; FCL's GJK does not care,
    # but keep them outward.
    if np.linalg.det(a) < 0:
        f = f[:, ::-1]
    return cc.convex(v, f)


def primitives_and_convex(n, seed=1, density=2.0):
    rng = np.random.default_rng(seed)
    side = (4.0 * n / density) ** (1 / 3)
    out = []
    for i in range(n):
        kind = i % 6
        s = rng.uniform(0.5, 1.0)
        if kind == 0:
            g = cc.box(*(rng.uniform(0.3, 1.0, 3)))
        elif kind == 1:
            g = cc.sphere(s / 2)
        elif kind == 2:
            g = cc.cylinder(s / 3, s)
        elif kind == 3:
            g = cc.capsule(s / 4, s / 2)
        elif kind == 4:
            g = cc.cone(s / 3, s)
        else:
            g = random_convex(rng, s)
        out.append((f"p{i}", g, pose(random_rotation(rng), rng.uniform(0, side, 3))))
    return out


def tube(segments, radius, length):
    """A closed cylinder along z: 4 * segments triangles."""
    a = np.linspace(0, 2 * math.pi, segments, endpoint=False)
    ring = np.stack([radius * np.cos(a), radius * np.sin(a)], 1)
    bottom = np.hstack([ring, np.full((segments, 1), -length / 2)])
    top = np.hstack([ring, np.full((segments, 1), length / 2)])
    v = np.vstack([bottom, top, [[0, 0, -length / 2], [0, 0, length / 2]]])
    k = np.arange(segments)
    n = (k + 1) % segments
    sides = np.vstack([np.stack([k, n, k + segments], 1),
                       np.stack([n, n + segments, k + segments], 1)])
    caps = np.vstack([np.stack([np.full(segments, 2 * segments), n, k], 1),
                      np.stack([np.full(segments, 2 * segments + 1), k + segments,
                                n + segments], 1)])
    return v, np.vstack([sides, caps])


def grid_box(cells, extents):
    """A box whose 6 faces are cells x cells grids: 12 * cells^2 triangles."""
    verts, faces = [], []
    g = np.linspace(-0.5, 0.5, cells + 1)
    u, w = np.meshgrid(g, g, indexing="ij")
    u, w = u.ravel(), w.ravel()
    for axis in range(3):
        for sign in (-0.5, 0.5):
            p = np.zeros((u.size, 3))
            p[:, axis] = sign
            p[:, (axis + 1) % 3] = u
            p[:, (axis + 2) % 3] = w
            base = sum(len(x) for x in verts)
            verts.append(p)
            idx = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1) + base
            a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
            c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
            t = np.vstack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
            faces.append(t if sign > 0 else t[:, ::-1])
    return np.vstack(verts) * np.asarray(extents), np.vstack(faces)


def uv_sphere(rings, radius):
    """About 2 * rings * (2 * rings) triangles."""
    seg = 2 * rings
    th = np.linspace(0, math.pi, rings + 1)[1:-1]
    ph = np.linspace(0, 2 * math.pi, seg, endpoint=False)
    t, p = np.meshgrid(th, ph, indexing="ij")
    v = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    v = np.vstack([v, [[0, 0, 1], [0, 0, -1]]]) * radius
    faces = []
    for r in range(rings - 2):
        for s in range(seg):
            a, b = r * seg + s, r * seg + (s + 1) % seg
            c, d = a + seg, b + seg
            faces += [[a, c, b], [b, c, d]]
    top, bot = len(v) - 2, len(v) - 1
    last = (rings - 2) * seg
    for s in range(seg):
        faces.append([top, s, (s + 1) % seg])
        faces.append([bot, last + (s + 1) % seg, last + s])
    return v, np.array(faces)


AXES = [np.eye(3), np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float).T,
        np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], float).T]


def clash(n, seed=2, density=1.0):
    """n meshes of 100-2,000 triangles: pipes, beams / slabs and equipment."""
    rng = np.random.default_rng(seed)
    side = (30.0 * n / density) ** (1 / 3)
    out = []
    for i in range(n):
        tris = int(round(math.exp(rng.uniform(math.log(100), math.log(2000)))))
        kind = i % 3
        rot = AXES[rng.integers(3)]
        if kind == 0:  # a pipe
            v, f = tube(max(8, tris // 4), rng.uniform(0.05, 0.3), rng.uniform(2, 8))
        elif kind == 1:  # a beam or a slab
            cells = max(3, int(round(math.sqrt(tris / 12))))
            ext = rng.uniform(0.2, 0.6, 3)
            ext[rng.integers(3)] = rng.uniform(2, 6)
            v, f = grid_box(cells, ext)
        else:  # equipment
            v, f = uv_sphere(max(4, int(round(math.sqrt(tris / 4)))), rng.uniform(0.3, 1.0))
        out.append((f"m{i}", cc.mesh(v, f), pose(rot, rng.uniform(0, side, 3))))
    return out


def build(scene, backend="cube", threads=0):
    """A manager holding the scene, added in one call (one build of the tree on both backends:
    FCL's top-down build for backend="fcl", as FCL users register a world)."""
    m = cc.CollisionManager(backend=backend, threads=threads)
    if scene:
        names, geometries, transforms = zip(*scene)
        m.add_objects(list(names), list(geometries), np.stack(transforms))
    return m


def cone_mesh(segments, radius, length):
    """A closed cone along z (FCL's: base at -length / 2, apex at +length / 2)."""
    a = np.linspace(0, 2 * math.pi, segments, endpoint=False)
    ring = np.stack([radius * np.cos(a), radius * np.sin(a), np.full(segments, -length / 2)], 1)
    v = np.vstack([ring, [[0, 0, length / 2], [0, 0, -length / 2]]])
    k = np.arange(segments)
    n = (k + 1) % segments
    f = np.vstack([np.stack([k, n, np.full(segments, segments)], 1),
                   np.stack([np.full(segments, segments + 1), n, k], 1)])
    return v, f


def as_mesh(g):
    """(vertices, faces, is_convex) of a scene's geometry as trimesh would hold it: a mesh stays
    a mesh (not convex); a convex and the primitives (tessellated) are convex meshes."""
    p = g.params
    if g.kind == "mesh":
        return g.vertices, g.faces, False
    if g.kind == "convex":
        return g.vertices, g.faces, True
    if g.kind == "box":
        return (*grid_box(1, p[:3]), True)
    if g.kind == "sphere":
        return (*uv_sphere(4, p[0]), True)
    if g.kind == "cylinder":
        return (*tube(12, p[0], p[1]), True)
    if g.kind == "capsule":  # a sphere's halves moved apart by the length
        v, f = uv_sphere(4, p[0])
        v = v.copy()
        v[:, 2] += np.where(v[:, 2] >= 0, p[1] / 2, -p[1] / 2)
        return v, f, True
    if g.kind == "cone":
        return (*cone_mesh(12, p[0], p[1]), True)
    raise ValueError(f"as_mesh: no mesh for {g.kind}")
