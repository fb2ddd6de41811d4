"""Pickling rebuilds the same world; concurrent Python threads get the serial answers."""

import pickle
import threading

import numpy as np

import cube_collision as cc
import scenes
from conftest import build, mixed_scene


def test_manager_pickles_with_its_rules(backend):
    m = build(mixed_scene(50, 17), backend)
    m.set_filter("o3", 2, 1)
    m.ignore_pair("o4", "o5")
    m.set_margin(0.05)
    m.set_margin(0.2, "o6")
    c = pickle.loads(pickle.dumps(m))
    assert c.backend == backend and c.names == m.names
    assert c.get_filter("o3") == (2, 1) and c.ignored_pairs == [("o4", "o5")]
    assert c.get_margin() == 0.05 and c.get_margin("o6") == 0.2 and c.get_margin("o7") == 0.05
    for n in m.names:
        np.testing.assert_array_equal(c.get_transform(n), m.get_transform(n))
    assert c.in_collision_internal(return_names=True) == m.in_collision_internal(return_names=True)
    assert c.min_distance_internal() == m.min_distance_internal()


def test_body_pickles():
    body = cc.Body()
    body.add_link(cc.capsule(0.1, 1), margin=0.01, category=2, mask=5)
    body.add_link(cc.mesh(*scenes.tube(8, 0.2, 1)))
    body.allow_pair(0, 1)
    b = pickle.loads(pickle.dumps(body))
    assert len(b) == 2 and b.allowed_pairs == [(0, 1)]


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
