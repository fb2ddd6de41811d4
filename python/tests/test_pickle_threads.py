"""Pickling rebuilds the same world; concurrent Python threads get the serial answers."""

import os
import pickle
import subprocess
import sys
import threading

import numpy as np

import cube_collision as cc
import scenes
from conftest import build, mixed_scene


def test_manager_pickles_with_its_rules(backend):
    m = build(mixed_scene(50, 17), backend)
    m.set_filter("o3", 2, 1)
    m.exclude_pair("o4", "o5")
    m.set_margin(0.05)
    m.set_margin(0.2, "o6")
    c = pickle.loads(pickle.dumps(m))
    assert c.backend == backend and c.names == m.names
    assert c.get_filter("o3") == (2, 1) and c.excluded_pairs == [("o4", "o5")]
    assert c.get_margin() == 0.05 and c.get_margin("o6") == 0.2 and c.get_margin("o7") == 0.05
    for n in m.names:
        np.testing.assert_array_equal(c.get_transform(n), m.get_transform(n))
    assert c.in_collision_internal(return_names=True) == m.in_collision_internal(return_names=True)
    assert c.min_distance_internal() == m.min_distance_internal()


def test_body_pickles():
    body = cc.Body()
    body.add_link(cc.capsule(0.1, 1), margin=0.01, category=2, mask=5)
    body.add_link(cc.mesh(*scenes.tube(8, 0.2, 1)))
    body.exclude_pair(0, 1)
    b = pickle.loads(pickle.dumps(body))
    assert len(b) == 2 and b.excluded_pairs == [(0, 1)]


def test_manager_pickle_keeps_own_margins_apart_from_the_managers(backend):
    """An object's own margin stays its own after a round trip (an own margin equal to the
    manager's included), and the others follow the manager's margin when it changes."""
    m = build(mixed_scene(40, 23), backend)
    m.set_margin(0.05)
    m.set_margin(0.3, "o6")
    m.set_margin(0.05, "o8")
    c = pickle.loads(pickle.dumps(m))
    for manager in (m, c):
        manager.set_margin(0.15)
    for n in m.names:
        assert c.get_margin(n) == m.get_margin(n)
    assert c.get_margin("o6") == 0.3 and c.get_margin("o8") == 0.05 and c.get_margin("o7") == 0.15
    assert c.in_collision_internal(return_names=True) == m.in_collision_internal(return_names=True)


def test_manager_pickle_keeps_filter_bits_that_decide_pairs(backend):
    m = build(mixed_scene(60, 29), backend)
    pairs = m.in_collision_internal(return_names=True)[1]
    a, b = sorted(pairs)[0]
    m.set_filter(a, 2, 1)
    m.set_filter(b, 1, 1)  # a's category 2 is not in b's mask: the pair is never tested
    c = pickle.loads(pickle.dumps(m))
    assert c.get_filter(a) == (2, 1) and c.get_filter(b) == (1, 1)
    got = c.in_collision_internal(return_names=True)[1]
    assert (a, b) not in got and got == m.in_collision_internal(return_names=True)[1]


def test_body_pickle_keeps_link_margins_bits_and_excluded_pairs():
    """The copy answers every state as the original, on states where the links' margins, filter
    bits and excluded pairs each decide an answer."""
    world = cc.CollisionManager()
    world.add_object("b", cc.sphere(0.5), category=4, mask=4)  # meets category-4 links only
    world.add_object("c", cc.sphere(0.5), scenes.pose(np.eye(3), [10.0, 0, 0]))

    def make(margin, category, exclude):
        body = cc.Body()
        for _ in range(3):
            body.add_link(cc.sphere(0.3), margin=margin, category=category)
        if exclude:
            body.exclude_pair(0, 1)
        return body

    def at(*xs):
        return np.stack([scenes.pose(np.eye(3), [x, 50.0 * k, 0]) for k, x in enumerate(xs)])

    far = (100.0, 200.0, 300.0)
    states = np.stack([
        at(10.9, far[1], far[2]),   # link 0 0.1 from c: touching within the margin only
        at(0.0, far[1], far[2]),    # link 0 inside b: only with category 4
        np.stack([scenes.pose(np.eye(3), [-20.0, 0, 0]), scenes.pose(np.eye(3), [-20.2, 0, 0]),
                  scenes.pose(np.eye(3), [far[2], 0, 0])]),  # links 0 and 1 overlap
    ])
    body = make(0.2, 4, True)
    copy = pickle.loads(pickle.dumps(body))
    assert copy.excluded_pairs == body.excluded_pairs == [(0, 1)]

    def answers(b):
        return world.check_states(b, states, self_collision=True)["colliding"].tolist()

    expected = answers(body)
    assert answers(copy) == expected
    # Each kind of state decides an answer here: a body without it answers otherwise.
    for other in (make(0.0, 4, True), make(0.2, 1, True), make(0.2, 4, False)):
        assert answers(other) != expected


def test_concurrent_queries_equal_serial_answers():
    scene = mixed_scene(150, 19)
    m = build(scene)
    expected = m.in_collision_internal(return_names=True)
    expected_d = m.min_distance_internal(return_names=True)
    rng = np.random.default_rng(3)
    probes = [scenes.pose(scenes.random_rotation(rng), rng.uniform(0, 8, 3)) for _ in range(20)]
    expected_s = [m.in_collision_single(cc.sphere(0.7), t, return_names=True) for t in probes]
    errors = []

    def worker():
        try:
            for _ in range(5):
                assert m.in_collision_internal(return_names=True) == expected
                assert m.min_distance_internal(return_names=True) == expected_d
                for t, e in zip(probes, expected_s):
                    assert m.in_collision_single(cc.sphere(0.7), t, return_names=True) == e
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_mutations_while_other_threads_query():
    scene = mixed_scene(100, 23)
    m = build(scene)
    stop = threading.Event()
    errors = []

    def reader():
        try:
            while not stop.is_set():
                hit, names = m.in_collision_internal(return_names=True)
                assert all(a in scene_names and b in scene_names for a, b in names)
                m.min_distance_internal()
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    scene_names = {n for n, _, _ in scene} | {"extra"}
    readers = [threading.Thread(target=reader) for _ in range(3)]
    for t in readers:
        t.start()
    rng = np.random.default_rng(0)
    for i in range(30):
        names = [scene[j][0] for j in rng.choice(100, 10, replace=False)]
        m.set_transforms(names, np.stack([scenes.pose(scenes.random_rotation(rng),
                                                      rng.uniform(0, 8, 3)) for _ in names]))
        if i % 2 == 0:
            m.add_object("extra", cc.sphere(0.5))
        else:
            m.remove_object("extra")
    stop.set()
    for t in readers:
        t.join()
    assert not errors
    now = [(n, m.get_geometry(n), m.get_transform(n)) for n in m.names]
    from conftest import brute_colliding
    assert m.in_collision_internal(return_names=True)[1] == brute_colliding(now)


# A finaliser that mutates the manager, run by collections set off inside the call under test:
# a gc callback leaves a fresh reference cycle with a __del__ at the start of every collection,
# and a threshold of 1 collects on (nearly) every allocation, those the call makes included.
FINALISER_SCRIPT = """
import gc, pickle, sys
import numpy as np
import cube_collision as cc

m = cc.CollisionManager(backend=sys.argv[1])
for i in range(20):
    t = np.eye(4)
    t[0, 3] = 2.0 * i
    m.add_object(f"o{i}", cc.sphere(0.5), t)
refused, done = [], []

class Finaliser:
    def __init__(self):
        self.cycle = self

    def __del__(self):
        try:
            m.set_transform("o0", np.eye(4))
            done.append(1)
        except RuntimeError as e:
            refused.append(str(e))

def leave_garbage(phase, info):
    if phase == "start":
        Finaliser()

gc.collect()
gc.callbacks.append(leave_garbage)
gc.set_threshold(1)
copy = pickle.loads(pickle.dumps(m))
gc.set_threshold(700)
gc.callbacks.remove(leave_garbage)
gc.collect()
assert copy.names == m.names, (copy.names, m.names)
print(len(refused), len(done))
print(refused[0] if refused else "")
"""


def test_pickling_refuses_a_mutating_finaliser_instead_of_deadlocking(backend):
    """pickle.dumps holds the manager's read lock while it builds the state: a __del__ that
    mutates the manager then gets RuntimeError, as during a query's result, and the call
    returns. Run in a child process with a timeout: the deadlock would hang forever."""
    try:
        out = subprocess.run([sys.executable, "-c", FINALISER_SCRIPT, backend],
                             capture_output=True, text=True, timeout=30, env=os.environ.copy())
    except subprocess.TimeoutExpired:
        raise AssertionError("pickle.dumps deadlocked on a finaliser that mutates the manager") \
            from None
    assert out.returncode == 0, out.stderr
    counts, message = out.stdout.split("\n", 1)
    refused, done = map(int, counts.split())
    # Collections inside the state's construction were refused, those outside it were not.
    assert refused >= 1 and done >= 1
    assert "cannot change" in message
