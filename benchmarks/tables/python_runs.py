"""The Python benchmarks' outputs: bench_trimesh.py and bench_fcl_compat.py."""

import gzip
import json
import os
import re
import statistics
import sys
from collections import defaultdict

from .cube_bench import *  # noqa: F401,F403


def trimesh_text(path):
    """The ratios of python/benchmarks/bench_trimesh.py's output (one or more runs in one file):
    per scene and query, cube's time (default threads) and the other manager's time / cube's; and
    cube's default threads against one thread, called in turn, with each run's load."""
    runs, scene, query = [], None, None
    for line in open(path):
        if line.startswith("cube_collision "):  # the header of each run
            m = re.search(r"(\d+) busy processes beside", line)
            runs.append({"busy": int(m.group(1)) if m else 0, "times": {}, "threads": {}})
            continue
        if not runs:
            continue
        m = re.match(r"^load average at start: (\S+) \S+ \S+, (\d+) threads runnable", line)
        if m:  # the 1-minute average, and the other threads runnable (the reader excluded)
            runs[-1]["load"] = f"{m.group(1)} ({int(m.group(2)) - 1} other threads runnable)"
            continue
        m = re.match(r"^(\S[^:]*): (\d+) objects", line)
        if m:
            scene = f"{m.group(1)}, {int(m.group(2)):,}"
            continue
        m = re.match(r"^  (in_collision_internal|min_distance_internal)", line)
        if m:
            query = m.group(1)
            continue
        m = re.match(r"^    (.+?)\s+([\d.]+) ms\s+([\d.]+)x\s+([\d.]+)x", line)
        if m and scene and query:
            runs[-1]["times"][(scene, query, m.group(1))] = float(m.group(2))
            continue
        m = re.match(r"^  cube threads=\d+ against threads=1, minimums of (\d+) calls.*: "
                     r"in_collision_internal ([\d.]+) / ([\d.]+) ms = [\d.]+x, "
                     r"min_distance_internal ([\d.]+) / ([\d.]+) ms", line)
        if m and scene:
            runs[-1]["threads"][scene] = tuple(float(x) for x in m.groups()[1:])
            runs[-1]["calls"] = int(m.group(1))
    if not runs:
        return ""
    timed = [r for r in runs if r["busy"] == 0]
    scenes = list(dict.fromkeys(k[0] for r in runs for k in r["times"]))
    other = "fcl backend, narrow phase in C++"
    rows = [("in_collision_internal", "fcl backend + Python per pair (trimesh)",
             "`in_collision_internal(return_names=True)` vs trimesh's way", "cube, threads=0"),
            ("in_collision_internal", other,
             "the same vs the FCL backend (FCL's tree, the same rules and pipeline, in C++)",
             "cube, threads=0"),
            ("in_collision_internal", other,
             "the same, cube on one thread, vs the FCL backend", "cube, threads=1"),
            ("min_distance_internal", "fcl backend + Python per pair (trimesh)",
             "`min_distance_internal` vs trimesh's way", "cube"),
            ("min_distance_internal", other, "`min_distance_internal` vs the FCL backend",
             "cube")]
    loads = ", ".join(r.get("load", "?") for r in timed)
    out = ["### Python package: trimesh's calls (`python/benchmarks/bench_trimesh.py`)", "",
           f"From `{os.path.relpath(path, os.path.join(HERE, '..'))}`, the {len(timed)} runs "
           "with nothing of ours beside them (load average at the start of each: "
           f"{loads}); ratio = the other's time / cube's (cube with the default threads), "
           "one figure per run.", "",
           "| ratio | " + " | ".join(scenes) + " |", "|---|" + "---|" * len(scenes)]
    for query, oth, label, cube_key in rows:
        cells = []
        for sc in scenes:
            rs = [r["times"][(sc, query, oth)] / r["times"][(sc, query, cube_key)]
                  for r in timed if (sc, query, oth) in r["times"]
                  and (sc, query, cube_key) in r["times"]]
            cells.append(", ".join(f"{x:.1f}x" for x in rs) or "–")
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    with_threads = [r for r in runs if r["threads"]]
    if with_threads:
        calls = with_threads[0].get("calls", "?")
        out += ["", "Cube's default threads against one thread, the two managers called in turn "
                f"({calls} calls each, minimums): one thread's time / the default's, per run; "
                "loaded runs had busy processes beside them (`--load`).", "",
                "| run | busy processes | load average at start | " +
                " | ".join(f"{sc}: {q}" for sc in scenes
                           for q in ("`in_collision_internal`", "`min_distance_internal`")) + " |",
                "|---:|---:|---|" + "---:|" * (2 * len(scenes))]
        for i, r in enumerate(with_threads):
            cells = []
            for sc in scenes:
                t = r["threads"].get(sc)
                cells += (["–", "–"] if t is None else
                          [f"{t[0]:.2f} / {t[1]:.2f} ms = {t[1] / t[0]:.2f}x",
                           f"{t[2]:.2f} / {t[3]:.2f} ms = {t[3] / t[2]:.2f}x"])
            out.append(f"| {i + 1} | {r['busy']} | {r.get('load', '?')} | " + " | ".join(cells)
                       + " |")
    return "\n".join(out) + "\n"


def fcl_compat_text(path):
    """python/benchmarks/bench_fcl_compat.py's output (one or more runs in one file): trimesh's
    CollisionManager on cube_collision.fcl against python-fcl's way, the parts of the former's
    time, and the batched single-object query against one call per pose."""
    runs, scene = [], None
    num = r"([\d.]+) ms"
    for line in open(path):
        if line.startswith("cube_collision "):
            runs.append({"trimesh": {}, "parts": {}, "poses": {}, "load": "?"})
            continue
        if not runs:
            continue
        r = runs[-1]
        m = re.match(r"^load average at start: (\S+) \S+ \S+, (\d+) threads runnable", line)
        if m:
            r["load"] = f"{m.group(1)} ({int(m.group(2)) - 1} other threads runnable)"
            continue
        m = re.match(r"^trimesh (\S[^:]*): (\d+) objects, (\d+) colliding pairs, (\d+) "
                     r"contacts, budget (.*)$", line)
        if m:
            scene = m.group(1)
            r["trimesh"][scene] = {"about": (int(m.group(2)), int(m.group(3)), int(m.group(4)),
                                             m.group(5))}
            continue
        m = re.match(r"^  in_collision_internal\(return_names=True\): cube_collision.fcl " + num +
                     r", python-fcl's way " + num, line)
        if m and scene:
            r["trimesh"][scene]["times"] = (float(m.group(1)), float(m.group(2)))
            continue
        m = re.match(r"^  parts: manager.collide " + num + r", with enable_contact=False " + num +
                     r", the package's names query " + num, line)
        if m and scene:
            r["parts"][scene] = tuple(float(x) for x in m.groups())
            continue
        m = re.match(r"^poses (\S[^:]*): in_collision_single\((\w+), (\d+) poses\), (\d+) "
                     r"colliding: one call " + num + r", \d+ calls " + num, line)
        if m:
            r["poses"][m.group(1)] = (m.group(2), int(m.group(3)), int(m.group(4)),
                                      float(m.group(5)), float(m.group(6)))
    runs = [r for r in runs if r["trimesh"]]
    if not runs:
        return ""
    scenes = list(dict.fromkeys(k for r in runs for k in r["trimesh"]))
    rel = os.path.relpath(path, os.path.join(HERE, ".."))
    out = ["### Python package: trimesh's `CollisionManager` unchanged on `cube_collision.fcl` "
           "(`python/benchmarks/bench_fcl_compat.py`)", "",
           f"From `{rel}`, {len(runs)} runs (load average at the start of each: "
           + ", ".join(r["load"] for r in runs) + "). "
           "`in_collision_internal(return_names=True)` of trimesh's manager "
           "(`python/benchmarks/trimesh_collision.py`) over `cube_collision.fcl` against the "
           "same manager over python-fcl's way (`python/benchmarks/pyfcl_way.py`); ratio = "
           "python-fcl's way's time / `cube_collision.fcl`'s, one figure per run.", "",
           "| scene (as trimesh holds it) | objects | colliding pairs | contacts asked | "
           "contact budget | `cube_collision.fcl` | python-fcl's way | ratio |",
           "|---|---:|---:|---:|---|---|---|---|"]
    for sc in scenes:
        rs = [r["trimesh"][sc] for r in runs if "times" in r["trimesh"].get(sc, {})]
        n, pairs, contacts, budget = rs[0]["about"]
        out.append(f"| {sc} | {n:,} | {pairs:,} | {contacts:,} | {budget} | "
                   + ", ".join(f"{x['times'][0]:.1f}" for x in rs) + " ms | "
                   + ", ".join(f"{x['times'][1]:.1f}" for x in rs) + " ms | "
                   + ", ".join(f"{x['times'][1] / x['times'][0]:.1f}x" for x in rs) + " |")
    out += ["", "Where `cube_collision.fcl`'s time goes, per run: the manager's `collide` with "
            "trimesh's request (the query in C++ and its contacts made Python objects), the same "
            "with `enable_contact=False` (no contact points, normals or depths), and the "
            "package's own `in_collision_internal(return_names=True)` on the same geometries "
            "(one contact per pair); the rest of the first table's time is trimesh's loop over "
            "the contacts in Python.", "",
            "| scene | manager's `collide` | with `enable_contact=False` | the package's names "
            "query |", "|---|---|---|---|"]
    for sc in scenes:
        ps = [r["parts"][sc] for r in runs if sc in r["parts"]]
        out.append(f"| {sc} | " + " | ".join(", ".join(f"{p[k]:.1f}" for p in ps) + " ms"
                                             for k in range(3)) + " |")
    pscenes = list(dict.fromkeys(k for r in runs for k in r["poses"]))
    if pscenes:
        out += ["", "`in_collision_single(geometry, transforms)` with an (n, 4, 4) array (one "
                "call) against n calls of the single-pose form, the same answers; ratio = the "
                "n calls' time / the one call's, per run.", "",
                "| scene | query | poses | colliding | one call | n calls | ratio |",
                "|---|---|---:|---:|---|---|---|"]
        for sc in pscenes:
            ps = [r["poses"][sc] for r in runs if sc in r["poses"]]
            kind, n, hits = ps[0][:3]
            out.append(f"| {sc} | {kind} | {n:,} | {hits:,} | "
                       + ", ".join(f"{p[3]:.1f}" for p in ps) + " ms | "
                       + ", ".join(f"{p[4]:.1f}" for p in ps) + " ms | "
                       + ", ".join(f"{p[4] / p[3]:.1f}x" for p in ps) + " |")
    return "\n".join(out) + "\n"


# bench_check_states.py's calls as the tables name them.
CHECK_STATES_LABELS = {
    "check_states": "`check_states`",
    "check_states (self pairs)": "`check_states(self_collision=True)`",
    "check_motions": "`check_motions`",
    "check_motions_continuous se3": "`check_motions(continuous=True)` (SE(3) bounds)",
    "check_motions_continuous bounds": "`check_motions(motion_bounds=B)`"}


def check_states_text(path):
    """python/benchmarks/bench_check_states.py's output (one or more runs in one file): per call
    and thread count, the Python call's time against the C++ call's on the same world, body and
    poses, one figure per run."""
    runs = []
    num = r"([\d.]+) ms"
    for line in open(path):
        m = re.match(r"^world: (\d+) objects; (\d+) states of (\d+) links; (\d+) edges of (\d+) "
                     r"states; load (\S+) \S+ \S+, (\d+) threads runnable", line)
        if m:
            runs.append({"about": tuple(int(m.group(i)) for i in (1, 2, 3, 4, 5)),
                         "load": f"{m.group(6)} ({int(m.group(7)) - 1} other threads runnable)",
                         "times": {}})
            continue
        if not runs:
            continue
        m = re.match(r"^(check_states|check_motions_continuous \w+|check_motions)\s+threads=(\d+)"
                     r"(?: self=(\d))?.*?: python\s+" + num + r", C\+\+\s+" + num, line)
        if m:
            call = m.group(1)
            if m.group(3) is not None:
                call += " (self pairs)" if m.group(3) == "1" else ""
            runs[-1]["times"][(call, int(m.group(2)))] = (float(m.group(4)), float(m.group(5)))
    runs = [r for r in runs if r["times"]]
    if not runs:
        return ""
    calls = list(dict.fromkeys(c for r in runs for c, _ in r["times"]))
    threads = sorted({t for r in runs for _, t in r["times"]}, key=lambda t: (t == 0, t))
    objects, states, links, edges, edge_states = runs[0]["about"]
    loads = ", ".join(r["load"] for r in runs)
    head = ["one thread" if t == 1 else "default threads" if t == 0 else f"{t} threads"
            for t in threads]
    out = ["### Python package: the batched checks against the C++ calls "
           "(`python/benchmarks/bench_check_states.py`)", "",
           f"From `{os.path.relpath(path, os.path.join(HERE, '..'))}`, {len(runs)} runs (load "
           f"average at the start of each: {loads}): {objects:,} world objects, {states:,} "
           f"states of a {links}-link chain ({edges} edges of {edge_states:,} states for the "
           "motions). Per run, the Python call's time / the C++ call's on the same manager, "
           "body and poses (the C++ poses made just before its clock starts, the Python call's "
           "arrays read just before its own: both start with their input in the cache), each "
           "the best of its repeats, the two called in turn.", "",
           "| call | " + " | ".join(head) + " |", "|---|" + "---|" * len(threads)]
    for call in calls:
        cells = []
        for t in threads:
            rs = [r["times"][(call, t)] for r in runs if (call, t) in r["times"]]
            cells.append(", ".join(f"{p / c:.2f}x" for p, c in rs) or "–")
        out.append(f"| {CHECK_STATES_LABELS.get(call, call)} | " + " | ".join(cells) + " |")
    best = {}
    for call in calls:
        for t in threads:
            rs = [r["times"][(call, t)] for r in runs if (call, t) in r["times"]]
            if rs:
                best[(call, t)] = min(rs, key=lambda x: x[1])
    out += ["", "Times of the run whose C++ call was fastest, Python / C++:", "",
            "| call | " + " | ".join(head) + " |", "|---|" + "---|" * len(threads)]
    for call in calls:
        cells = [f"{best[(call, t)][0]:.2f} / {best[(call, t)][1]:.2f} ms"
                 if (call, t) in best else "–" for t in threads]
        out.append(f"| {CHECK_STATES_LABELS.get(call, call)} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def check_states_instructions_text(path):
    """bench_check_states.py --instructions' output: per call, the instructions of one Python
    call and of the C++ call it wraps, on one thread, as callgrind counts them."""
    rows = []
    about = None
    for line in open(path):
        m = re.match(r"^world: (\d+) objects; (\d+) states of (\d+) links", line)
        if m:
            about = tuple(int(m.group(i)) for i in (1, 2, 3))
            continue
        m = re.match(r"^(check_states|check_motions_continuous \w+|check_motions)\s+threads=1"
                     r"(?: self=(\d))?.*?: python\s+(\d+) instructions, C\+\+\s+(\d+) "
                     r"instructions", line)
        if m:
            call = m.group(1) + (" (self pairs)" if m.group(2) == "1" else "")
            rows.append((call, int(m.group(3)), int(m.group(4))))
    if not rows or about is None:
        return ""
    out = ["Instructions of one call on one thread, the same worlds and calls "
           f"(`{os.path.relpath(path, os.path.join(HERE, '..'))}`, `bench_check_states.py "
           "--instructions`, under callgrind: the Python call whole, binding and conversion of "
           "the poses included, against the library's call alone):", "",
           "| call | Python | C++ | Python / C++ |", "|---|---:|---:|---:|"]
    for call, py, cpp in rows:
        out.append(f"| {CHECK_STATES_LABELS.get(call, call)} | {py / 1e6:.1f}M | {cpp / 1e6:.1f}M | "
                   f"{py / cpp:.3f} |")
    return "\n".join(out) + "\n"
