"""Continuous edges (check_motions with continuous=True or motion_bounds) against brute force: the
documented rule (each state checked with each link's margin raised by half the larger motion
bound of the intervals it ends and starts, by FCL's narrow phase pair by pair), a subdivision
100 times finer checked state by state, and the discrete check."""

import numpy as np
import pytest

import cube_collision as cc
import scenes
from conftest import build, mixed_scene
from test_batch import bisection_order

FINE = 100  # fine states per interval of an edge
SIDE = 8.0  # the world's cube


def rotation(axis, angle):
    """The rotation by `angle` about the unit `axis` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def robot():
    """(body, geometries, reach): links of several kinds, adjacent ones excluded; reach[l] the
    farthest corner of link l's local box from its origin."""
    tube = scenes.tube(8, 0.15, 0.7)
    links = [(cc.box(0.3, 0.2, 0.6), [0.15, 0.1, 0.3]),
             (cc.capsule(0.12, 0.5), [0.12, 0.12, 0.25 + 0.12]),
             (cc.cylinder(0.15, 0.5), [0.15, 0.15, 0.25]),
             (cc.sphere(0.2), [0.2, 0.2, 0.2]),
             (cc.mesh(*tube), None)]
    body, geoms, reach = cc.Body(), [], []
    for g, half in links:
        body.add_link(g)
        geoms.append(g)
        if half is None:
            lo, hi = tube[0].min(axis=0), tube[0].max(axis=0)
            far = np.abs((lo + hi) / 2) + (hi - lo) / 2
        else:
            far = np.array(half)
        reach.append(float(np.linalg.norm(far)))
    for i in range(len(geoms) - 1):
        body.exclude_pair(i, i + 1)
    return body, geoms, np.array(reach)


def world(seed):
    """Mixed objects and thin plates (thinner than an edge's step: a discrete check steps over
    them)."""
    scene = mixed_scene(12, seed, side=SIDE)
    rng = np.random.default_rng(seed + 100)
    for i in range(12):
        scene.append((f"plate{i}", cc.box(3.0, 3.0, 0.02),
                      scenes.pose(scenes.random_rotation(rng), rng.uniform(0, SIDE, 3))))
    return scene


def se3_edges(rng, edges, links):
    """Edges along which each link moves in SE(3) (translation linear, rotation about a fixed
    axis: the geodesic): (poses, starts, fine poses per edge)."""
    poses, starts, fine = [], [], []
    for e in range(edges):
        n = 1 if e % 7 == 3 else int(rng.integers(2, 8))
        base, shift = rng.uniform(0, SIDE, 3), rng.normal(0, 1.5, 3)
        motion = [(scenes.random_rotation(rng), rng.normal(0, 0.5, 3),
                   scenes.random_rotation(rng)[0], rng.uniform(-1.5, 1.5)) for _ in range(links)]

        def state(t):
            return np.array([scenes.pose(r0 @ rotation(axis, theta * t), base + off + t * shift)
                             for r0, off, axis, theta in motion])
        starts.append(len(poses))
        poses += [state(k / max(n - 1, 1)) for k in range(n)]
        fine.append(np.array([state(j / (FINE * max(n - 1, 1)))
                              for j in range(FINE * (n - 1) + 1)]))
    return np.array(poses), np.array(starts), fine


def arc_edges(rng, edges, links):
    """Edges along which the links turn together about an axis through a moving point (a joint
    of a robot interpolated in joint space: each link's origin moves along an arc, not a line),
    with motion bounds from that kinematics: (poses, starts, bounds, fine poses per edge)."""
    _, _, reach = robot()
    poses, starts, bounds, fine = [], [], [], []
    for e in range(edges):
        n = int(rng.integers(2, 8))
        center, shift = rng.uniform(0, SIDE, 3), rng.normal(0, 0.3, 3)
        axis, dq = scenes.random_rotation(rng)[0], rng.uniform(-2.5, 2.5)
        local = [scenes.pose(scenes.random_rotation(rng), center + rng.normal(0, 0.7, 3))
                 for _ in range(links)]

        def state(t):
            turn = scenes.pose(rotation(axis, dq * t), center + t * shift - rotation(
                axis, dq * t) @ center)
            return np.array([turn @ p for p in local])
        starts.append(len(poses))
        poses += [state(k / (n - 1)) for k in range(n)]
        # A point x of link l moves at most |shift| + |dq| |x - center| over the edge.
        per = [(np.linalg.norm(shift) + abs(dq) * (np.linalg.norm(p[:3, 3] - center) + reach[l]))
               / (n - 1) for l, p in enumerate(local)]
        bounds += [per] * (n - 1) + [[0.0] * links]
        fine.append(np.array([state(j / (FINE * (n - 1))) for j in range(FINE * (n - 1) + 1)]))
    return np.array(poses), np.array(starts), np.array(bounds), fine


def se3_bounds(poses, starts, reach):
    """The SE(3) bounds as the library computes them from the poses: |t1 - t0| + angle * reach,
    per interval within an edge."""
    out = np.zeros(poses.shape[:2])
    ends = set(np.append(starts[1:], len(poses)) - 1)
    for k in range(len(poses) - 1):
        if k in ends:
            continue
        for l in range(poses.shape[1]):
            a, b = poses[k, l], poses[k + 1, l]
            m = a[:3, :3].T @ b[:3, :3]
            s = 0.5 * np.linalg.norm([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
            angle = np.arctan2(s, 0.5 * (np.trace(m) - 1))
            out[k, l] = np.linalg.norm(b[:3, 3] - a[:3, 3]) + angle * reach[l]
    return out


def raised_fails(scene, geoms, pose, raise_, excluded, self_collision):
    """Whether a state fails with each link's margin raised: a contact (fcl::collide) or
    fcl::distance within the raises, over every link and world object (and link pair)."""
    for l, g in enumerate(geoms):
        for _, wg, wt in scene:
            if (cc.pair_in_collision(g, pose[l], wg, wt)
                    or cc.pair_distance(g, pose[l], wg, wt) <= raise_[l]):
                return True
        if self_collision:
            for j in range(l + 1, len(geoms)):
                if (l, j) in excluded:
                    continue
                if (cc.pair_in_collision(g, pose[l], geoms[j], pose[j])
                        or cc.pair_distance(g, pose[l], geoms[j], pose[j])
                        <= raise_[l] + raise_[j]):
                    return True
    return False


def rule_answers(scene, geoms, poses, starts, bounds, order, self_collision, excluded):
    """Per edge, the first state in `order` whose raised check fails, -1 if none: the documented
    rule, by brute force."""
    out = []
    ends = list(starts[1:]) + [len(poses)]
    for s, t in zip(starts, ends):
        visit = list(range(t - s)) if order == "path" else bisection_order(t - s)
        answer = -1
        for i in visit:
            k = s + i
            before = bounds[k - 1] if k > s else np.zeros(len(geoms))
            after = bounds[k] if k + 1 < t else np.zeros(len(geoms))
            if raised_fails(scene, geoms, poses[k], 0.5 * np.maximum(before, after), excluded,
                            self_collision):
                answer = i
                break
        out.append(answer)
    return out


def check_against_fine_and_discrete(m, body, poses, starts, fine, got, self_collision, order):
    """Continuous never says free where the fine subdivision finds a contact, and finds a
    collision no later (in the order) than the discrete check. Returns (edges the discrete check
    misses, edges refused that the fine subdivision finds free)."""
    discrete = m.check_motions(body, poses, starts, order=order, self_collision=self_collision)
    ends = list(starts[1:]) + [len(poses)]
    missed = refused = 0
    for e, (s, t) in enumerate(zip(starts, ends)):
        touches = bool(m.check_states(body, fine[e], self_collision=self_collision)
                       ["colliding"].any())
        if touches:
            assert got[e] != -1, e
        if discrete[e] != -1:
            visit = list(range(t - s)) if order == "path" else bisection_order(t - s)
            assert got[e] != -1 and visit.index(got[e]) <= visit.index(discrete[e]), e
        missed += touches and discrete[e] == -1
        refused += not touches and got[e] != -1
    return missed, refused


@pytest.mark.parametrize("self_collision", [False, True])
def test_continuous_se3_edges_follow_the_rule_and_miss_no_contact(self_collision):
    """continuous=True: the answers are the raised check's with the SE(3) bounds of the poses,
    on one and two threads (more than one chunk of converted states), never free where a
    subdivision 100 times finer touches, and never later than the discrete check."""
    scene = world(31)
    m = build(scene)
    body, geoms, reach = robot()
    excluded = set(body.excluded_pairs)
    poses, starts, fine = se3_edges(np.random.default_rng(32), 130, len(geoms))
    assert len(poses) > 512
    bounds = se3_bounds(poses, starts, reach)
    for order in ("path", "bisection"):
        want = rule_answers(scene, geoms, poses, starts, bounds, order, self_collision, excluded)
        for threads in (1, 2):
            got = m.check_motions(body, poses, starts, order=order, continuous=True,
                                  self_collision=self_collision, threads=threads)
            assert list(got) == want, (order, threads)
        missed, refused = check_against_fine_and_discrete(m, body, poses, starts, fine, got,
                                                          self_collision, order)
        # The scene must exercise the option: contacts the discrete check steps over, and
        # edges free all along.
        assert missed > 0 and want.count(-1) > 0, (missed, refused)


def test_continuous_with_kinematic_bounds_follows_the_rule_and_misses_no_contact():
    """motion_bounds from the kinematics of a joint-space motion (arcs, which the SE(3) bounds
    do not cover): the answers are the raised check's with those bounds, with or without
    continuous=True, never free where the fine subdivision touches."""
    scene = world(41)
    m = build(scene)
    body, geoms, _ = robot()
    excluded = set(body.excluded_pairs)
    poses, starts, bounds, fine = arc_edges(np.random.default_rng(42), 130, len(geoms))
    assert len(poses) > 512
    want = rule_answers(scene, geoms, poses, starts, bounds, "path", True, excluded)
    for threads in (1, 2):
        for continuous in (False, True):
            got = m.check_motions(body, poses, starts, self_collision=True, continuous=continuous,
                                  motion_bounds=bounds, threads=threads)
            assert list(got) == want, (continuous, threads)
    missed, _ = check_against_fine_and_discrete(m, body, poses, starts, fine, got, True, "path")
    assert missed > 0 and want.count(-1) > 0


def test_zero_bounds_give_the_discrete_answers():
    """Bounds of 0 (nothing moves between states) raise no margin: the discrete answers."""
    scene = world(51)
    m = build(scene)
    body, geoms, _ = robot()
    poses, starts, _ = se3_edges(np.random.default_rng(52), 20, len(geoms))
    zero = np.zeros(poses.shape[:2])
    for order in ("path", "bisection"):
        want = m.check_motions(body, poses, starts, order=order, self_collision=True)
        assert (want != -1).any() and (want == -1).any()
        got = m.check_motions(body, poses, starts, order=order, self_collision=True,
                              motion_bounds=zero)
        assert list(got) == list(want)


def free_edges(m, body, geoms, edges=40, states=20):
    """`edges` edges of `states` copies of one free state (nothing moves: every bound 0)."""
    rng = np.random.default_rng(61)
    while True:
        base = rng.uniform(0, SIDE, 3)
        state = np.array([scenes.pose(scenes.random_rotation(rng), base + rng.normal(0, 0.5, 3))
                          for _ in geoms])
        if not m.check_states(body, state[None], self_collision=True)["colliding"][0]:
            break
    return np.repeat(state[None], edges * states, axis=0), np.arange(0, edges * states, states)


def colliding_state(m, body, geoms):
    rng = np.random.default_rng(62)
    while True:
        base = rng.uniform(0, SIDE, 3)
        state = np.array([scenes.pose(scenes.random_rotation(rng), base + rng.normal(0, 0.5, 3))
                          for _ in geoms])
        if m.check_states(body, state[None])["colliding"][0]:
            return state


def test_a_bad_pose_is_named_where_the_continuous_check_reads_it():
    """A pose not rigid or not finite raises naming it (its index in the whole array, past the
    first chunk of converted states) where its state, or with continuous=True a neighbour's
    check, reads it; after an edge's first failing state it is not read."""
    m = build(world(61))
    body, geoms, _ = robot()
    poses, starts = free_edges(m, body, geoms)
    zero = np.zeros(poses.shape[:2])
    bad = poses.copy()
    bad[700, 2, :3, :3] *= 1.01  # scaled: not rigid
    for threads in (1, 2):
        for kw in ({"continuous": True}, {"motion_bounds": zero}):
            with pytest.raises(ValueError, match=r"poses\[700, 2\].*rigid"):
                m.check_motions(body, bad, starts, threads=threads, **kw)
    hit = colliding_state(m, body, geoms)
    for threads in (1, 2):
        # Given bounds: a colliding state, then the bad one: the bad pose's state is not read.
        edge = np.stack([hit, bad[700]])
        assert list(m.check_motions(body, edge, [0], motion_bounds=np.zeros((2, len(geoms))),
                                    threads=threads)) == [0]
        # SE(3) bounds: state 0's check reads its neighbour's pose.
        with pytest.raises(ValueError, match=r"poses\[1, 2\].*rigid"):
            m.check_motions(body, edge, [0], continuous=True, threads=threads)
        nan = bad[700].copy()
        nan[2, 0, 3] = np.nan
        with pytest.raises(ValueError, match=r"poses\[1, 2\]"):
            m.check_motions(body, np.stack([poses[0], nan]), [0], continuous=True,
                            threads=threads)


@pytest.mark.parametrize("bounds, error, message", [
    (lambda z: z[:, :-1], ValueError, "shape"),
    (lambda z: z[:-1], ValueError, "shape"),
    (lambda z: z.ravel(), ValueError, "shape"),
    (lambda z: np.where(np.arange(z.size).reshape(z.shape) == 7, np.nan, z), ValueError,
     r"motion_bounds\[1, 2\]"),
    (lambda z: np.where(np.arange(z.size).reshape(z.shape) == 11, -0.5, z), ValueError,
     r"motion_bounds\[2, 1\]"),
    (lambda z: np.where(np.arange(z.size).reshape(z.shape) == 3, np.inf, z), ValueError,
     r"motion_bounds\[0, 3\]"),
    (lambda z: z.astype(str), TypeError, "real"),
])
def test_bad_motion_bounds_raise_and_leave_the_manager_usable(bounds, error, message):
    m = build(world(71))
    body, geoms, _ = robot()
    poses, starts, _ = se3_edges(np.random.default_rng(72), 8, len(geoms))
    good = np.full(poses.shape[:2], 0.05)
    want = m.check_motions(body, poses, starts, motion_bounds=good)
    with pytest.raises(error, match=message):
        m.check_motions(body, poses, starts, motion_bounds=bounds(good))
    assert len(body) == len(geoms)
    assert list(m.check_motions(body, poses, starts, motion_bounds=good)) == list(want)


def test_a_bad_motion_bound_raises_before_any_state_is_checked():
    # Wherever it lies: in no edge at all, or past every edge's first colliding state.
    m = build(world(73))
    body, geoms, _ = robot()
    poses, starts, _ = se3_edges(np.random.default_rng(74), 8, len(geoms))
    bad = np.full(poses.shape[:2], 1e9)  # every state collides once raised that far
    bad[-1, -1] = -1.0
    last = f"motion_bounds\\[{len(poses) - 1}, {len(geoms) - 1}\\]"
    for edges in (starts, np.zeros(0, dtype=np.int64)):
        with pytest.raises(ValueError, match=last):
            m.check_motions(body, poses, edges, motion_bounds=bad)
    bad[-1, -1] = 1e9
    # With that value fixed, every edge of two states or more collides at its first state.
    sizes = np.diff(np.append(starts, len(poses)))
    got = m.check_motions(body, poses, starts, motion_bounds=bad)
    assert (got[sizes > 1] == 0).all() and (sizes > 1).sum() >= 4


@pytest.mark.parametrize("call, error", [
    (lambda m, b, p, s: m.check_motions(b, p, s, continuous="yes"), TypeError),
    (lambda m, b, p, s: m.check_motions(b, p[:, :2], s, continuous=True), ValueError),
    (lambda m, b, p, s: m.check_motions(b, p, s[::-1], continuous=True), ValueError),
    (lambda m, b, p, s: m.check_motions(b, p * 2, s, continuous=True), ValueError),
    (lambda m, b, p, s: cc.CollisionManager(backend="fcl").check_motions(
        b, p, s, continuous=True), ValueError),
])
def test_bad_continuous_calls_raise_and_leave_the_manager_usable(call, error):
    m = build(world(81))
    body, geoms, _ = robot()
    poses, starts, _ = se3_edges(np.random.default_rng(82), 8, len(geoms))
    want = m.check_motions(body, poses, starts, continuous=True)
    with pytest.raises(error):
        call(m, body, poses, starts)
    assert len(body) == len(geoms)
    assert list(m.check_motions(body, poses, starts, continuous=True)) == list(want)
