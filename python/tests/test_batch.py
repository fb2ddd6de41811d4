"""Batched states and motions against brute force over every link, world object and link pair."""

import numpy as np
import pytest

import cube_collision as cc
import scenes
from conftest import build, mixed_scene, same_distance


def robot(links=5, exclude="exclude_pair"):
    body = cc.Body()
    geoms = []
    for i in range(links):
        g = [cc.capsule(0.15, 0.8), cc.box(0.3, 0.3, 0.9), cc.cylinder(0.2, 0.7),
             cc.mesh(*scenes.tube(8, 0.2, 0.8))][i % 4]
        geoms.append(g)
        assert body.add_link(g) == i
    for i in range(links - 1):
        getattr(body, exclude)(i, i + 1)
    return body, geoms


def poses(rng, states, links, spread=6.0):
    out = np.zeros((states, links, 4, 4))
    for k in range(states):
        base = rng.uniform(0, spread, 3)
        for l in range(links):
            out[k, l] = scenes.pose(scenes.random_rotation(rng), base + rng.normal(0, 0.6, 3))
    return out


def brute_state(world, geoms, pose, allowed, self_collision):
    """(colliding, first pair, clearance) by the documented rule."""
    first, clearance = None, np.inf
    for l, g in enumerate(geoms):
        for name, wg, wt in world:
            if cc.pair_in_collision(g, pose[l], wg, wt):
                first = first or (l, name, -1)
            clearance = min(clearance, cc.pair_distance(g, pose[l], wg, wt))
        if self_collision:
            for j in range(l + 1, len(geoms)):
                if (l, j) in allowed:
                    continue
                if cc.pair_in_collision(g, pose[l], geoms[j], pose[j]):
                    first = first or (l, None, j)
                clearance = min(clearance, cc.pair_distance(g, pose[l], geoms[j], pose[j]))
    return first is not None, first, clearance


def brute_colliding(world, geoms, pose, allowed, self_collision):
    """Whether any link meets a world object (or, self_collision, a link not excluded)."""
    for l, g in enumerate(geoms):
        if any(cc.pair_in_collision(g, pose[l], wg, wt) for _, wg, wt in world):
            return True
        if self_collision and any(
                cc.pair_in_collision(g, pose[l], geoms[j], pose[j])
                for j in range(l + 1, len(geoms)) if (l, j) not in allowed):
            return True
    return False


@pytest.mark.parametrize("exclude", ["exclude_pair", "allow_pair"])
@pytest.mark.parametrize("self_collision", [False, True])
def test_check_states_equals_brute_force(self_collision, exclude):
    """Either name of the excluded link pairs (allow_pair is exclude_pair's alias) gives the
    answers of brute force over the pairs not excluded."""
    world = mixed_scene(40, 13)
    m = build(world)
    body, geoms = robot(exclude=exclude)
    assert body.excluded_pairs == body.allowed_pairs == [(i, i + 1) for i in range(len(geoms) - 1)]
    allowed = {(i, i + 1) for i in range(len(geoms) - 1)}
    rng = np.random.default_rng(5)
    p = poses(rng, 40, len(geoms))
    for threads in (1, 2):
        r = m.check_states(body, p, self_collision=self_collision, first_pair=True,
                           clearance=True, threads=threads)
        for k in range(len(p)):
            hit, first, clearance = brute_state(world, geoms, p[k], allowed, self_collision)
            assert r["colliding"][k] == hit
            if hit:
                assert (r["link"][k], r["object"][k], r["other_link"][k]) == first
                assert r["clearance"][k] == 0
            else:
                assert r["link"][k] == -1 and r["object"][k] is None
                assert same_distance(r["clearance"][k], clearance)


def test_check_motions_equal_the_first_colliding_state():
    world = mixed_scene(40, 14)
    m = build(world)
    body, geoms = robot()
    rng = np.random.default_rng(6)
    p = poses(rng, 60, len(geoms))
    starts = np.array([0, 7, 20, 21, 45])
    colliding = m.check_states(body, p)["colliding"]
    ends = list(starts[1:]) + [len(p)]
    path = m.check_motions(body, p, starts)
    bis = m.check_motions(body, p, starts, order="bisection")
    for e, (s, t) in enumerate(zip(starts, ends)):
        hits = np.flatnonzero(colliding[s:t])
        assert path[e] == (hits[0] if len(hits) else -1)
        assert (bis[e] == -1) == (len(hits) == 0)
        if len(hits):
            assert colliding[s + bis[e]]


def bisection_order(n):
    """OMPL's DiscreteMotionValidator order, as the docstring of check_motions names it: the last
    state, then the middles of the intervals left, breadth first."""
    if n < 2:
        return list(range(n))
    out, open_ = [n - 1], [(0, n - 2)]
    while open_:
        lo, hi = open_.pop(0)
        mid = lo + (hi - lo) // 2
        out.append(mid)
        if mid > lo:
            open_.append((lo, mid - 1))
        if mid < hi:
            open_.append((mid + 1, hi))
    return out


def edge_poses(rng, edges, links, spread=6.0):
    """Straight sweeps of a random rigid shape of links: (poses, edge starts)."""
    shape = [scenes.pose(scenes.random_rotation(rng), rng.normal(0, 0.6, 3)) for _ in range(links)]
    out, starts = [], []
    for e in range(edges):
        starts.append(len(out))
        a, b = rng.uniform(0, spread, 3), rng.uniform(0, spread, 3)
        n = 1 + (e * 13) % 40
        for k in range(n):
            t = k / (n - 1) if n > 1 else 0.0
            state = np.array(shape)
            state[:, :3, 3] += a + t * (b - a)
            out.append(state)
    return np.array(out), np.array(starts)


@pytest.mark.parametrize("self_collision", [False, True])
def test_check_motions_equal_brute_force(self_collision):
    """Each edge's answer is the first state in its order that brute force finds colliding, on
    one and two threads (batches above the 64 states from which the threads run)."""
    world = mixed_scene(40, 16)
    m = build(world)
    body, geoms = robot()
    allowed = {(i, i + 1) for i in range(len(geoms) - 1)}
    p, starts = edge_poses(np.random.default_rng(8), 20, len(geoms))
    assert len(p) > 128
    hit = [brute_colliding(world, geoms, p[k], allowed, self_collision) for k in range(len(p))]
    ends = list(starts[1:]) + [len(p)]
    free_edges = 0
    for order in ("path", "bisection"):
        for threads in (1, 2):
            got = m.check_motions(body, p, starts, order=order, self_collision=self_collision,
                                  threads=threads)
            free_edges = 0
            for e, (s, t) in enumerate(zip(starts, ends)):
                visit = list(range(t - s)) if order == "path" else bisection_order(t - s)
                want = next((i for i in visit if hit[s + i]), -1)
                assert got[e] == want, (order, threads, e)
                free_edges += want == -1
    # The scene must exercise both answers.
    assert 0 < free_edges < len(starts)


def test_check_states_on_threads_equal_brute_force():
    """A batch above the threads' 64 states: every thread count gives brute force's answers."""
    world = mixed_scene(40, 17)
    m = build(world)
    body, geoms = robot()
    allowed = {(i, i + 1) for i in range(len(geoms) - 1)}
    p = poses(np.random.default_rng(9), 150, len(geoms))
    want = [brute_colliding(world, geoms, p[k], allowed, True) for k in range(len(p))]
    assert 5 < sum(want) < len(p) - 5
    for threads in (1, 2, 3):
        got = m.check_states(body, p, self_collision=True, threads=threads)["colliding"]
        assert list(got) == want


def test_a_pose_that_is_not_rigid_is_named():
    """check_states names the first pose that is not rigid, on any thread count; check_motions
    does where its state is checked (before its edge's first colliding state), and reads no
    state after it, as the library's checkMotions."""
    world = mixed_scene(40, 18)
    m = build(world)
    body, geoms = robot()
    p = poses(np.random.default_rng(10), 150, len(geoms))
    bad = p.copy()
    bad[120, 3, :3, :3] *= 1.01  # scaled: not rigid
    bad[130, 1, 0, 3] = np.nan
    for threads in (1, 2):
        with pytest.raises(ValueError, match=r"poses\[120, 3\].*rigid"):
            m.check_states(body, bad, threads=threads)
    colliding = m.check_states(body, p)["colliding"]
    hit = int(np.flatnonzero(colliding)[0])
    free = int(np.flatnonzero(~colliding)[0])
    for threads in (1, 2):
        # A colliding state, then the bad one: the edge's answer is its first state.
        edge = np.stack([p[hit], bad[120]])
        assert list(m.check_motions(body, edge, [0], threads=threads)) == [0]
        # A free state, then the bad one: read, and named.
        edge = np.stack([p[free], bad[120]])
        with pytest.raises(ValueError, match=r"poses\[1, 3\].*rigid"):
            m.check_motions(body, edge, [0], threads=threads)
        edge = np.stack([p[free], bad[130]])
        with pytest.raises(ValueError, match=r"poses\[1, 1\]"):
            m.check_motions(body, edge, [0], threads=threads)


@pytest.mark.parametrize("call, error", [
    (lambda m, b, p: m.check_states(b, p[:, :2]), ValueError),        # wrong number of links
    (lambda m, b, p: m.check_states(b, p.astype(str)), TypeError),
    (lambda m, b, p: m.check_states(b, np.where(np.isfinite(p), p, 0) * np.nan), ValueError),
    (lambda m, b, p: m.check_states(b, p * 2), ValueError),           # not rigid
    (lambda m, b, p: m.check_states(cc.Body(), p), ValueError),       # no link
    (lambda m, b, p: m.check_motions(b, p, [1, 2]), ValueError),      # not starting at 0
    (lambda m, b, p: m.check_motions(b, p, [0, 3, 3]), ValueError),
    (lambda m, b, p: m.check_motions(b, p, [0, 2.5]), TypeError),
    (lambda m, b, p: m.check_motions(b, p, [0], order="random"), ValueError),
    (lambda m, b, p: cc.CollisionManager(backend="fcl").check_states(b, p), ValueError),
])
def test_batch_bad_input(call, error):
    m = build(mixed_scene(10, 15))
    body, geoms = robot()
    p = poses(np.random.default_rng(0), 5, len(geoms))
    with pytest.raises(error):
        call(m, body, p)


def test_body_bad_input():
    body = cc.Body()
    with pytest.raises(ValueError):
        body.add_link(cc.plane([0, 0, 1], 0))
    with pytest.raises(ValueError):
        body.add_link(cc.sphere(1), margin=-1)
    with pytest.raises(TypeError):
        body.add_link("sphere")
    body.add_link(cc.sphere(1))
    for exclude in (body.exclude_pair, body.allow_pair):
        with pytest.raises(ValueError):
            exclude(0, 0)
        with pytest.raises(ValueError):
            exclude(0, 3)
    assert len(body) == 1 and body.excluded_pairs == []
