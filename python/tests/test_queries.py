"""Rays and regions: the cube backend against the FCL backend, which loops over every object
with the same per-object test; spheres against the analytic answer."""

import numpy as np
import pytest

import cube_collision as cc
from conftest import build, mixed_scene


def test_rays_equal_a_loop_over_every_object():
    scene = mixed_scene(80, 8)
    cube, loop = build(scene), build(scene, "fcl")
    rng = np.random.default_rng(1)
    o = rng.uniform(-1, 8, (40, 3))
    e = rng.uniform(-1, 8, (40, 3))
    for narrow in (True, False):
        a = cube.ray_first(o, e, narrow_phase=narrow)
        b = loop.ray_first(o, e, narrow_phase=narrow)
        assert list(a[0]) == list(b[0])
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_array_equal(a[2], b[2])
        for i in range(10):
            ra = cube.ray_all(o[i], e[i], narrow_phase=narrow)
            rb = loop.ray_all(o[i], e[i], narrow_phase=narrow)
            assert ra[0] == rb[0]
            np.testing.assert_array_equal(ra[1], rb[1])


def test_ray_against_a_sphere_is_exact(backend):
    m = cc.CollisionManager(backend=backend)
    t = np.eye(4)
    t[:3, 3] = [5, 0, 0]
    m.add_object("ball", cc.sphere(1.0), t)
    names, ts, pts = m.ray_first([[0, 0, 0], [0, 5, 0]], [[10, 0, 0], [10, 5, 0]])
    assert names[0] == "ball" and names[1] is None
    assert ts[0] == pytest.approx(0.4) and np.isnan(ts[1])
    np.testing.assert_allclose(pts[0], [4, 0, 0])


def test_regions_equal_a_loop_over_every_object():
    scene = mixed_scene(80, 9)
    cube, loop = build(scene), build(scene, "fcl")
    rng = np.random.default_rng(2)
    for _ in range(20):
        lo = rng.uniform(0, 6, 3)
        hi = lo + rng.uniform(0, 3, 3)
        assert cube.objects_in_box(lo, hi) == loop.objects_in_box(lo, hi)
        p, r = rng.uniform(0, 6, 3), rng.uniform(0, 2)
        assert cube.objects_near(p, r) == loop.objects_near(p, r)
    assert cube.objects_in_box([-np.inf] * 3, [np.inf] * 3) == cube.names
    assert cube.objects_near([0, 0, 0], np.inf) == cube.names


def test_filter_bits_rule_rays_and_regions_as_a_loop_over_every_object():
    """Each backend's filtered answer is its unfiltered one less the objects the query's bits
    reject (written here: each one's category meets the other's mask)."""
    scene = mixed_scene(120, 10)
    cube, loop = build(scene), build(scene, "fcl")
    layouts = [(1, 2**64 - 1), (2, 2 | 4), (4, 1 | 4), (8, 0)]
    bits = {}
    for i, name in enumerate(cube.names):
        bits[name] = layouts[i % len(layouts)]
        for m in (cube, loop):
            m.set_filter(name, *bits[name])

    def keep(names, f):
        return [n for n in names if (bits[n][0] & f[1]) and (f[0] & bits[n][1])]

    rng = np.random.default_rng(3)
    changed = 0
    for f in [(1, 2**64 - 1), (2, 2**64 - 1), (4, 8), (6, 1 | 2), (1, 0)]:
        for m in (cube, loop):
            o = rng.uniform(-1, 8, (20, 3))
            e = rng.uniform(-1, 8, (20, 3))
            for i in range(20):
                full = m.ray_all(o[i], e[i])
                got = m.ray_all(o[i], e[i], filter=f)
                want = [(n, t) for n, t in zip(full[0], full[1]) if keep([n], f)]
                assert list(zip(got[0], got[1])) == want
                first = m.ray_first(o[i:i + 1], e[i:i + 1], filter=f)
                assert first[0][0] == (want[0][0] if want else None)
                changed += len(full[0]) != len(got[0])
            for _ in range(10):
                lo = rng.uniform(0, 6, 3)
                hi = lo + rng.uniform(0, 3, 3)
                assert m.objects_in_box(lo, hi, filter=f) == keep(m.objects_in_box(lo, hi), f)
                p, r = rng.uniform(0, 6, 3), rng.uniform(0, 2)
                assert m.objects_near(p, r, filter=f) == keep(m.objects_near(p, r), f)
                changed += len(m.objects_in_box(lo, hi, filter=f)) != len(m.objects_in_box(lo, hi))
        assert cube.objects_in_box([-np.inf] * 3, [np.inf] * 3, filter=f) == keep(cube.names, f)
    assert changed > 20


def test_capsules_equal_fcl_on_every_object():
    """objects_in_capsule: the cube backend against FCL's tree putting every object to
    fcl::collide with the same capsule, with and without filter bits; a segment of length 0
    against spheres is a ball."""
    scene = mixed_scene(120, 11)
    cube, loop = build(scene), build(scene, "fcl")
    for i, name in enumerate(cube.names):
        for m in (cube, loop):
            m.set_filter(name, *[(1, 2**64 - 1), (2, 2 | 4), (4, 1 | 4)][i % 3])
    rng = np.random.default_rng(4)
    found = 0
    for i in range(40):
        a, b = rng.uniform(-1, 8, 3), rng.uniform(-1, 8, 3)
        if i % 5 == 0:
            b = a
        r = 0.0 if i % 7 == 0 else rng.uniform(0.1, 2)
        want = loop.objects_in_capsule(a, b, r)
        assert cube.objects_in_capsule(a, b, r) == want
        found += len(want)
        for f in [(2, 2**64 - 1), (1, 2)]:
            assert cube.objects_in_capsule(a, b, r, filter=f) == \
                loop.objects_in_capsule(a, b, r, filter=f)
    assert found > 20

    m = cc.CollisionManager()
    centres = rng.uniform(-5, 5, (50, 3))
    for i, c in enumerate(centres):
        t = np.eye(4)
        t[:3, 3] = c
        m.add_object(f"s{i}", cc.sphere(0.5), t)
    for _ in range(20):
        p, r = rng.uniform(-5, 5, 3), rng.uniform(0.2, 2)
        gaps = np.linalg.norm(centres - p, axis=1) - 0.5 - r
        got = set(m.objects_in_capsule(p, p, r))
        for i, g in enumerate(gaps):
            if abs(g) > 1e-6:
                assert (f"s{i}" in got) == (g < 0)


@pytest.mark.parametrize("args", [([np.nan, 0, 0], [1, 0, 0], 1.0), ([0, 0, 0], [1, 0, 0], -1.0),
                                  ([0, 0, 0], [1, 0, 0], np.inf), ([0, 0, 0], [1, 0, 0], np.nan),
                                  ([0, 0, 0], [0, 0, 0], 1e200)])
def test_bad_capsules_raise_value_error(backend, args):
    m = cc.CollisionManager(backend=backend)
    m.add_object("ball", cc.sphere(1.0))
    with pytest.raises(ValueError):
        m.objects_in_capsule(*args)
    assert m.objects_in_capsule([0, 0, 0], [1, 0, 0], 0.5) == ["ball"]
