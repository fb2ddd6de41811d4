"""Bad input: a clear exception, never a crash, and nothing changed."""

import numpy as np
import pytest

import cube_collision as cc
from conftest import build, mixed_scene


def state(m):
    """Everything a mutation could change, for before/after comparisons."""
    return (m.names, [m.get_transform(n).tolist() for n in m.names],
            [m.get_filter(n) for n in m.names], [m.get_margin(n) for n in m.names],
            m.excluded_pairs, m.in_collision_internal(return_names=True))


NAN = np.full((4, 4), np.nan)
SCALED = np.diag([2.0, 1, 1, 1])
MIRROR = np.diag([-1.0, 1, 1, 1])
SHEAR = np.eye(4)
SHEAR[0, 1] = 0.3
BAD_ROW = np.eye(4)
BAD_ROW[3, 0] = 1
INF = np.eye(4)
INF[0, 3] = np.inf

CASES = [
    (ValueError, lambda m: m.add_object("o0", cc.sphere(1))),                 # duplicate name
    (TypeError, lambda m: m.add_object(7, cc.sphere(1))),                     # name not a str
    (TypeError, lambda m: m.add_object("x", "not a geometry")),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), np.eye(3))),       # wrong shape
    (TypeError, lambda m: m.add_object("x", cc.sphere(1), np.full((4, 4), "a"))),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), NAN)),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), INF)),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), SCALED)),          # non-rigid
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), MIRROR)),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), SHEAR)),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), BAD_ROW)),
    (ValueError, lambda m: m.add_object("x", cc.sphere(1), margin=-1.0)),
    (ValueError, lambda m: m.add_objects(["x", "x"], [cc.sphere(1)] * 2)),   # named twice
    (ValueError, lambda m: m.add_objects(["x", "o3"], [cc.sphere(1)] * 2)),  # exists
    (ValueError, lambda m: m.add_objects(["x", "y"], [cc.sphere(1)])),       # lengths differ
    (ValueError, lambda m: m.add_objects(["x", "y"], [cc.sphere(1)] * 2, np.stack([np.eye(4), SCALED]))),
    (TypeError, lambda m: m.add_objects(["x", "y"], [cc.sphere(1), "no"])),
    (KeyError, lambda m: m.remove_object("nobody")),
    (KeyError, lambda m: m.set_transform("nobody", np.eye(4))),
    (ValueError, lambda m: m.set_transform("o1", NAN)),
    (ValueError, lambda m: m.set_transform("o1", SCALED)),
    (KeyError, lambda m: m.set_transforms(["o1", "nobody"], np.stack([np.eye(4)] * 2))),
    (ValueError, lambda m: m.set_transforms(["o1", "o1"], np.stack([np.eye(4)] * 2))),
    (ValueError, lambda m: m.set_transforms(["o1", "o2"], np.stack([np.eye(4), SCALED]))),
    (ValueError, lambda m: m.set_transforms(["o1", "o2"], np.stack([np.eye(4)] * 3))),
    (TypeError, lambda m: m.set_transforms(["o1", 2], np.stack([np.eye(4)] * 2))),
    (KeyError, lambda m: m.set_filter("nobody", 1, 1)),
    (TypeError, lambda m: m.set_filter("o1", -1, 1)),
    (KeyError, lambda m: m.exclude_pair("o1", "nobody")),
    (ValueError, lambda m: m.exclude_pair("o1", "o1")),
    (KeyError, lambda m: m.include_pair("nobody", "o1")),
    (KeyError, lambda m: m.ignore_pair("o1", "nobody")),
    (ValueError, lambda m: m.ignore_pair("o1", "o1")),
    (KeyError, lambda m: m.pair_passes("o1", "nobody")),
    (KeyError, lambda m: m.pair_passes("nobody", "o1")),
    (TypeError, lambda m: m.pair_passes("o1", 2)),
    (ValueError, lambda m: m.set_margin(-0.1)),
    (ValueError, lambda m: m.set_margin(float("nan"))),
    (ValueError, lambda m: m.set_margin(float("inf"), "o1")),
    (KeyError, lambda m: m.set_margin(0.1, "nobody")),
    (ValueError, lambda m: m.in_collision_single(cc.sphere(1), NAN)),
    (ValueError, lambda m: m.in_collision_single(cc.sphere(1), SCALED)),
    (TypeError, lambda m: m.in_collision_single(None)),
    (ValueError, lambda m: m.min_distance_single(cc.sphere(1), np.zeros((4, 4)))),
    (ValueError, lambda m: m.in_collision_internal(return_data=True, max_contacts=0)),
    (ValueError, lambda m: m.ray_first([[0, 0, 0]], [[np.nan, 0, 0]])),
    (ValueError, lambda m: m.ray_first([[0, 0, 0]], [[1, 0, 0], [2, 0, 0]])),
    (ValueError, lambda m: m.ray_all([0, 0, 0], [1, 0, 0], tolerance=-1)),
    (ValueError, lambda m: m.objects_in_box([1, 1, 1], [0, 0, 0])),
    (ValueError, lambda m: m.objects_in_box([np.nan, 0, 0], [1, 1, 1])),
    (ValueError, lambda m: m.objects_near([0, 0, 0], -1)),
    (ValueError, lambda m: m.objects_near([np.inf, 0, 0], 1)),
    (KeyError, lambda m: m.get_transform("nobody")),
]


@pytest.mark.parametrize("error, call", CASES)
def test_bad_input_raises_and_changes_nothing(backend, error, call):
    m = build(mixed_scene(20, 3), backend)
    m.set_margin(0.05, "o2")
    before = state(m)
    with pytest.raises(error):
        call(m)
    assert state(m) == before


@pytest.mark.parametrize("bad", [NAN, SCALED, MIRROR, SHEAR, BAD_ROW, INF])
def test_set_transforms_names_the_first_bad_pose_and_moves_nothing(backend, bad):
    m = build(mixed_scene(12, 5), backend)
    before = state(m)
    names = m.names[:5]
    tfs = np.stack([m.get_transform(n) for n in names])
    tfs[:, :3, 3] += 0.25  # the good ones move
    tfs[3] = bad
    tfs[4] = SCALED  # a later bad one is not the one named
    with pytest.raises(ValueError, match=r"transforms\[3\]"):
        m.set_transforms(names, tfs)
    assert state(m) == before


def test_unknown_backend():
    with pytest.raises(ValueError):
        cc.CollisionManager(backend="bullet")


def test_removed_objects_leave_nothing_behind(backend):
    m = build(mixed_scene(20, 3), backend)
    m.exclude_pair("o1", "o2")
    m.remove_object("o1")
    assert m.excluded_pairs == [] and "o1" not in m and len(m) == 19
    m.add_object("o1", cc.sphere(0.1))  # the name is free again
    assert m.get_filter("o1") == (1, cc.ALL_BITS)


def test_mutation_from_a_query_callback_is_refused():
    m = build(mixed_scene(20, 3), "fcl")

    def callback(a, b):
        m.remove_object(a.name)

    with pytest.raises(RuntimeError):
        m._collide_python(callback)
    assert len(m) == 20


def test_set_transform_to_none_is_type_error_and_moves_nothing(backend):
    # trimesh raises on a None transform (as set_transforms does here); no move to the origin.
    m = build(mixed_scene(20, 3), backend)
    before = state(m)
    with pytest.raises(TypeError, match="None"):
        m.set_transform("o1", None)
    assert state(m) == before



def bad_collide_callback(a, b):
    return "yes"          # not a bool


def bad_distance_callback(a, b):
    return False, "far"   # the distance is not a number


@pytest.mark.parametrize("hook, callback", [("_collide_python", bad_collide_callback),
                                            ("_distance_python", bad_distance_callback)])
def test_callback_of_the_wrong_type_leaves_managers_mutable(backend, hook, callback):
    m = build(mixed_scene(20, 3), backend)
    with pytest.raises(TypeError, match="callback"):
        getattr(m, hook)(callback)
    m.add_object("late", cc.sphere(0.5))       # the same manager, on the same thread
    m.remove_object("late")
    fresh = cc.CollisionManager(backend=backend)
    fresh.add_object("x", cc.sphere(0.5))      # and a new one
    assert "x" in fresh and len(m) == 20
