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
