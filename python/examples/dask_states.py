#!/usr/bin/env python3
"""Shard a large batch of robot states across a dask.distributed cluster.

A 7-joint arm (capsule links) among a world of primitives, convex hulls and meshes; a batch of
joint configurations is checked with CollisionManager.check_states, once in this process and
once on a Dask cluster: the world (manager and body, which pickle) is scattered to every worker
once, where it is rebuilt once, and each task computes its shard's link poses (forward
kinematics) and checks them there. The answers must equal the single-process call.

  python3 python/examples/dask_states.py [--states 200000] [--workers 2]
  python3 python/examples/dask_states.py --scheduler tcp://host:8786   # a running cluster
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "benchmarks"))

import cube_collision as cc  # noqa: E402

LINKS = 7
LINK_LENGTH = 0.45


def make_world(objects=3000, seed=3):
    """The static world: primitives and convex hulls (scenes.py) plus some meshes."""
    import scenes

    side = 12.0
    rng = np.random.default_rng(seed)
    world = cc.CollisionManager()
    for i, (name, g, t) in enumerate(scenes.primitives_and_convex(objects, seed=seed)):
        t = t.copy()
        t[:3, 3] = rng.uniform(-side / 2, side / 2, 3)
        if np.linalg.norm(t[:3, 3]) < 1.5:  # keep the arm's base clear
            continue
        if i % 10 == 0:
            g = cc.mesh(*scenes.uv_sphere(6, 0.3))
        world.add_object(name, g, t)
    body = cc.Body()
    for _ in range(LINKS):
        body.add_link(cc.capsule(0.06, LINK_LENGTH - 0.12))
    for i in range(LINKS - 1):
        body.allow_pair(i, i + 1)
    return world, body


BUILDS = 0  # worlds rebuilt from a pickle in this process


class World:
    """The manager and the body, shipped together; unpickling rebuilds both (and counts)."""

    def __init__(self, manager, body):
        self.manager, self.body = manager, body

    def __reduce__(self):
        return _rebuild, (self.manager, self.body)


def _rebuild(manager, body):
    global BUILDS
    BUILDS += 1
    return World(manager, body)


def builds():
    return BUILDS


def rot(axis, angles):
    """(n, 4, 4) rotations about x, y or z."""
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((len(angles), 4, 4))
    out[:, 3, 3] = 1
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    k = 3 - i - j
    out[:, k, k] = 1
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = -s
    out[:, j, i] = s
    return out


def forward_kinematics(q):
    """Link poses (n, LINKS, 4, 4) of joint configurations q (n, LINKS): joints alternate about z
    and y; each capsule is centred on its link."""
    n = len(q)
    frame = np.tile(np.eye(4), (n, 1, 1))
    half = np.eye(4)
    half[2, 3] = LINK_LENGTH / 2
    out = np.empty((n, LINKS, 4, 4))
    for j in range(LINKS):
        frame = frame @ rot(2 if j % 2 == 0 else 1, q[:, j])
        centre = frame @ half
        out[:, j] = centre
        frame = centre @ half
    return out


def shard_states(seed, n):
    """A shard's joint configurations, drawn where they are checked (nothing big is shipped)."""
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, LINKS))


def check_shard(world, seed, n):
    """One task: the shard's states, their link poses (forward kinematics) and their check, on
    the worker, on one thread."""
    poses = forward_kinematics(shard_states(seed, n))
    return world.manager.check_states(world.body, poses, self_collision=True, threads=1)


def merge(parts):
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def run(states=200000, workers=2, scheduler=None, objects=3000, shards_per_worker=2,
        verbose=True):
    """Returns (answers equal, single-process seconds, Dask seconds for the checks, {worker:
    worlds rebuilt there})."""
    from dask.distributed import Client, LocalCluster

    world = World(*make_world(objects))
    # Workers started by LocalCluster import this module (check_shard) from here.
    here = os.path.dirname(os.path.abspath(__file__))
    os.environ["PYTHONPATH"] = os.pathsep.join(
        [here] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])

    def shards(count):
        sizes = [len(c) for c in np.array_split(np.arange(states), count)]
        return [(1000 + i, n) for i, n in enumerate(sizes)]


    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        n_workers = len(client.scheduler_info()["workers"])
        t0 = time.perf_counter()
        shared = client.scatter(world, broadcast=True)  # rebuilt once per worker
        t_scatter = time.perf_counter() - t0
        parts = shards(shards_per_worker * n_workers)
        t0 = time.perf_counter()
        futures = [client.submit(check_shard, shared, seed, n, pure=False) for seed, n in parts]
        dask = merge(client.gather(futures))
        t_dask = time.perf_counter() - t0
        rebuilt = client.run(builds)  # {worker: worlds rebuilt there}
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    # The same shards in this process, one after the other on one thread: the answers to compare.
    t0 = time.perf_counter()
    single = merge([check_shard(world, seed, n) for seed, n in parts])
    t_single = time.perf_counter() - t0
    equal = all(np.array_equal(single[k], dask[k]) for k in single)
    if verbose:
        print(f"{len(world.manager)} world objects, {LINKS} links, {states} states, "
              f"{int(single['colliding'].sum())} colliding; {n_workers} Dask workers")
        print(f"single process, one thread: {t_single:.3f} s")
        print(f"Dask: {t_dask:.3f} s for the checks ({t_single / t_dask:.2f}x), "
              f"{t_scatter:.3f} s to ship and rebuild the world on every worker")
        print(f"worlds rebuilt per worker: {sorted(rebuilt.values())}")
        print("answers equal the single-process call" if equal else "ANSWERS DIFFER")
    return equal, t_single, t_dask, rebuilt


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--states", type=int, default=200000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--objects", type=int, default=3000)
    ap.add_argument("--scheduler", default=None, help="address of a running scheduler")
    args = ap.parse_args()
    # Imported by name, so that the workers import it too (a __main__ would travel by value).
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import dask_states

    equal, _, _, _ = dask_states.run(args.states, args.workers, args.scheduler, args.objects)
    sys.exit(0 if equal else 1)


if __name__ == "__main__":
    main()
