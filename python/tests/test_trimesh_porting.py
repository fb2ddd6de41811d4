"""trimesh's calls that a ported script makes, beyond test_oracle's: the keyword mesh=, what
add_object returns, min_distance_internal(name=...), and the error for an unknown name."""

import numpy as np
import pytest

import cube_collision as cc
import scenes
from conftest import BOX_FACES, BOX_VERTICES, TrimeshLike, build, mixed_scene, same_distance
from test_bad_input import state


def moved(x, y=0.0, z=0.0):
    return scenes.pose(np.eye(3), [x, y, z])


def test_mesh_keyword_as_trimesh_scene_to_collision_calls(backend):
    box = TrimeshLike(BOX_VERTICES, BOX_FACES, True)
    m = cc.CollisionManager(backend=backend)
    # trimesh.collision.scene_to_collision: add_object(name=node, mesh=..., transform=T)
    m.add_object(name="box", mesh=box, transform=moved(3))
    m.add_object("ball", mesh=cc.sphere(0.5))
    assert m.names == ["box", "ball"] and m.get_geometry("box").kind == "convex"
    np.testing.assert_array_equal(m.get_transform("box"), moved(3))
    probe = cc.sphere(0.3)
    for t in (moved(2.0), moved(3.5, 0.5), moved(0.7), moved(5, 5)):
        expected = {n for n in m.names
                    if cc.pair_in_collision(m.get_geometry(n), m.get_transform(n), probe, t)}
        assert m.in_collision_single(mesh=probe, transform=t, return_names=True) == \
            (bool(expected), expected)
        assert m.in_collision_single(mesh=probe, transform=t) == m.in_collision_single(probe, t)
        best = min(cc.pair_distance(m.get_geometry(n), m.get_transform(n), probe, t)
                   for n in m.names)
        assert same_distance(m.min_distance_single(mesh=probe, transform=t), best)


@pytest.mark.parametrize("call", [
    lambda m: m.add_object("x", cc.sphere(1), mesh=cc.sphere(1)),     # both
    lambda m: m.add_object("x"),                                      # neither
    lambda m: m.add_object(name="x", transform=np.eye(4)),
    lambda m: m.in_collision_single(cc.sphere(1), mesh=cc.sphere(1)),
    lambda m: m.in_collision_single(),
    lambda m: m.min_distance_single(cc.sphere(1), mesh=cc.sphere(1)),
    lambda m: m.min_distance_single(transform=np.eye(4)),
])
def test_geometry_and_mesh_together_or_neither_is_type_error(backend, call):
    m = build(mixed_scene(10, 3), backend)
    before = state(m)
    with pytest.raises(TypeError, match="give the geometry"):
        call(m)
    assert state(m) == before


def test_add_object_returns_the_geometry_it_added(backend):
    m = cc.CollisionManager(backend=backend)
    g = cc.capsule(0.2, 1.0)
    assert m.add_object("cap", g) is g
    made = m.add_object("box", TrimeshLike(BOX_VERTICES, BOX_FACES, False))
    assert made.kind == "mesh" and made is m.get_geometry("box")
    np.testing.assert_array_equal(made.vertices, BOX_VERTICES)
    np.testing.assert_array_equal(made.faces, BOX_FACES)


def test_min_distance_internal_from_a_named_object_equals_brute_force(backend):
    scene = mixed_scene(40, 71, side=9.0)
    m = build(scene, backend)
    rng = np.random.default_rng(72)
    bits = {n: (1 << int(rng.integers(2)), int(rng.integers(1, 4))) for n, _, _ in scene}
    for n, b in bits.items():
        m.set_filter(n, *b)
    m.ignore_pair("o0", "o1")
    placed = {n: (g, t) for n, g, t in scene}

    def allowed(a, b):
        (ca, ma), (cb, mb) = bits[a], bits[b]
        return a != b and bool(ca & mb) and bool(cb & ma) and {a, b} != {"o0", "o1"}

    for name in ("o0", "o1", "o7", "o13", "o22", "o39"):
        # In the order the broadphase hands the pair over, (the other, the named object): GJK's
        # distance differs in its last digits with the order.
        pairs = [(cc.pair_distance(*placed[n], *placed[name]), n) for n in placed
                 if allowed(name, n)]
        d, names = m.min_distance_internal(return_names=True, name=name)
        if not pairs:
            assert d == float("inf") and names is None
            continue
        best, nearest = min(pairs)
        assert same_distance(d, best)
        if best > 0:
            assert names == tuple(sorted((name, nearest)))
        assert name in names
        d2, data = m.min_distance_internal(return_data=True, name=name)
        assert d2 == d and name in data["names"] and set(data["names"]) == set(names)
        if best > 0:  # the nearest points, one on each object, are the distance apart
            a, b = data["points"]
            assert np.linalg.norm(a - b) == pytest.approx(d, rel=1e-6, abs=1e-9)
        # The whole manager's minimum is no larger than any one object's.
        assert m.min_distance_internal() <= d or same_distance(m.min_distance_internal(), d)


UNKNOWN = [
    lambda m: m.remove_object("nobody"),
    lambda m: m.set_transform("nobody", np.eye(4)),
    lambda m: m.set_transforms(["o1", "nobody"], np.stack([np.eye(4)] * 2)),
    lambda m: m.get_transform("nobody"),
    lambda m: m.get_geometry("nobody"),
    lambda m: m.set_filter("nobody", 1, 1),
    lambda m: m.get_filter("nobody"),
    lambda m: m.ignore_pair("o1", "nobody"),
    lambda m: m.unignore_pair("nobody", "o1"),
    lambda m: m.set_margin(0.1, "nobody"),
    lambda m: m.get_margin("nobody"),
    lambda m: m.min_distance_internal(name="nobody"),
]


@pytest.mark.parametrize("call", UNKNOWN)
def test_unknown_name_is_both_key_error_and_value_error(backend, call):
    # KeyError, this package's word, and ValueError, trimesh's: either except clause catches it.
    assert issubclass(cc.UnknownNameError, KeyError)
    assert issubclass(cc.UnknownNameError, ValueError)
    m = build(mixed_scene(10, 3), backend)
    before = state(m)
    for error in (KeyError, ValueError, cc.UnknownNameError):
        with pytest.raises(error, match="nobody"):
            call(m)
    assert state(m) == before
