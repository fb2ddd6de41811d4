"""Answers against brute force over every pair with FCL's narrow phase, on both backends."""

import itertools
import pickle

import numpy as np
import pytest

import cube_collision as cc
import scenes
from conftest import (BOX_VERTICES, BOX_FACES, TrimeshLike, brute_colliding, brute_min_distance,
                      build, mixed_scene, same_distance)

SEEDS = [1, 2, 3]


@pytest.mark.parametrize("seed", SEEDS)
def test_internal_collisions_equal_brute_force(seed, backend):
    scene = mixed_scene(70, seed)
    m = build(scene, backend)
    expected = brute_colliding(scene)
    hit, names = m.in_collision_internal(return_names=True)
    assert names == expected and hit == bool(expected)
    assert m.in_collision_internal() == bool(expected)
    # Contacts: one or more rows per colliding pair, every row of a colliding pair.
    hit2, names2, data = m.in_collision_internal(return_names=True, return_data=True)
    assert names2 == expected
    rows = {tuple(sorted(p)) for p in data["names"]}
    assert rows == expected
    n = len(data["names"])
    assert data["points"].shape == (n, 3) and data["normals"].shape == (n, 3)
    assert data["depths"].shape == (n,) and np.all(np.isfinite(data["points"]))


def test_shapes_only_scene_equals_brute_force(backend):
    # No meshes: the cube backend names pairs from one pipeline pass (another code path).
    scene = mixed_scene(120, 7, meshes=False)
    assert build(scene, backend).in_collision_internal(return_names=True)[1] == \
        brute_colliding(scene)


@pytest.mark.parametrize("other_backend", ["cube", "fcl"])
def test_shapes_only_single_and_other(backend, other_backend):
    # Shapes only: the cube backend's names come from one pipeline pass (no per-pair results).
    a = mixed_scene(80, 61, meshes=False)
    b = [("b" + n, g, t) for n, g, t in mixed_scene(60, 62, meshes=False)]
    ma, mb = build(a, backend), build(b, other_backend)
    expected = {(na, nb) for na, ga, ta in a for nb, gb, tb in b
                if cc.pair_in_collision(ga, ta, gb, tb)}
    assert ma.in_collision_other(mb, return_names=True) == (bool(expected), expected)
    rng = np.random.default_rng(63)
    # a[0][1] is also a managed object's geometry: the answers must still name objects right.
    for probe in (cc.sphere(0.8), cc.box(1, 2, 1), scenes.random_convex(rng, 1.5), a[0][1]):
        for k in range(4):
            t = scenes.pose(scenes.random_rotation(rng), rng.uniform(0, 6, 3))
            if k == 0:
                t = a[0][2]  # on top of the object that shares its geometry
            hits = {n for n, g, tf in a if cc.pair_in_collision(g, tf, probe, t)}
            assert ma.in_collision_single(probe, t, return_names=True) == (bool(hits), hits)


@pytest.mark.parametrize("seed", SEEDS)
def test_min_distance_equals_brute_force(seed, backend):
    scene = mixed_scene(40, seed, side=14.0)  # sparse: a real search
    m = build(scene, backend)
    best, names = brute_min_distance(scene)
    d, found, data = m.min_distance_internal(return_names=True, return_data=True)
    assert same_distance(d, best)
    if best > 0:
        assert found == names
        pts = data["points"]
        assert pts.shape == (2, 3)
        assert np.linalg.norm(pts[0] - pts[1]) == pytest.approx(best, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
def test_single_queries_equal_brute_force(seed, backend):
    scene = mixed_scene(50, seed)
    m = build(scene, backend)
    rng = np.random.default_rng(seed + 100)
    for probe in (cc.sphere(0.8), cc.mesh(*scenes.uv_sphere(6, 0.9)), cc.box(1, 2, 1)):
        for _ in range(4):
            t = scenes.pose(scenes.random_rotation(rng),
                                          rng.uniform(0, 6, 3))
            expected = {n for n, g, tf in scene if cc.pair_in_collision(g, tf, probe, t)}
            hit, names = m.in_collision_single(probe, t, return_names=True)
            assert names == expected and hit == bool(expected)
            d, name = m.min_distance_single(probe, t, return_name=True)
            dists = {n: cc.pair_distance(g, tf, probe, t) for n, g, tf in scene}
            best = min(dists.values())
            assert same_distance(d, best)
            if best > 0:
                assert dists[name] == pytest.approx(best, rel=1e-6, abs=1e-9)


def test_ellipsoids_equal_brute_force(backend):
    rng = np.random.default_rng(44)
    scene = [(f"e{i}", cc.ellipsoid(*rng.uniform(0.2, 0.8, 3)),
              scenes.pose(scenes.random_rotation(rng), rng.uniform(0, 5, 3))) for i in range(30)]
    scene += mixed_scene(30, 45, side=5.0)
    m = build(scene, backend)
    expected = brute_colliding(scene)
    assert any(a.startswith("e") and b.startswith("e") for a, b in expected)
    assert any(a.startswith("e") != b.startswith("e") for a, b in expected)
    assert m.in_collision_internal(return_names=True) == (True, expected)
    best, names = brute_min_distance(scene)
    d, found = m.min_distance_internal(return_names=True)
    assert same_distance(d, best)
    probe = cc.ellipsoid(0.9, 0.4, 0.6)
    for _ in range(5):
        t = scenes.pose(scenes.random_rotation(rng), rng.uniform(0, 5, 3))
        hits = {n for n, g, tf in scene if cc.pair_in_collision(g, tf, probe, t)}
        assert m.in_collision_single(probe, t, return_names=True) == (bool(hits), hits)
        assert same_distance(m.min_distance_single(probe, t),
                             min(cc.pair_distance(g, tf, probe, t) for _, g, tf in scene))
    again = pickle.loads(pickle.dumps(m))
    assert again.in_collision_internal(return_names=True) == (True, expected)
    assert again.get_geometry("e0").kind == "ellipsoid"
    assert again.get_geometry("e0").params == scene[0][1].params
    for bad in ((0, 1, 1), (1, -1, 1), (1, 1, float("nan"))):
        with pytest.raises(ValueError, match="ellipsoid"):
            cc.ellipsoid(*bad)


def cone_meets_halfspace(cone, tf, n, d):
    """Exact: the lowest point of the cone along n is within n . x <= d."""
    r, h = cone.params
    R, t = tf[:3, :3], tf[:3, 3]
    m = R.T @ n
    low = min(m[2] * h / 2, -m[2] * h / 2 - r * np.hypot(m[0], m[1]))
    return low <= d - n @ t


def test_halfspaces_on_the_cube_backend_equal_brute_force():
    scene = [s for s in mixed_scene(60, 47, side=5.0) if s[1].kind != "convex"]
    spaces = [("h0", cc.halfspace([0.2, 0.1, 1.0], 0.8), np.eye(4)),
              ("h1", cc.halfspace([-1.0, 0.3, 0.2], -4.0), scenes.pose(np.eye(3), [0, 0, 0.5]))]
    scene += spaces
    m = build(scene)

    def collides(a, b):
        (na, ga, ta), (nb, gb, tb) = sorted((a, b), key=lambda s: s[1].kind != "halfspace")
        if ga.kind == "halfspace" and gb.kind == "cone":
            # FCL 0.7's cone-halfspace test is wrong; the library answers from the geometry
            n, d = np.array(ga.params[:3]), ga.params[3]
            n_w = ta[:3, :3] @ n
            return cone_meets_halfspace(gb, tb, n_w, d + n_w @ ta[:3, 3])
        return cc.pair_in_collision(ga, ta, gb, tb)

    expected = {tuple(sorted((a[0], b[0]))) for a, b in itertools.combinations(scene, 2)
                if collides(a, b)}
    assert any("h0" in p for p in expected) and any("h1" in p for p in expected)
    assert m.in_collision_internal(return_names=True) == (True, expected)
    probe = scenes.pose(np.eye(3), [1.0, 1.0, 0.0])
    assert m.in_collision_single(cc.sphere(0.3), probe, return_names=True)[1] == \
        {n for n, g, tf in scene if collides((n, g, tf), ("q", cc.sphere(0.3), probe))}
    again = pickle.loads(pickle.dumps(m))
    assert again.in_collision_internal(return_names=True) == (True, expected)
    # the library's distance to a halfspace: the sphere's gap above n . x = d
    alone = cc.CollisionManager()
    alone.add_object("h", cc.halfspace([0, 0, 2.0], 1.0))  # z <= 0.5
    alone.add_object("s", cc.sphere(0.5), scenes.pose(np.eye(3), [0, 0, 3.0]))
    assert alone.min_distance_internal() == pytest.approx(2.0)
    # refused where a plane is: the FCL backend, links, a convex beside it
    with pytest.raises(ValueError, match="halfspace"):
        cc.CollisionManager(backend="fcl").add_object("h", cc.halfspace([0, 0, 1.0], 0))
    with pytest.raises(ValueError, match="halfspace"):
        cc.Body().add_link(cc.halfspace([0, 0, 1.0], 0))
    with pytest.raises(ValueError, match="convex"):
        m.in_collision_single(scenes.random_convex(np.random.default_rng(1), 1.0), probe)
    with pytest.raises(ValueError, match="normal"):
        cc.halfspace([0, 0, 0], 1.0)


@pytest.mark.parametrize("probe", ["box", "mesh", "convex trimesh"])
def test_single_query_at_many_poses_equals_each_pose_and_brute_force(backend, probe):
    """in_collision_single with an (n, 4, 4) array: one answer per pose, each the single-pose
    call's, under the same filter bits and margins."""
    scene = mixed_scene(60, 41)
    m = build(scene, backend)
    rng = np.random.default_rng(42)
    masks = {}
    for name, _, _ in scene[::3]:  # category 2; half of them refuse the query's category 1
        masks[name] = int(rng.integers(2, 4))
        m.set_filter(name, 2, masks[name])
    if probe == "box":
        geometry, kw = cc.box(0.9, 0.5, 0.4), {}
    elif probe == "mesh":
        geometry, kw = cc.mesh(*scenes.uv_sphere(5, 0.5)), {}
    else:  # trimesh's keyword and a convex trimesh, taken as a solid as for one pose
        geometry, kw = None, {"mesh": TrimeshLike(BOX_VERTICES * 0.4, BOX_FACES, True)}
    solid = geometry if geometry is not None else cc.convex(BOX_VERTICES * 0.4, BOX_FACES)
    side = (4.0 * len(scene)) ** (1 / 3)
    poses = np.array([scenes.pose(scenes.random_rotation(rng), rng.uniform(0, side, 3))
                      for _ in range(120)])
    hits = m.in_collision_single(geometry, poses, **kw)
    assert isinstance(hits, np.ndarray) and hits.dtype == bool and hits.shape == (len(poses),)
    assert hits.tolist() == [m.in_collision_single(geometry, p, **kw) for p in poses]
    expected = [any(masks.get(n, 1) & 1 and cc.pair_in_collision(g, tf, solid, p)
                    for n, g, tf in scene) for p in poses]
    assert hits.tolist() == expected
    assert 0 < sum(expected) < len(expected)
    # margins: the poses within the margin of an allowed object hit too, as for one pose
    m.set_margin(0.3)
    wide = m.in_collision_single(geometry, poses, **kw)
    assert wide.tolist() == [m.in_collision_single(geometry, p, **kw) for p in poses]
    assert np.all(wide >= hits) and wide.sum() > hits.sum()
    assert m.in_collision_single(geometry, poses[:0], **kw).shape == (0,)


def test_single_query_at_many_poses_refuses_names_and_bad_poses(backend):
    m = build(mixed_scene(20, 43), backend)
    poses = np.array([np.eye(4)] * 3)
    with pytest.raises(ValueError, match="one pose"):
        m.in_collision_single(cc.sphere(0.5), poses, return_names=True)
    bad = poses.copy()
    bad[2, 0, 0] = 2.0  # a scale
    with pytest.raises(ValueError, match=r"transforms\[2\]"):
        m.in_collision_single(cc.sphere(0.5), bad)
    with pytest.raises(ValueError, match="shape"):
        m.in_collision_single(cc.sphere(0.5), np.zeros((3, 3, 4)))


@pytest.mark.parametrize("other_backend", ["cube", "fcl"])
def test_other_manager_equals_brute_force(backend, other_backend):
    a = mixed_scene(40, 11)
    b = [("b" + n, g, t) for n, g, t in mixed_scene(40, 12)]
    ma, mb = build(a, backend), build(b, other_backend)
    expected = {(na, nb) for na, ga, ta in a for nb, gb, tb in b
                if cc.pair_in_collision(ga, ta, gb, tb)}
    hit, names = ma.in_collision_other(mb, return_names=True)
    assert names == expected and hit == bool(expected)
    best = min(cc.pair_distance(ga, ta, gb, tb) for _, ga, ta in a for _, gb, tb in b)
    d, pair = ma.min_distance_other(mb, return_names=True)
    assert same_distance(d, best)
    assert pair[0] in ma and pair[1] in mb


def test_filters_and_excluded_pairs_equal_brute_force(backend):
    scene = mixed_scene(70, 5)
    m = build(scene, backend)
    rng = np.random.default_rng(9)
    bits = {}
    for name, _, _ in scene:
        cat, mask = 1 << int(rng.integers(3)), int(rng.integers(1, 8))
        bits[name] = (cat, mask)
        m.set_filter(name, cat, mask)
    pairs = sorted(brute_colliding(scene))
    excluded = {pairs[i] for i in range(0, len(pairs), 3)}
    for a, b in excluded:
        m.exclude_pair(a, b)

    def allowed(a, b):
        (ca, ma), (cb, mb) = bits[a], bits[b]
        return bool(ca & mb) and bool(cb & ma) and tuple(sorted((a, b))) not in excluded

    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene, allowed)
    assert same_distance(m.min_distance_internal(), brute_min_distance(scene, allowed)[0])
    m.clear_excluded()
    assert m.excluded_pairs == []


def test_excluded_pairs_are_the_rules_objects_on_either_backend(backend):
    """Both backends keep excluded pairs in the library's rules object: listed as (added first,
    added later), forgotten with a removed object, which comes back excluded from nothing."""
    scene = mixed_scene(12, 3)
    m = build(scene, backend)
    m.exclude_pair("o7", "o1")
    m.exclude_pair("o4", "o10")
    assert m.excluded_pairs == [("o1", "o7"), ("o4", "o10")]
    m.remove_object("o7")
    assert m.excluded_pairs == [("o4", "o10")]
    name, geometry, transform = scene[7]
    m.add_object(name, geometry, transform)
    assert m.excluded_pairs == [("o4", "o10")]
    kept = lambda a, b: tuple(sorted((a, b))) != ("o10", "o4")
    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene, kept)


def test_pair_passes_is_whether_the_internal_query_reports_an_overlapping_pair(backend):
    """pair_passes(a, b) over every ordered pair of objects all around the origin (so that every
    pair collides), under random filter bits and excluded pairs: true exactly for the pairs
    in_collision_internal reports, and for those the bits and exclusions let through."""
    rng = np.random.default_rng(17)
    scene = []
    for i in range(24):
        size = rng.uniform(0.4, 1.0)
        g = [cc.box(*rng.uniform(0.4, 1.0, 3)), cc.sphere(size / 2),
             cc.capsule(size / 4, size), cc.cylinder(size / 3, size)][i % 4]
        centre = rng.uniform(-0.05, 0.05, 3)
        scene.append((f"o{i}", g, scenes.pose(scenes.random_rotation(rng), centre)))
    names = [n for n, _, _ in scene]
    every = set(itertools.combinations(sorted(names), 2))
    m = build(scene, backend)
    assert m.in_collision_internal(return_names=True)[1] == every  # every pair overlaps
    assert all(m.pair_passes(a, b) for a, b in every)
    bits = {}
    for name in names:
        if rng.integers(4) == 0:
            bits[name] = (1, cc.ALL_BITS)  # the default, left as it is
            continue
        bits[name] = (1 << int(rng.integers(4)), int(rng.integers(16)))
        m.set_filter(name, *bits[name])
    excluded = {p for p in sorted(every) if rng.integers(3) == 0}
    for a, b in excluded:
        if rng.integers(2):
            a, b = b, a  # either order names the pair
        m.exclude_pair(a, b)

    def allowed(a, b):
        (ca, ma), (cb, mb) = bits[a], bits[b]
        return bool(ca & mb) and bool(cb & ma) and tuple(sorted((a, b))) not in excluded

    reported = m.in_collision_internal(return_names=True)[1]
    passing = 0
    for a in names:
        assert not m.pair_passes(a, a)
        for b in names:
            if a == b:
                continue
            got = m.pair_passes(a, b)
            assert got == (tuple(sorted((a, b))) in reported), (a, b)
            assert got == allowed(a, b), (a, b)
            passing += got
    # Both answers occur, for each reason a pair is held.
    held_by_bits = [p for p in every if p not in excluded and not allowed(*p)]
    assert passing > 0 and excluded and held_by_bits and reported
    assert len(reported) < len(every)


EXCLUDE_NAMES = ("exclude_pair", "include_pair", "excluded_pairs", "clear_excluded")
ALIAS_NAMES = ("ignore_pair", "unignore_pair", "ignored_pairs", "clear_ignored")


@pytest.mark.parametrize("names", [EXCLUDE_NAMES, ALIAS_NAMES], ids=["exclude", "ignore"])
def test_excluded_pairs_equal_brute_force_under_either_name(backend, names):
    """exclude_pair / include_pair / excluded_pairs / clear_excluded and their aliases
    ignore_pair / unignore_pair / ignored_pairs / clear_ignored give the same answers: the
    colliding pairs and the smallest distance of brute force over the pairs not excluded, and
    the same list under both property names."""
    exclude, include, listed, clear = names
    scene = mixed_scene(60, 31)
    m = build(scene, backend)
    pairs = sorted(brute_colliding(scene))
    chosen = pairs[::2]
    for a, b in chosen:
        getattr(m, exclude)(a, b)
    back = chosen[::3]
    for a, b in back:
        getattr(m, include)(b, a)  # either order names the pair
    excluded = set(chosen) - set(back)
    assert len(excluded) >= 5 and len(back) >= 2
    got = getattr(m, listed)
    assert {tuple(sorted(p)) for p in got} == excluded
    assert m.excluded_pairs == m.ignored_pairs == got

    def kept(a, b):
        return tuple(sorted((a, b))) not in excluded

    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene, kept)
    assert same_distance(m.min_distance_internal(), brute_min_distance(scene, kept)[0])
    getattr(m, clear)()
    assert m.excluded_pairs == m.ignored_pairs == []
    assert m.in_collision_internal(return_names=True)[1] == set(pairs)


def test_margins_equal_brute_force(backend):
    scene = mixed_scene(50, 21, side=9.0, meshes=True)
    m = build(scene, backend)
    m.set_margin(0.1)
    own = {scene[i][0]: 0.3 for i in range(0, 50, 7)}
    for name, margin in own.items():
        m.set_margin(margin, name)

    def margin(n):
        return own.get(n, 0.1)

    expected = set()
    for (na, ga, ta), (nb, gb, tb) in itertools.combinations(scene, 2):
        if cc.pair_in_collision(ga, ta, gb, tb) or \
                cc.pair_distance(ga, ta, gb, tb) <= margin(na) + margin(nb):
            expected.add(tuple(sorted((na, nb))))
    hit, names, data = m.in_collision_internal(return_names=True, return_data=True)
    assert names == expected
    assert {tuple(sorted(p)) for p in data["names"]} == expected


def test_backends_agree_after_motion_and_removal():
    scene = mixed_scene(60, 31)
    cube, fcl = build(scene), build(scene, "fcl")
    rng = np.random.default_rng(4)
    for step in range(3):
        names = [n for n, _, _ in scene[step::3]]
        tfs = np.stack([scenes.pose(scenes.random_rotation(rng),
                                                  rng.uniform(0, 6, 3)) for _ in names])
        cube.set_transforms(names, tfs)
        fcl.set_transforms(names, tfs)
        cube.remove_object(scene[step][0])
        fcl.remove_object(scene[step][0])
        now = [(n, cube.get_geometry(n), cube.get_transform(n)) for n in cube.names]
        expected = brute_colliding(now)
        assert cube.in_collision_internal(return_names=True)[1] == expected
        assert fcl.in_collision_internal(return_names=True)[1] == expected


def test_batches_into_a_filled_manager(backend):
    scene = mixed_scene(90, 51)
    m = build(scene[:30], backend)
    for name, g, t in scene[30:45]:
        m.add_object(name, g, t)
    names, geoms, tfs = zip(*scene[45:])
    m.add_objects(list(names), list(geoms), np.stack(tfs))
    assert m.names == [n for n, _, _ in scene]
    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene)
    assert same_distance(m.min_distance_internal(), brute_min_distance(scene)[0])


def test_same_geometry_under_several_names():
    g = cc.mesh(*scenes.uv_sphere(6, 1.0))
    scene = [(f"s{i}", g, scenes.pose(np.eye(3), [1.5 * i, 0, 0])) for i in range(6)]
    m = build(scene)
    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene)
    d, names = m.min_distance_internal(return_names=True)
    assert d <= 0 and names[0] != names[1]


def test_planes_on_the_cube_backend():
    scene = [s for s in mixed_scene(40, 41) if s[1].kind != "convex"]
    floor = ("floor", cc.plane([0, 0, 1], 1.0), np.eye(4))
    m = build(scene + [floor])
    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(scene + [floor])
    probe = np.eye(4)
    probe[2, 3] = 1.2
    expected = {n for n, g, t in scene + [floor] if cc.pair_in_collision(g, t, cc.sphere(0.5), probe)}
    assert m.in_collision_single(cc.sphere(0.5), probe, return_names=True)[1] == expected
    with pytest.raises(ValueError):  # FCL's tree needs bounded boxes
        cc.CollisionManager(backend="fcl").add_object("floor", floor[1])


def test_what_crashes_fcl_is_refused():
    """FCL 0.7 segfaults in fcl::distance with a plane and in fcl::collide of a plane and a
    convex: these get ValueError where FCL's own calls would run (the 'fcl' backend,
    pair_distance), and nothing changes."""
    rng = np.random.default_rng(0)
    hull = scenes.random_convex(rng, 1.0)
    floor = cc.plane([0, 0, 1], 0.0)
    m = cc.CollisionManager()
    m.add_object("floor", floor)
    m.add_object("ball", cc.sphere(0.5))
    fcl_manager = cc.CollisionManager(backend="fcl")
    fcl_manager.add_object("ball", cc.sphere(0.5))
    for call in (lambda: m.add_object("hull", hull), lambda: fcl_manager.min_distance_single(floor),
                 lambda: m.in_collision_single(hull),
                 lambda: cc.pair_in_collision(floor, np.eye(4), hull, np.eye(4)),
                 lambda: cc.pair_distance(floor, np.eye(4), cc.sphere(1), np.eye(4)),
                 # a cube manager's plane measured against an FCL-backend manager: fcl::distance
                 lambda: m.min_distance_other(fcl_manager),
                 lambda: fcl_manager.min_distance_other(m)):
        with pytest.raises(ValueError):
            call()
    other = cc.CollisionManager()
    other.add_object("hull", hull)
    with pytest.raises(ValueError):
        m.in_collision_other(other)
    body = cc.Body()
    body.add_link(hull)
    with pytest.raises(ValueError):
        m.check_states(body, np.eye(4)[None, None])
    assert m.names == ["floor", "ball"] and m.in_collision_internal()


@pytest.mark.parametrize("other_backend", ["cube", "fcl"])
def test_filter_bits_apply_between_managers_of_either_backend(backend, other_backend):
    """Both managers' bits decide, whichever backend each side has and whichever side asks."""
    a = mixed_scene(40, 61, side=5.0)
    b = [("b" + n, g, t) for n, g, t in mixed_scene(40, 62, side=5.0)]
    ma, mb = build(a, backend), build(b, other_backend)
    rng = np.random.default_rng(63)
    bits = {}
    for m, scene in ((ma, a), (mb, b)):
        for name, _, _ in scene:
            bits[name] = (1 << int(rng.integers(3)), int(rng.integers(1, 8)))
            m.set_filter(name, *bits[name])

    def allowed(x, y):
        (cx, mx), (cy, my) = bits[x], bits[y]
        return bool(cx & my) and bool(cy & mx)

    expected = {(na, nb) for na, ga, ta in a for nb, gb, tb in b
                if allowed(na, nb) and cc.pair_in_collision(ga, ta, gb, tb)}
    assert expected  # the scene has allowed colliding pairs, and forbidden ones below
    assert expected != {(na, nb) for na, ga, ta in a for nb, gb, tb in b
                        if cc.pair_in_collision(ga, ta, gb, tb)}
    assert ma.in_collision_other(mb, return_names=True) == (True, expected)
    assert mb.in_collision_other(ma, return_names=True) == \
        (True, {(y, x) for x, y in expected})
    hit, names, data = ma.in_collision_other(mb, return_names=True, return_data=True)
    assert names == expected and {tuple(p) for p in data["names"]} == expected

    # Distances: every touching pair made forbidden (the b side's mask loses the a side's
    # category), so that the allowed minimum is positive and the forbidden pairs would undercut it.
    touching = {(na, nb) for na, ga, ta in a for nb, gb, tb in b
                if cc.pair_distance(ga, ta, gb, tb) <= 0}
    assert touching
    for na, nb in touching:
        bits[nb] = (bits[nb][0], bits[nb][1] & ~bits[na][0])
    for name, _, _ in b:
        mb.set_filter(name, *bits[name])
    best, pair = min((cc.pair_distance(ga, ta, gb, tb), (na, nb)) for na, ga, ta in a
                     for nb, gb, tb in b if allowed(na, nb))
    assert 0 < best < float("inf")
    d, names = ma.min_distance_other(mb, return_names=True)
    assert same_distance(d, best) and names == pair
    d, names = mb.min_distance_other(ma, return_names=True)
    assert same_distance(d, best) and names == pair[::-1]


def lowest_along(kind, size, g, transform, n):
    """min of n . x over a placed shape, from its own description: a sphere's centre less its
    radius, a box's corners, a cylinder's centre . n - |axis . n| h/2 - r sqrt(1 - (axis . n)^2),
    a capsule's end balls, a cone's apex or lowest base rim point, a mesh's vertices."""
    R, t = transform[:3, :3], transform[:3, 3]
    c, a = t @ n, R[:, 2] @ n
    rim = np.sqrt(max(0.0, 1 - a * a))
    if kind == "sphere":
        return c - size[0]
    if kind == "box":
        corners = np.array(list(itertools.product(*[(-s / 2, s / 2) for s in size])))
        return min((corners @ R.T + t) @ n)
    if kind == "cylinder":
        return c - abs(a) * size[1] / 2 - size[0] * rim
    if kind == "capsule":
        return c - abs(a) * size[1] / 2 - size[0]
    if kind == "cone":
        return min(c + a * size[1] / 2, c - a * size[1] / 2 - size[0] * rim)
    return min((np.asarray(size) @ R.T + t) @ n)  # a mesh: its vertices


def test_distances_to_tilted_planes_far_away_are_exact():
    """A plane n . x = d whose normal is tilted and which passes about 1000 units from the
    origin: min_distance_single / _internal / _other give every kind its exact distance (the gap
    between the plane and the shape's nearer extreme along n; -1 when they meet), with the
    plane's nearest point on the plane."""
    rng = np.random.default_rng(11)
    verts, faces = scenes.uv_sphere(6, 0.6)
    kinds = [("sphere", (0.5,), cc.sphere(0.5)), ("box", (1.0, 0.4, 0.7), cc.box(1.0, 0.4, 0.7)),
             ("cylinder", (0.3, 1.6), cc.cylinder(0.3, 1.6)),
             ("capsule", (0.25, 0.9), cc.capsule(0.25, 0.9)),
             ("cone", (0.4, 1.2), cc.cone(0.4, 1.2)),
             ("mesh", np.asarray(verts, dtype=float), cc.mesh(verts, faces))]
    apart = meeting = 0
    for rep in range(15):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        anchor = np.array([600.0, -700.0, 500.0]) + rng.uniform(-5, 5, 3)
        d = float(n @ anchor)
        floor = cc.plane(n, d)
        m = cc.CollisionManager()
        m.add_object("floor", floor)
        for kind, size, g in kinds:
            tf = scenes.pose(scenes.random_rotation(rng),
                             anchor + np.cross(n, rng.normal(size=3)) + n * rng.uniform(-3, 6))
            lo = lowest_along(kind, size, g, tf, n) - d
            hi = d + lowest_along(kind, size, g, tf, -n)  # d - max n . x
            gap = max(lo, hi)
            if abs(gap) < 1e-6:
                continue
            want = gap if gap > 0 else -1.0
            apart += gap > 0
            meeting += gap <= 0
            dist, name, data = m.min_distance_single(g, tf, return_name=True, return_data=True)
            assert abs(dist - want) < 1e-6, (kind, rep)
            assert name == "floor"
            if want > 0:
                on_plane = data["points"][list(data["names"]).index("floor")]
                assert abs(on_plane @ n - d) < 1e-6
                assert abs(np.linalg.norm(data["points"][0] - data["points"][1]) - want) < 1e-6
            pair = cc.CollisionManager()
            pair.add_object("floor", floor)
            pair.add_object("thing", g, tf)
            assert abs(pair.min_distance_internal() - want) < 1e-6, (kind, rep)
            other = cc.CollisionManager()
            other.add_object("thing", g, tf)
            assert abs(m.min_distance_other(other) - want) < 1e-6, (kind, rep)
            assert abs(other.min_distance_other(m) - want) < 1e-6, (kind, rep)
    assert apart > 20 and meeting > 10


def test_sphere_above_a_tilted_plane_is_free_beyond_its_margin():
    """A sphere 50 units above x + y + z = 0 with a margin of 0.01 is free, its clearance 50;
    0.005 above, within its margin it collides."""
    n = np.ones(3) / np.sqrt(3)
    m = cc.CollisionManager()
    m.add_object("floor", cc.plane(n, 0.0))
    body = cc.Body()
    body.add_link(cc.sphere(0.5), margin=0.01)
    for gap in (50.0, 0.02, 0.005):
        r = m.check_states(body, scenes.pose(np.eye(3), n * (0.5 + gap))[None, None],
                           clearance=True)
        assert bool(r["colliding"][0]) == (gap <= 0.01)
        if gap > 0.01:
            assert abs(r["clearance"][0] - gap) < 1e-9
        assert abs(m.min_distance_single(cc.sphere(0.5), scenes.pose(np.eye(3), n * (0.5 + gap)))
                   - gap) < 1e-9
