#!/usr/bin/env python3
"""The Python batched checks against the C++ calls they wrap, same run, same world and body.

CollisionManager.check_states / check_motions on a (states, links, 4, 4) array against
cube::checkStates / checkMotions on the same manager's world and the same Body, called from C++
(cube_collision_bench.check_states_cpp / check_motions_cpp, python/benchmarks/batch_way.cpp)
with the poses converted before the clock starts. The robot is bench_batch.cpp's: a chain of 30
links (boxes, capsules, cylinders, each --link times the world's typical object size), joints about
alternating axes, adjacent links excluded; random configurations across the world sorted into
free and colliding ones, 70% free in the batch (bench_batch.cpp's states_free), and edges of 20
to 100 states from free configurations. Continuous edges (check_motions_continuous): other edges
of 20 to 100 states from free configurations to an end whose joint angles lie within --near of
the start's, checked with continuous=True (se3) and with motion_bounds (bounds: the same SE(3)
bounds computed here), against checkMotions with BatchOptions::continuous and the overload that
takes motion bounds. The world:
boxes, spheres and cylinders at uniform random poses, about one overlap per object. Answers are
compared before any time is printed; each time is the best of --repeat calls, the Python and
the C++ call in turn, each after a pause (PAUSE, below) with the Python call's arrays read just
before its clock (warm); ratio = Python / C++. With --instructions, one call of each side on one
thread is counted under callgrind instead (the script runs itself again under valgrind).

  PYTHONPATH=build/python python3 python/benchmarks/bench_check_states.py [--objects 10000]
      [--states 10000] [--repeat 5] [--threads 1 0] [--near 0.02] [--instructions]
"""

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cube_collision as cc  # noqa: E402
import cube_collision_bench as cb  # noqa: E402
import scenes  # noqa: E402
from bench_trimesh import load_average  # noqa: E402

LINKS = 30
HALF = 2000.0


def world(n, rng):
    """n boxes, spheres and cylinders uniform in a cube of half-side HALF; the typical size."""
    a = (8 * HALF ** 3 / n) ** (1 / 3)
    out = []
    for i in range(n):
        s = a * rng.uniform(0.5, 1.0)
        g = [cc.box(s, s, s), cc.sphere(s / 2), cc.cylinder(s / 2, s)][i % 3]
        out.append((f"o{i}", g, scenes.pose(scenes.random_rotation(rng),
                                            rng.uniform(-HALF, HALF, 3))))
    return out, a


def robot(length):
    body = cc.Body()
    for i in range(LINKS):
        body.add_link([cc.box(0.3 * length, 0.3 * length, length),
                       cc.capsule(0.15 * length, 0.7 * length),
                       cc.cylinder(0.15 * length, length)][i % 3])
    for i in range(LINKS - 1):
        body.exclude_pair(i, i + 1)
    return body


def rotation(axis, q):
    """(n, 4, 4) rotations by angles q about the x (axis 0) or y (axis 1) axis."""
    c, s = np.cos(q), np.sin(q)
    out = np.zeros((len(q), 4, 4))
    out[:, 3, 3] = 1
    if axis == 0:
        out[:, 0, 0] = 1
        out[:, 1, 1], out[:, 1, 2], out[:, 2, 1], out[:, 2, 2] = c, -s, s, c
    else:
        out[:, 1, 1] = 1
        out[:, 0, 0], out[:, 0, 2], out[:, 2, 0], out[:, 2, 2] = c, s, -s, c
    return out


def chain(base, q, length):
    """Forward kinematics: bases (n, 3) and angles (n, LINKS) -> poses (n, LINKS, 4, 4)."""
    n = len(base)
    t = np.tile(np.eye(4), (n, 1, 1))
    t[:, :3, 3] = base
    half, full = np.eye(4), np.eye(4)
    half[2, 3], full[2, 3] = length / 2, length
    out = np.empty((n, LINKS, 4, 4))
    for i in range(LINKS):
        t = t @ rotation(1 if i % 2 == 0 else 0, q[:, i])
        out[:, i] = t @ half
        t = t @ full
    return out


def configurations(rng, n):
    return rng.uniform(-0.9 * HALF, 0.9 * HALF, (n, 3)), rng.uniform(-0.6, 0.6, (n, LINKS))


def pools(m, body, rng, length, want):
    """Random configurations sorted by check_states into free and colliding ones (bases, angles)
    each, until `want` free ones or 40 rounds."""
    free, hit = [], []
    for _ in range(40):
        b, q = configurations(rng, 1000)
        c = m.check_states(body, chain(b, q, length))["colliding"]
        free.append((b[~c], q[~c]))
        hit.append((b[c], q[c]))
        if sum(len(f[0]) for f in free) >= want:
            break
    return [tuple(np.concatenate(x) for x in zip(*p)) for p in (free, hit)]


def mix(free, hit, states, free_share):
    """`states` configurations, free_share of them free, interleaved (pools reused cyclically,
    as bench_batch.cpp does)."""
    nf = int(free_share * states)
    k = np.arange(states)
    is_free = (k * nf) // states != ((k + 1) * nf) // states
    fi = np.cumsum(is_free) - 1
    hi = np.cumsum(~is_free) - 1
    b = np.where(is_free[:, None], free[0][fi % len(free[0])], hit[0][hi % len(hit[0])])
    q = np.where(is_free[:, None], free[1][fi % len(free[1])], hit[1][hi % len(hit[1])])
    return b, q


def edges(rng, free, count, length, near=None):
    """`count` straight edges of 20 to 100 states in configuration space from free
    configurations; (poses, starts). near: the end's joint angles within `near` of the start's
    and its base within a link length (short edges, for the continuous checks), instead of
    anywhere."""
    bases, qs, starts = [], [], []
    total = 0
    for e in range(count):
        b0, q0 = free[0][e % len(free[0])][None], free[1][e % len(free[1])][None]
        if near is None:
            b1 = b0 + rng.uniform(-0.05 * HALF, 0.05 * HALF, (1, 3))
            q1 = rng.uniform(-0.6, 0.6, (1, LINKS))
        else:
            b1 = b0 + rng.uniform(-length, length, (1, 3))
            q1 = q0 + rng.uniform(-near, near, (1, LINKS))
        k = 20 + (e * 4) % 81
        t = np.linspace(0, 1, k)[:, None]
        bases.append(b0 + t * (b1 - b0))
        qs.append(q0 + t * (q1 - q0))
        starts.append(total)
        total += k
    return chain(np.concatenate(bases), np.concatenate(qs), length), np.array(starts)


def se3_bounds(length, poses, starts):
    """(states, LINKS) motion bounds for links moving in SE(3) between consecutive states of an
    edge, as BatchOptions::continuous computes them: |t1 - t0| + angle * the farthest corner of
    the link's local box (every link of robot() has half extents 0.15, 0.15, 0.5 link lengths);
    0 after an edge's last state."""
    reach = length * math.sqrt(2 * 0.15 ** 2 + 0.5 ** 2)
    a, b = poses[:-1], poses[1:]
    m = np.swapaxes(a[..., :3, :3], -1, -2) @ b[..., :3, :3]
    skew = np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                     m[..., 1, 0] - m[..., 0, 1]], -1)
    angle = np.arctan2(0.5 * np.linalg.norm(skew, axis=-1),
                       0.5 * (np.trace(m, axis1=-2, axis2=-1) - 1))
    out = np.zeros(poses.shape[:2])
    out[:-1] = np.linalg.norm(b[..., :3, 3] - a[..., :3, 3], axis=-1) + angle * reach
    out[np.asarray(starts[1:]) - 1] = 0
    return out


# The pause before each call. The C++ calls run in the benchmark module, a second copy of the
# library in this process: each copy counts the other's OpenMP workers, still spinning for a few
# milliseconds after its region (libgomp's active wait), as other load on the machine, and so
# would run a call that follows the other's on one thread. A user's process holds one copy,
# which discounts its own last region's workers (thread_policy.h); after the pause neither sees
# the other's.
PAUSE = 0.05


def warm(*arrays):
    """Reads every byte of the arrays. The C++ side converts its poses (and copies its bounds)
    just before its clock starts, so they are in the cache when its call reads them; without
    this, the Python call would read its arrays from memory (a pose array of 10,000 states is
    38 MB, the C++ call's own copy evicted them), and the ratio would time the two calls'
    caches rather than their work."""
    for a in arrays:
        np.add.reduce(a, axis=None)


def timed(repeat, py, cpp, inputs):
    """The least time of `repeat` calls of each, the two called in turn (so that a change of
    the machine's load meets both alike), each after PAUSE, the Python call's `inputs` read
    just before its clock starts (warm): (python seconds, C++ seconds)."""
    t_py = t_cpp = math.inf
    for _ in range(repeat):
        time.sleep(PAUSE)
        warm(*inputs)
        t0 = time.perf_counter()
        py()
        t_py = min(t_py, time.perf_counter() - t0)
        time.sleep(PAUSE)
        t_cpp = min(t_cpp, cpp())
    return t_py, t_cpp


class Instructions:
    """The instructions of one call of each side instead of times, under callgrind: the Python
    call inside cb.counted, the C++ call given count_as, each dumped as a profile of its own into
    `folder` (valgrind's --callgrind-out-file), whose total is read back."""

    def __init__(self, folder):
        self.folder = folder
        self.dumps = 0

    def _last(self):
        self.dumps += 1
        path = os.path.join(self.folder, f"cg.out.{self.dumps}")
        with open(path) as f:
            for line in f:
                if line.startswith("totals:"):
                    return int(line.split()[1])
        raise RuntimeError(f"{path}: no total")

    def __call__(self, label, py, cpp):
        cb.counted(label + " python", py)
        a = self._last()
        cpp(count_as=label + " C++")
        return a, self._last()


def instructions_run(argv):
    """Runs this script again under callgrind (instrumentation off until a counted call) with
    --count-into a fresh folder; its exit status."""
    import shutil
    import subprocess
    import tempfile
    if shutil.which("valgrind") is None:
        print("--instructions needs valgrind (Debian: apt-get install valgrind)", file=sys.stderr)
        return 2
    folder = tempfile.mkdtemp(prefix="cube_counts_")
    try:
        rest = [a for a in argv if a != "--instructions"]
        # valgrind's own lines into a file, the script's messages through
        cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no",
               f"--log-file={os.path.join(folder, 'valgrind.log')}",
               f"--callgrind-out-file={os.path.join(folder, 'cg.out')}",
               sys.executable, os.path.abspath(__file__), "--count-into", folder] + rest
        code = subprocess.run(cmd).returncode
        if code != 0:  # valgrind's own reason, which goes with the folder
            log = os.path.join(folder, "valgrind.log")
            if os.path.exists(log):
                with open(log) as f:
                    sys.stderr.write(f.read())
        return code
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if "--instructions" in argv:
        return instructions_run(argv)
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--instructions", action="store_true",
                    help="instead of times, the instructions of one call of each side on one "
                    "thread, under callgrind (valgrind runs this script again)")
    ap.add_argument("--count-into", help=argparse.SUPPRESS)
    ap.add_argument("--objects", type=int, default=10000)
    ap.add_argument("--states", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 0])
    ap.add_argument("--near", type=float, default=0.02,
                    help="continuous edges: joint angles of the end within this of the start's")
    ap.add_argument("--link", type=float, default=1.0,
                    help="link length in the world's typical object sizes")
    args = ap.parse_args(argv)
    counts = None
    if args.count_into:
        if not cb.on_valgrind():
            print("--count-into: not under valgrind", file=sys.stderr)
            return 2
        counts = Instructions(args.count_into)
        args.threads = [1]

    def measure(label, py, cpp, inputs):
        """'python A, C++ B, ratio A / B': times (best of --repeat), or instructions."""
        if counts is not None:
            a, b = counts(label, py, cpp)
            return f"python {a:13d} instructions, C++ {b:13d} instructions, ratio {a / b:.3f}"
        a, b = timed(args.repeat, py, cpp, inputs)
        return f"python {1e3 * a:8.2f} ms, C++ {1e3 * b:8.2f} ms, ratio {a / b:.3f}"
    rng = np.random.default_rng(7)
    scene, typical = world(args.objects, rng)
    m = scenes.build(scene)
    length = args.link * typical
    body = robot(length)
    free, hit = pools(m, body, rng, length, 200)
    if len(free[0]) == 0 or len(hit[0]) == 0:
        print("no free or no colliding configuration found", file=sys.stderr)
        return 1
    poses = chain(*mix(free, hit, args.states, 0.7), length)
    edge_poses, starts = edges(rng, free, max(1, args.states // 60), length)
    near_poses, near_starts = edges(rng, free, max(1, args.states // 60), length, args.near)
    bounds = se3_bounds(length, near_poses, near_starts)
    print(f"world: {args.objects} objects; {args.states} states of {LINKS} links; "
          f"{len(starts)} edges of {len(edge_poses)} states; load {load_average()}")
    failed = False
    for threads in args.threads:
        for self_collision in (False, True):
            py = m.check_states(body, poses, self_collision=self_collision, threads=threads)
            _, cpp = cb.check_states_cpp(m, body, poses, threads, 1, self_collision)
            if not np.array_equal(py["colliding"], cpp):
                print("check_states: answers differ", file=sys.stderr)
                failed = True
                continue
            got = measure(
                f"check_states self={int(self_collision)}",
                lambda: m.check_states(body, poses, self_collision=self_collision,
                                       threads=threads),
                lambda **c: cb.check_states_cpp(m, body, poses, threads, 1, self_collision,
                                                **c)[0],
                (poses,))
            print(f"check_states  threads={threads} self={int(self_collision)} "
                  f"colliding={int(cpp.sum())}/{len(cpp)}: {got}")
        py = m.check_motions(body, edge_poses, starts, threads=threads)
        _, cpp = cb.check_motions_cpp(m, body, edge_poses, list(starts), threads, 1)
        if not np.array_equal(py, cpp):
            print("check_motions: answers differ", file=sys.stderr)
            failed = True
            continue
        got = measure(
            "check_motions", lambda: m.check_motions(body, edge_poses, starts, threads=threads),
            lambda **c: cb.check_motions_cpp(m, body, edge_poses, list(starts), threads, 1,
                                             **c)[0],
            (edge_poses,))
        print(f"check_motions threads={threads} free={int((cpp < 0).sum())}/{len(cpp)}: {got}")
        for label, kw in (("se3", {"continuous": True}),
                          ("bounds", {"motion_bounds": bounds})):
            py = m.check_motions(body, near_poses, near_starts, threads=threads, **kw)
            flat = {"motion_bounds": bounds.ravel().tolist()} if "motion_bounds" in kw else kw
            _, cpp = cb.check_motions_cpp(m, body, near_poses, list(near_starts), threads, 1,
                                          **flat)
            if not np.array_equal(py, cpp):
                print(f"check_motions_continuous ({label}): answers differ", file=sys.stderr)
                failed = True
                continue
            got = measure(
                f"check_motions_continuous {label}",
                lambda: m.check_motions(body, near_poses, near_starts, threads=threads, **kw),
                lambda **c: cb.check_motions_cpp(m, body, near_poses, list(near_starts), threads,
                                                 1, **flat, **c)[0],
                (near_poses, bounds) if "motion_bounds" in kw else (near_poses,))
            print(f"check_motions_continuous {label:6} threads={threads} "
                  f"free={int((cpp < 0).sum())}/{len(cpp)}: {got}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
