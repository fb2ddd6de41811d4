"""Other libraries and resources: bench_bullet's Bullet broadphases, cube_memory's bytes."""

import gzip
import json
import os
import re
import statistics
import sys
from collections import defaultdict

from .cube_bench import *  # noqa: F401,F403


BULLET_PEERS = ["fcl_dyntree", "bt_dbvt_bp", "bt_dbvt_bp_deferred", "bt_32bit_sap",
                "bt_dbvt_bottomup", "bt_dbvt_topdown"]


def bullet_text(path):
    """bench_bullet's run: per case, scene and size, cube's time and each peer's time / cube's
    (hand-timed wall time, the median of the repetitions); a peer whose pairs differed from the
    brute force's is marked."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        data = json.load(f)
    times, agree, missing, order = defaultdict(list), {}, {}, []
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
            continue
        case, scene, n, peer = b["run_name"].split("/")[:4]
        row = (case, scene, int(n))
        if row not in order:
            order.append(row)
        times[(row, peer)].append(b["real_time"] * TO_US[b["time_unit"]])
        if b.get("agree", 1) == 0:
            agree[(row, peer)] = False
            missing[(row, peer)] = int(b.get("missing", 0))
    med = {k: statistics.median(v) for k, v in times.items()}
    reps = max((len(v) for v in times.values()), default=0)
    # The floor peer (copy the boxes, call the callback per pair) is in runs that measured it.
    has_floor = any(peer == "floor" for _, peer in med)
    # The cube manager with keep_pairs, in runs that measured it: its time, and the best peer's
    # (the plain cube manager's too) over it.
    has_keep = any(peer == "cube_keep" for _, peer in med)
    keep_text = (" keep_pairs: the cube manager with `Config::keep_pairs` (its pairs kept between "
                 "calls, as Bullet's pair caches keep theirs), its time and the best other's "
                 "(the plain cube manager's included) over it." if has_keep else "")
    floor_text = (" floor: copying every object's AABB out of its FCL object and calling the "
                  "callback once per overlapping pair (the pairs known beforehand); cube / floor "
                  "is cube's time over that." if has_floor else "")
    out = ["### Bullet's broadphases and FCL's dynamic tree (`bench_bullet`)", "",
           f"From `{os.path.basename(path)}` ({reps} repetitions, median wall time). Ratio = the "
           "peer's time / cube's: above 1, cube is faster. ✗: that peer missed pairs the brute "
           "force finds (their number in brackets); its time is of the wrong answer." +
           floor_text + keep_text, "",
           "| case | scene | n | cube | " + " | ".join(BULLET_PEERS) + " | best peer / cube |" +
           (" floor | cube / floor |" if has_floor else "") +
           (" keep_pairs | best other / keep_pairs |" if has_keep else ""),
           "|---|---|---:|---:|" + "---:|" * (len(BULLET_PEERS) + (3 if has_floor else 1) +
                                               (2 if has_keep else 0))]
    for row in order:
        cube = med.get((row, "cube"))
        if cube is None:
            continue
        cells, ratios = [], []
        for p in BULLET_PEERS:
            t = med.get((row, p))
            if t is None:
                cells.append("–")
                continue
            r = t / cube
            bad = agree.get((row, p)) is False
            if not bad:
                ratios.append(r)
            cells.append(f"{r:.2f}x" + (f" ✗ ({missing[(row, p)]:,})" if bad else ""))
        best_cell = f"{min(ratios):.2f}x" if ratios else "–"
        floor = med.get((row, "floor"))
        floor_cells = (f" {fmt_time(floor)} | {cube / floor:.2f}x |" if floor else " – | – |")
        keep = med.get((row, "cube_keep"))
        keep_cells = ""
        if has_keep:
            others = [t for (r, p), t in med.items()
                      if r == row and p in BULLET_PEERS + ["cube"] and agree.get((r, p)) is not False]
            keep_cells = (f" {fmt_time(keep)} | {min(others) / keep:.2f}x |" if keep and others
                          else " – | – |")
        out.append(f"| {row[0]} | {row[1]} | {row[2]:,} | {fmt_time(cube)} | " +
                   " | ".join(cells) + f" | {best_cell} |" + (floor_cells if has_floor else "") +
                   keep_cells)
    return "\n".join(out) + "\n"


MEMORY_MANAGERS = ["cube", "DynamicAABBTree", "DynamicAABBTree_Array", "cube_float",
                   "DynamicAABBTree_float"]
MEMORY_SHORT = dict(SHORT, cube_float="cube float", DynamicAABBTree_float="DynTree float")
MEMORY_PARTS = [("slots", "slots (`Item`, exact box)"), ("cubes", "cubes (`Node`)"),
                ("tree other", "parent links"), ("table", "object table"),
                ("pointer map", "of which the pointer map")]


def memory_text(path):
    """cube_memory's run: per size, each manager's heap per object after the build and at the
    build's peak, and where the cube manager's bytes go."""
    with open(path) as f:
        data = json.load(f)
    res = {(r["manager"], r["n"]): r for r in data["results"]}
    sizes = sorted({r["n"] for r in data["results"]})
    agree = all(r["pairs"] == res.get(("DynamicAABBTree" + ("_float" if r["manager"].endswith(
        "_float") else ""), r["n"]), r)["pairs"] for r in data["results"])
    out = ["### Memory of a drop-in manager (`cube_memory`)", "",
           f"From `{os.path.basename(path)}`: {data['scene']} scene, `double` (and in `float` "
           "the columns so named), each "
           "manager built as a user replacing an FCL manager builds it (construction, "
           "`registerObjects`, `setup`). Bytes per object of every heap block the build leaves "
           "allocated (glibc's block sizes, as `mallinfo2` counts them), and of the heap's "
           "highest point during the build over its level before. " +
           ("Every manager's self-collide found the same pairs." if agree else
            "**The managers' self-collides found different pairs.**"), "",
           "| n | " + " | ".join(f"{MEMORY_SHORT[m]} after / peak" for m in MEMORY_MANAGERS) +
           " | DynTree / cube after | DynTree / cube peak |",
           "|---:|" + "---:|" * (len(MEMORY_MANAGERS) + 2)]
    for n in sizes:
        cells = []
        for m in MEMORY_MANAGERS:
            r = res.get((m, n))
            cells.append("–" if r is None else
                         f"{r['bytes_per_object']:.1f} / {r['build_peak_per_object']:.1f}")
        c, d = res.get(("cube", n)), res.get(("DynamicAABBTree", n))
        ra = "–" if not (c and d) else f"{d['bytes_per_object'] / c['bytes_per_object']:.2f}x"
        rp = "–" if not (c and d) else \
            f"{d['build_peak_per_object'] / c['build_peak_per_object']:.2f}x"
        out.append(f"| {n:,} | " + " | ".join(cells) + f" | {ra} | {rp} |")
    out += ["", "Where the cube manager's bytes go (`double`; `bytes()` of its parts, bytes per "
            "object):", "",
            "| n | " + " | ".join(label for _, label in MEMORY_PARTS) + " | `bytes()` |",
            "|---:|" + "---:|" * (len(MEMORY_PARTS) + 1)]
    for n in sizes:
        parts = res.get(("cube", n), {}).get("parts", {})
        out.append(f"| {n:,} | " + " | ".join(
            f"{parts[k]:.2f}" if k in parts else "–" for k, _ in MEMORY_PARTS) +
            f" | {parts.get('bytes()', float('nan')):.2f} |")
    if not any("build_s" in r for r in data["results"]):
        return "\n".join(out) + "\n"
    out += ["", "Time of the same build and of one self-collide (wall clock, the counting "
            "allocator in place; the best of three); "
            "ratio = FCL's dynamic tree's time / the cube manager's, each in its scalar type:", "",
            "| n | cube build | DynTree build | ratio | cube self-collide | DynTree self-collide | "
            "ratio | cube float build / self | DynTree float build / self | float ratios |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]

    def secs(x):
        return f"{x * 1e3:.1f} ms" if x < 1 else f"{x:.2f} s"

    for n in sizes:
        c, d = res.get(("cube", n)), res.get(("DynamicAABBTree", n))
        cf, df = res.get(("cube_float", n)), res.get(("DynamicAABBTree_float", n))
        if not (c and d and "build_s" in c and "build_s" in d):
            continue
        row = (f"| {n:,} | {secs(c['build_s'])} | {secs(d['build_s'])} | "
               f"{d['build_s'] / c['build_s']:.2f}x | {secs(c['self_s'])} | {secs(d['self_s'])} | "
               f"{d['self_s'] / c['self_s']:.2f}x |")
        if cf and df and "build_s" in cf and "build_s" in df:
            row += (f" {secs(cf['build_s'])} / {secs(cf['self_s'])} | "
                    f"{secs(df['build_s'])} / {secs(df['self_s'])} | "
                    f"{df['build_s'] / cf['build_s']:.2f}x / {df['self_s'] / cf['self_s']:.2f}x |")
        else:
            row += " – | – | – |"
        out.append(row)
    return "\n".join(out) + "\n"
