import pickle

import numpy as np
import pytest

import cube_collision as cc
import scenes
from conftest import BOX_FACES, BOX_VERTICES, TrimeshLike

I = np.eye(4)


def test_kinds_and_params():
    assert cc.box(1, 2, 3).params == [1, 2, 3]
    assert cc.sphere(0.5).kind == "sphere"
    assert cc.capsule(0.2, 1).params == [0.2, 1]
    p = cc.plane([0, 0, 2], 4)
    assert p.params == pytest.approx([0, 0, 1, 2])  # normalised
    v, f = scenes.tube(8, 0.5, 2)
    m = cc.mesh(v, f)
    assert m.vertices.shape == (len(v), 3) and m.faces.shape == (32, 3)
    np.testing.assert_allclose(m.aabb, [[-0.5, -0.5, -1], [0.5, 0.5, 1]], atol=1e-9)


def test_mesh_collides_as_fcl_says():
    # A tube mesh against spheres inside it (a surface: no contact) and across its wall.
    tube = cc.mesh(*scenes.tube(32, 1.0, 4.0))
    inside = np.eye(4)
    across = np.eye(4)
    across[0, 3] = 1.0
    assert not cc.pair_in_collision(tube, I, cc.sphere(0.3), inside)
    assert cc.pair_in_collision(tube, I, cc.sphere(0.3), across)


def test_trimesh_like_objects_become_meshes():
    class Trimeshish:
        vertices, faces = scenes.tube(8, 0.5, 2)

    m = cc.CollisionManager()
    m.add_object("t", Trimeshish())
    assert m.get_geometry("t").kind == "mesh"


@pytest.mark.parametrize("backend", ["cube", "fcl"])
def test_convex_trimesh_is_a_solid_and_others_stay_surfaces(backend):
    # As trimesh: a mesh whose is_convex is true becomes FCL's Convex (a solid), so a sphere
    # inside the box collides with it; a mesh that is not convex stays a BVH surface.
    ball = cc.sphere(0.25)
    assert cc.pair_in_collision(cc.convex(BOX_VERTICES, BOX_FACES), I, ball, I)   # the oracle
    assert not cc.pair_in_collision(cc.mesh(BOX_VERTICES, BOX_FACES), I, ball, I)
    m = cc.CollisionManager(backend=backend)
    m.add_object("solid", TrimeshLike(BOX_VERTICES, BOX_FACES, True))
    m.add_object("shell", TrimeshLike(BOX_VERTICES, BOX_FACES, False),
                 scenes.pose(I[:3, :3], [5, 0, 0]))
    assert m.get_geometry("solid").kind == "convex" and m.get_geometry("shell").kind == "mesh"
    assert m.in_collision_single(ball, return_names=True) == (True, {"solid"})
    assert not m.in_collision_single(ball, scenes.pose(I[:3, :3], [5, 0, 0]))
    # As a query geometry too: a convex trimesh around an object collides with it.
    inner = cc.CollisionManager(backend=backend)
    inner.add_object("ball", ball)
    assert inner.in_collision_single(TrimeshLike(BOX_VERTICES, BOX_FACES, True))
    assert not inner.in_collision_single(TrimeshLike(BOX_VERTICES, BOX_FACES, False))


@pytest.mark.parametrize("make", [
    lambda: cc.box(0, 1, 1), lambda: cc.box(1, -1, 1), lambda: cc.sphere(float("nan")),
    lambda: cc.cylinder(1, float("inf")), lambda: cc.capsule(-1, 1), lambda: cc.cone(1, 0),
    lambda: cc.plane([0, 0, 0], 1), lambda: cc.plane([0, 0, 1], float("nan")),
    lambda: cc.mesh(np.zeros((2, 3)), [[0, 1, 1]]),               # empty mesh
    lambda: cc.mesh(np.zeros((3, 3)), np.zeros((0, 3), int)),       # no face
    lambda: cc.mesh(np.zeros((3, 3)), [[0, 1, 3]]),                 # past the vertices
    lambda: cc.mesh(np.zeros((3, 3)), [[0, -1, 2]]),                # negative
    lambda: cc.mesh([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]]),
    lambda: cc.mesh([[0, 0, 0], [1, 0, 0], [0, np.inf, 0]], [[0, 1, 2]]),
    lambda: cc.mesh(np.zeros((3, 2)), [[0, 1, 2]]),                 # wrong shape
    lambda: cc.convex(np.zeros((3, 3)), [[0, 1, 2, 0]]),
])
def test_bad_geometry_is_value_error(make):
    with pytest.raises(ValueError):
        make()


@pytest.mark.parametrize("make", [
    lambda: cc.mesh(np.zeros((3, 3)), np.array([[0, 1, 2.0]])),   # float faces
    lambda: cc.mesh([["a", "b", "c"]] * 3, [[0, 1, 2]]),           # strings
    lambda: cc.mesh(np.zeros((3, 3), dtype=complex), [[0, 1, 2]]),
    lambda: cc.sphere("big"),
])
def test_bad_geometry_types_are_type_error(make):
    with pytest.raises(TypeError):
        make()


def test_geometry_pickles():
    for g in (cc.box(1, 2, 3), cc.sphere(1), cc.cone(1, 2), cc.plane([1, 0, 0], 2),
              cc.mesh(*scenes.uv_sphere(5, 1)), scenes.random_convex(np.random.default_rng(0), 1)):
        h = pickle.loads(pickle.dumps(g))
        assert h.kind == g.kind and h.params == g.params
        np.testing.assert_array_equal(h.vertices, g.vertices)
        np.testing.assert_array_equal(h.faces, g.faces)
        np.testing.assert_allclose(h.aabb, g.aabb)
