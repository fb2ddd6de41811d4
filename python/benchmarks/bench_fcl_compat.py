#!/usr/bin/env python3
"""Same-run comparison: trimesh's CollisionManager, unchanged, on cube_collision.fcl against the
same manager on python-fcl's way; and the batched single-object query over many poses.

1. trimesh_collision.py (trimesh's CollisionManager re-written call for call over a given
   python-fcl module) over cube_collision.fcl (the package's python-fcl-compatible module:
   default callbacks run in C++ on the cube manager) and over pyfcl_way.py (python-fcl's way:
   FCL's DynamicAABBTreeCollisionManager calling the Python default callback per candidate
   pair, fcl.collide compiled). Timed: in_collision_internal(return_names=True), the request
   trimesh makes (every contact, enable_contact) whatever the caller reads. Scenes
   (scenes.py) as trimesh holds them: "primitives+convex" made convex meshes (trimesh's
   primitives are meshes, given to FCL as fcl.Convex), "clash" meshes (fcl.BVHModel). The names
   are checked equal on both before any time is printed. trimesh's budget of 100,000 contacts
   stops a query early where the contacts exceed it, at a point that depends on the pair order:
   there both are timed with the budget raised to 10**9 (complete answers, compared), as
   bench_trimesh.py does. The parts of cube_collision.fcl's time are printed too: the manager's
   collide alone, the same with enable_contact=False (what the contacts cost), and the package's
   own in_collision_internal(return_names=True) on the same geometries (one contact per pair).
2. CollisionManager.in_collision_single(geometry, transforms) with an (n, 4, 4) array against n
   calls of the single-pose form (answers compared), on both scenes.

  PYTHONPATH=build/python python3 python/benchmarks/bench_fcl_compat.py [--primitives 10000]
      [--meshes 5000] [--poses 10000] [--repeat 3]
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cube_collision as cc  # noqa: E402
import cube_collision.fcl as cfcl  # noqa: E402
import pyfcl_way  # noqa: E402
import scenes  # noqa: E402
from bench_trimesh import load_average  # noqa: E402
from trimesh_collision import CollisionManager, Mesh  # noqa: E402


def timed(fn, repeat):
    """Median of `repeat` timed calls after one untimed call."""
    times, result = [], fn()
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def standins(scene, max_contacts):
    out = []
    for fcl in (cfcl, pyfcl_way):
        m = CollisionManager(fcl, max_contacts=max_contacts)
        for name, g, tf in scene:
            m.add_object(name, Mesh(*scenes.as_mesh(g)), tf)
        out.append(m)
    return out


def run_trimesh(label, scene, repeat, out):
    mine, way = standins(scene, 100000)
    names = mine.in_collision_internal(return_names=True)[1]
    budget = "trimesh's 100,000 contacts"
    if names != way.in_collision_internal(return_names=True)[1]:
        budget = "raised to 10**9 (trimesh's 100,000 stop early, at points that differ)"
        mine._max_contacts = way._max_contacts = 10**9
    t_mine, r_mine = timed(lambda: mine.in_collision_internal(return_names=True), repeat)
    t_way, r_way = timed(lambda: way.in_collision_internal(return_names=True), repeat)
    if r_mine[1] != r_way[1]:
        raise SystemExit(f"{label}: the two modules disagree on the colliding pairs")
    ref = scenes.build([(n, mine._objs[n]["geom"]._g, tf) for n, _, tf in scene], "cube", 1)
    t_ref, (_, ref_names) = timed(lambda: ref.in_collision_internal(return_names=True), repeat)
    if ref_names != r_mine[1]:
        raise SystemExit(f"{label}: the package's manager disagrees on the colliding pairs")

    def collide(enable_contact):
        cdata = cfcl.CollisionData(cfcl.CollisionRequest(num_max_contacts=mine._max_contacts,
                                                         enable_contact=enable_contact))
        mine._manager.collide(cdata, cfcl.defaultCollisionCallback)
        return cdata

    t_col, cdata = timed(lambda: collide(True), repeat)
    t_nocontact, _ = timed(lambda: collide(False), repeat)
    out.append(f"trimesh {label}: {len(scene)} objects, {len(r_mine[1])} colliding pairs, "
               f"{len(cdata.result.contacts)} contacts, budget {budget}")
    out.append(f"  in_collision_internal(return_names=True): cube_collision.fcl "
               f"{t_mine * 1e3:.2f} ms, python-fcl's way {t_way * 1e3:.2f} ms, "
               f"ratio {t_way / t_mine:.2f}x")
    out.append(f"  parts: manager.collide {t_col * 1e3:.2f} ms, with enable_contact=False "
               f"{t_nocontact * 1e3:.2f} ms, the package's names query "
               f"{t_ref * 1e3:.2f} ms")
    pyfcl_way.forget()
    return t_way / t_mine


def run_poses(label, scene, query, n, repeat, out):
    m = scenes.build(scene)
    rng = np.random.default_rng(7)
    lo = np.min([tf[:3, 3] for _, _, tf in scene], axis=0)
    hi = np.max([tf[:3, 3] for _, _, tf in scene], axis=0)
    poses = np.array([scenes.pose(scenes.random_rotation(rng), rng.uniform(lo, hi))
                      for _ in range(n)])
    t_one, hits = timed(lambda: m.in_collision_single(query, poses), repeat)
    t_many, each = timed(lambda: [m.in_collision_single(query, p) for p in poses], repeat)
    if hits.tolist() != each:
        raise SystemExit(f"{label}: the batched query disagrees with the single-pose calls")
    out.append(f"poses {label}: in_collision_single({query.kind}, {n} poses), {int(hits.sum())} "
               f"colliding: one call {t_one * 1e3:.2f} ms, {n} calls {t_many * 1e3:.2f} ms, "
               f"ratio {t_many / t_one:.2f}x")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--primitives", type=int, default=10000)
    ap.add_argument("--meshes", type=int, default=5000)
    ap.add_argument("--poses", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    out = [f"cube_collision {cc.__version__}, medians of {args.repeat} (fcl compat)",
           f"load average at start: {load_average()}"]
    t0 = time.perf_counter()
    prim = scenes.primitives_and_convex(args.primitives)
    clash = scenes.clash(args.meshes)
    ratios = [run_trimesh("primitives+convex", prim, args.repeat, out),
              run_trimesh("clash", clash, args.repeat, out)]
    run_poses("primitives+convex", prim, cc.box(0.8, 0.5, 0.3), args.poses, args.repeat, out)
    run_poses("clash", clash, cc.mesh(*scenes.uv_sphere(6, 0.5)), args.poses, args.repeat, out)
    out.append(f"targets: primitives+convex {ratios[0]:.2f}x (>= 20x wanted), clash "
               f"{ratios[1]:.2f}x (>= 5x wanted)")
    out.append(f"load average at end: {load_average()}")
    out.append(f"total {time.perf_counter() - t0:.1f} s")
    print("\n".join(out))


if __name__ == "__main__":
    main()
