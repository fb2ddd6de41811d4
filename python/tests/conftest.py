"""Shared helpers: small random scenes and brute-force oracles over every pair with FCL's
narrow phase (cube_collision.pair_in_collision / pair_distance: fcl::collide / fcl::distance on
two placed geometries, no broadphase)."""

import itertools
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "benchmarks"))
sys.path.insert(0, os.path.join(HERE, "..", "examples"))

import cube_collision as cc  # noqa: E402
import scenes  # noqa: E402


def mixed_scene(n, seed, side=None, meshes=True):
    """n objects of every kind (meshes included), random poses in a cube of `side`."""
    rng = np.random.default_rng(seed)
    side = side if side is not None else (4.0 * n) ** (1 / 3)
    out = []
    for i in range(n):
        kind = i % 8 if meshes else i % 6
        s = rng.uniform(0.5, 1.2)
        if kind == 0:
            g = cc.box(*rng.uniform(0.3, 1.2, 3))
        elif kind == 1:
            g = cc.sphere(s / 2)
        elif kind == 2:
            g = cc.cylinder(s / 3, s)
        elif kind == 3:
            g = cc.capsule(s / 4, s / 2)
        elif kind == 4:
            g = cc.cone(s / 3, s)
        elif kind == 5:
            g = scenes.random_convex(rng, s)
        elif kind == 6:
            g = cc.mesh(*scenes.uv_sphere(int(rng.integers(4, 8)), s / 2))
        else:
            g = cc.mesh(*scenes.tube(int(rng.integers(6, 16)), s / 5, 2 * s))
        out.append((f"o{i}", g, scenes.pose(scenes.random_rotation(rng), rng.uniform(0, side, 3))))
    return out


def build(scene, backend="cube", threads=0):
    return scenes.build(scene, backend, threads)


def brute_colliding(scene, allowed=lambda a, b: True):
    """Sorted name pairs whose geometries collide (fcl::collide), over every pair."""
    out = set()
    for (na, ga, ta), (nb, gb, tb) in itertools.combinations(scene, 2):
        if allowed(na, nb) and cc.pair_in_collision(ga, ta, gb, tb):
            out.add(tuple(sorted((na, nb))))
    return out


def brute_min_distance(scene, allowed=lambda a, b: True):
    best, names = float("inf"), None
    for (na, ga, ta), (nb, gb, tb) in itertools.combinations(scene, 2):
        if not allowed(na, nb):
            continue
        d = cc.pair_distance(ga, ta, gb, tb)
        if d < best:
            best, names = d, tuple(sorted((na, nb)))
    return best, names


def same_distance(found, expected):
    if expected <= 0:
        return found <= 0
    return abs(found - expected) <= 1e-9 + 1e-6 * abs(expected)


# The surface of the box [-1, 1]^3 as 12 triangles (a closed convex mesh).
BOX_VERTICES = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
BOX_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


class TrimeshLike:
    """What the package reads of a trimesh.Trimesh: vertices, faces and is_convex."""

    def __init__(self, vertices, faces, is_convex):
        self.vertices, self.faces, self.is_convex = vertices, faces, is_convex


@pytest.fixture(params=["cube", "fcl"])
def backend(request):
    return request.param
