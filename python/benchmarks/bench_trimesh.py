#!/usr/bin/env python3
"""Same-run comparison: trimesh's collision calls on three managers.

  cube        cube_collision.CollisionManager() (the cube hierarchy and its narrow-phase pipeline)
  fcl         CollisionManager(backend="fcl"): FCL's DynamicAABBTreeCollisionManager as the
              broadphase, the same pair rules and narrow-phase pipeline as cube, in C++ (the
              broadphases compared; labelled "fcl backend, narrow phase in C++")
  fcl+py      FCL's tree driven the way trimesh drives python-fcl: the manager calls a Python
              callback per candidate pair, which calls fcl::collide / fcl::distance on the pair
              (python-fcl's compiled calls, re-created in the benchmark module
              cube_collision_bench, python/benchmarks/fcl_way.cpp) and keeps its contacts as
              Python objects, and the names are collected in Python afterwards. Two requests:
              "names" asks one contact per pair (what the names need); "trimesh" is trimesh's
              own in_collision_internal(return_names=True) request (enable_contact,
              num_max_contacts=100000: every contact of every pair).

Calls timed: in_collision_internal(return_names=True) on each scene, min_distance_internal() on
the same scene with its colliding objects removed (so that the search does not stop at the first
touching pair). Scenes (benchmarks/scenes.py): "primitives+convex" (boxes, spheres, cylinders,
capsules, cones, convex polytopes) and "clash" (meshes of 100-2,000 triangles). Every answer is
checked equal across the managers before any time is printed. Median of --repeat runs each,
after one untimed run.

  PYTHONPATH=build/python python3 python/benchmarks/bench_trimesh.py [--primitives 10000]
      [--meshes 5000] [--repeat 3] [--threads 0] [--load 0]

--load N runs N spinning processes beside the benchmark (a loaded machine; each stops by itself
after --load-seconds, and all are stopped at exit). Each scene also reports cube's time with the
given threads against threads=1, called in turn (the target: at least 0.95x the one-thread
speed, loaded or not).
"""

import argparse
import atexit
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cube_collision as cc  # noqa: E402
import scenes  # noqa: E402
from trimesh_way import TrimeshManager  # noqa: E402


def timed(fn, repeat):
    """Median of `repeat` timed calls after one untimed call (caches warm for every manager)."""
    times, result = [], fn()
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


SPIN = "import time\nend = time.monotonic() + {seconds}\nwhile time.monotonic() < end:\n    for _ in range(100000):\n        pass\n"


def start_load(processes, seconds):
    """`processes` spinning Python processes, each bounded to `seconds`, killed at exit."""
    procs = [subprocess.Popen([sys.executable, "-c", SPIN.format(seconds=seconds)])
             for _ in range(processes)]

    def stop():
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()
    atexit.register(stop)
    return stop


def load_average():
    """/proc/loadavg's 1-, 5- and 15-minute averages and its count of runnable threads (this
    process included), before any busy process of --load starts."""
    try:
        with open("/proc/loadavg") as f:
            fields = f.read().split()
        return f"{fields[0]} {fields[1]} {fields[2]}, {fields[3].split('/')[0]} threads runnable"
    except OSError:
        return "unknown"


def timed_pair(fa, fb, repeat):
    """Minimums of `repeat` timed calls of fa and fb in turn (after one untimed call of each): on a
    busy machine the background changes between calls far apart."""
    ta, tb, ra, rb = [], [], fa(), fb()
    for _ in range(repeat):
        t = time.perf_counter()
        ra = fa()
        ta.append(time.perf_counter() - t)
        t = time.perf_counter()
        rb = fb()
        tb.append(time.perf_counter() - t)
    return min(ta), ra, min(tb), rb


def without_collisions(scene):
    """The scene less one object of each colliding pair (greedily)."""
    m = scenes.build(scene)
    _, pairs = m.in_collision_internal(return_names=True)
    drop = set()
    for a, b in sorted(pairs):
        if a not in drop and b not in drop:
            drop.add(b)
    return [s for s in scene if s[0] not in drop]


def close(a, b):
    return a == b or (a <= 0 and b <= 0) or abs(a - b) <= 1e-6 * max(1.0, abs(a))


def run_scene(label, scene, repeat, threads, out):
    cube = scenes.build(scene, "cube", threads)
    cube1 = scenes.build(scene, "cube", 1)
    fcl = scenes.build(scene, "fcl")
    trimesh = TrimeshManager(fcl)
    t_cube, (_, names) = timed(lambda: cube.in_collision_internal(return_names=True), repeat)
    t_cube1, r1 = timed(lambda: cube1.in_collision_internal(return_names=True), repeat)
    m_cube, _, m_cube1, _ = timed_pair(lambda: cube.in_collision_internal(return_names=True),
                                       lambda: cube1.in_collision_internal(return_names=True),
                                       3 * repeat)
    t_fcl, r_fcl = timed(lambda: fcl.in_collision_internal(return_names=True), repeat)
    t_tm, r_tm = timed(lambda: trimesh.in_collision_internal(return_names=True), repeat)
    for other in (r1, r_fcl):
        if other[1] != names:
            raise SystemExit(f"{label}: the managers disagree on the colliding pairs")
    out.append(f"{label}: {len(scene)} objects, {len(names)} colliding pairs, the same on every "
               "manager")
    if r_tm[1] != names:
        # trimesh's request stops the whole query at 100,000 contacts: its answer is incomplete.
        if not r_tm[1] <= names:
            raise SystemExit(f"{label}: trimesh's way reports pairs that do not collide")
        out.append(f"  trimesh's way with its 100,000-contact budget stopped early: "
                   f"{len(r_tm[1])} of the {len(names)} pairs ({t_tm * 1e3:.2f} ms); timed "
                   "below with the budget raised to 10**9, which finds them all")
        trimesh = TrimeshManager(fcl, max_contacts=10**9)
        t_tm, r_tm = timed(lambda: trimesh.in_collision_internal(return_names=True), repeat)
        if r_tm[1] != names:
            raise SystemExit(f"{label}: the managers disagree on the colliding pairs")
    out.append("  in_collision_internal(return_names=True)                  time   fcl+py/x   fcl/x")
    for what, t in ((f"cube, threads={threads}", t_cube), ("cube, threads=1", t_cube1),
                    ("fcl backend, narrow phase in C++", t_fcl),
                    ("fcl backend + Python per pair (trimesh)", t_tm)):
        out.append(f"    {what:45s} {t * 1e3:10.2f} ms {t_tm / t:8.2f}x {t_fcl / t:7.2f}x")

    free = without_collisions(scene)
    dcube = scenes.build(free, "cube", threads)
    dfcl = scenes.build(free, "fcl")
    dtrimesh = TrimeshManager(dfcl)
    dcube1 = scenes.build(free, "cube", 1)
    t_dc, (d_c, n_c) = timed(lambda: dcube.min_distance_internal(return_names=True), repeat)
    m_dc, _, m_dc1, (d_c1, _) = timed_pair(
        lambda: dcube.min_distance_internal(return_names=True),
        lambda: dcube1.min_distance_internal(return_names=True), 3 * repeat)
    if d_c1 != d_c:
        raise SystemExit(f"{label}: the distance depends on the thread count: {d_c} {d_c1}")
    t_df, (d_f, n_f) = timed(lambda: dfcl.min_distance_internal(return_names=True), repeat)
    t_dp, (d_p, n_p) = timed(lambda: dtrimesh.min_distance_internal(return_names=True), repeat)
    if not (close(d_c, d_f) and close(d_c, d_p)):
        raise SystemExit(f"{label}: the managers disagree on the distance: {d_c} {d_f} {d_p}")
    out.append(f"  min_distance_internal(return_names=True), the {len(free)} objects left without "
               f"collisions: {d_c:.6g} ({n_c[0]}, {n_c[1]}) on every manager")
    for what, t in (("cube", t_dc), ("fcl backend, narrow phase in C++", t_df),
                    ("fcl backend + Python per pair (trimesh)", t_dp)):
        out.append(f"    {what:45s} {t * 1e3:10.2f} ms {t_dp / t:8.2f}x {t_df / t:7.2f}x")
    out.append(f"  cube threads={threads} against threads=1, minimums of {3 * repeat} calls in "
               f"turn (speed, >= 0.95x wanted): in_collision_internal {m_cube * 1e3:.2f} / "
               f"{m_cube1 * 1e3:.2f} ms = {m_cube1 / m_cube:.2f}x, min_distance_internal "
               f"{m_dc * 1e3:.2f} / {m_dc1 * 1e3:.2f} ms = {m_dc1 / m_dc:.2f}x")
    return {"collide": (t_cube, t_fcl, t_tm), "distance": (t_dc, t_df, t_dp)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--primitives", type=int, default=10000)
    ap.add_argument("--meshes", type=int, default=5000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--load", type=int, default=0, help="spinning processes beside the run")
    ap.add_argument("--load-seconds", type=float, default=1800)
    args = ap.parse_args(argv)
    start = load_average()
    stop = start_load(args.load, args.load_seconds) if args.load > 0 else None
    out = [f"cube_collision {cc.__version__}, threads={args.threads} "
           f"(0: the hardware's, {os.cpu_count()} here), medians of {args.repeat}, "
           f"{args.load} busy processes beside",
           f"load average at start: {start}"]
    t0 = time.perf_counter()
    prim = run_scene("primitives+convex", scenes.primitives_and_convex(args.primitives),
                     args.repeat, args.threads, out)
    clash = run_scene("clash", scenes.clash(args.meshes), args.repeat, args.threads, out)
    out.append("targets (cube with the default threads):")
    for label, r, need in (("primitives+convex", prim, 20), ("clash", clash, 5)):
        t_cube, t_fcl, t_tm = r["collide"]
        t_dc, t_df, t_dp = r["distance"]
        out.append(f"  {label}: in_collision_internal(return_names=True) {t_tm / t_cube:.2f}x vs "
                   f"trimesh's way (target >= {need}x), {t_fcl / t_cube:.2f}x vs fcl in C++ "
                   f"(target >= 2x); min_distance_internal {t_dp / t_dc:.2f}x / "
                   f"{t_df / t_dc:.2f}x")
    out.append(f"load average at end: {load_average()}")
    out.append(f"total {time.perf_counter() - t0:.1f} s")
    if stop is not None:
        stop()
    print("\n".join(out))


if __name__ == "__main__":
    main()
