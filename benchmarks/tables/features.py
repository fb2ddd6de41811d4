"""The feature tables of a cube_bench run: pair rules, continuous, spatial and batched cases."""

import gzip
import json
import os
import re
import statistics
import sys
from collections import defaultdict

from .cube_bench import *  # noqa: F401,F403  (formatting and the managers' names)


def raw_medians(path):
    """Medians of the cube-only feature cases (pair rules, continuous, spatial, batch_), keyed by
    run_name: {"time": us, counter: value, ...}. The time is real time for the cases timed by
    hand and for the batch_ cases (threads), CPU time otherwise."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        data = json.load(f)
    vals = defaultdict(lambda: defaultdict(list))
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
            continue
        name = b["run_name"].replace("/manual_time", "").replace("/real_time", "")
        if not name.split("/")[0] in ("pair_filters", "margins", "canonical", "continuous") \
                and not name.startswith(("spatial_", "batch_")):
            continue
        real = "manual_time" in b["name"] or "real_time" in b["name"] or name.startswith("batch_")
        vals[name]["time"].append(b["real_time" if real else "cpu_time"] * TO_US[b["time_unit"]])
        for k, v in b.items():
            if isinstance(v, (int, float)) and k not in (
                    "real_time", "cpu_time", "iterations", "repetitions", "repetition_index",
                    "threads", "family_index", "per_family_instance_index"):
                vals[name][k].append(v)
    return {n: {k: statistics.median(v) for k, v in d.items()} for n, d in vals.items()}


def get(raw, name, field="time"):
    return raw.get(name, {}).get(field)


def pair_rules_table(raw):
    out = []
    sizes = [1000, 10000]
    if not any(get(raw, f"canonical/{n}/off/cube") for n in sizes):
        return out
    out += ["### Filter bits, margins and canonical order (`pair_filters/`, `margins/`, `canonical/`)",
            "",
            "Uniform scene. The masked scene is two groups, each pairing only within itself, "
            "spread alike over the world.",
            "",
            "| case | " + " | ".join(f"{n:,} objects" for n in sizes) + " |",
            "|---|" + "---|" * len(sizes)]

    def pair(fmt_a, fmt_b, a, b):
        return [f"{fmt_a(x)} / {fmt_b(y)}" if x is not None and y is not None else "–"
                for x, y in zip(a, b)]
    num = lambda v: f"{v:,.0f}"
    rows = [
        ("self-collide + FCL's narrow phase (`collideAll`, 1 thread), unmasked / half masked",
         pair(fmt_time, fmt_time, [get(raw, f"pair_filters/{n}/narrow/unmasked/cube") for n in sizes],
              [get(raw, f"pair_filters/{n}/narrow/half_masked/cube") for n in sizes])),
        ("narrow-phase calls, unmasked / half masked",
         pair(num, num, [get(raw, f"pair_filters/{n}/narrow/unmasked/cube", "narrow_calls") for n in sizes],
              [get(raw, f"pair_filters/{n}/narrow/half_masked/cube", "narrow_calls") for n in sizes])),
        ("self-collide alone (counting callback), unmasked / half masked",
         pair(fmt_time, fmt_time, [get(raw, f"pair_filters/{n}/broadphase/unmasked/cube") for n in sizes],
              [get(raw, f"pair_filters/{n}/broadphase/half_masked/cube") for n in sizes])),
        ("pairs within a margin: `contactsWithinMargin` / FCL's tree over grown AABBs + "
         "`fcl::collide` + `fcl::distance`",
         pair(fmt_time, fmt_time, [get(raw, f"margins/{n}/cube") for n in sizes],
              [get(raw, f"margins/{n}/fcl_inflated") for n in sizes])),
        ("self-collide alone, `canonical_pairs` off / on",
         pair(fmt_time, fmt_time, [get(raw, f"canonical/{n}/off/cube") for n in sizes],
              [get(raw, f"canonical/{n}/on/cube") for n in sizes])),
    ]
    for label, cells in rows:
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    return out + [""]


def continuous_table(raw):
    sizes = [1000, 10000]
    names = [("swept-pairs", "`sweptPairs`"), ("collide-all", "`continuousCollideAll`")]
    if not any(k.startswith("continuous/") for k in raw):
        return []
    out = ["### Continuous collision (`continuous/`)", "",
           "10% of the objects move up to three object sizes per axis (screw: and turn up to a "
           "half turn). Cube's time, the time of testing every pair with a mover, and their ratio.",
           "",
           "| call | motion | " + " | ".join(f"{n:,} objects" for n in sizes) + " |",
           "|---|---|" + "---|" * len(sizes)]
    for case, label in names:
        for motion in ("trans", "screw"):
            cells = []
            for n in sizes:
                d = raw.get(f"continuous/{case}/{n}/{motion}/cube")
                if not d:
                    cells.append("–")
                    continue
                cells.append(f"{fmt_time(d['time'])} / {fmt_time(d['brute_ms'] * 1e3)} "
                             f"({d['x_brute']:.0f}x)")
            out.append(f"| {label} | {motion} | " + " | ".join(cells) + " |")
    return out + [""]


def spatial_table(raw):
    sizes = [1000, 10000, 100000]
    cases = [("spatial_ray_first_box", "first hit, AABB only"),
             ("spatial_ray_all_box", "all hits, AABB only"),
             ("spatial_ray_first_narrow", "first hit, narrow phase"),
             ("spatial_ray_all_narrow", "all hits, narrow phase"),
             ("spatial_objects_near", "`objectsNear`"),
             ("spatial_objects_in_box", "`objectsInBox`")]
    if not any(k.startswith("spatial_") for k in raw):
        return []
    out = ["### Ray and region queries (`spatial_`)", "",
           "64 segments between random points of the uniform scene, 64 regions a few object "
           "sizes across; per query, cube / a loop over every object (ratio).", "",
           "| query | " + " | ".join(f"{n:,} objects" for n in sizes) + " |",
           "|---|" + "---|" * len(sizes)]
    for case, label in cases:
        cells = []
        for n in sizes:
            d = raw.get(f"{case}/uniform/{n}/cube")
            cells.append("–" if not d else f"{fmt_time(d['cube_us_per_query'])} / "
                         f"{fmt_time(d['brute_us_per_query'])} ({d['vs_brute']:,.0f}x)")
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    return out + [""]


def batch_tables(raw):
    kinds = ["batch_states_free", "batch_states_hit", "batch_states_self", "batch_edges",
             "batch_edges_free", "batch_single", "batch_states_long"]
    scenes = ["uniform", "clustered", "meshes"]
    keys = [tuple(k.split("/")) for k in raw if k.startswith("batch_")]
    if not keys:
        return []
    out = ["### Batched state and motion checks (`batch_`)", "",
           "A 30-link robot; per cell: best FCL manager's time / cube's on one thread / on two "
           "threads, then microseconds per state, cube on one thread against that FCL manager, "
           "and the library's single-state path (`cube_loop`: a robot manager moved per state and "
           "`collideAll`, one thread)'s time / cube's on one thread; for single states, also "
           "cube's calls with one `BatchScratch` kept for all of them (best FCL / it, and its "
           "microseconds per state).",
           ""]
    for n in sorted({int(k[2]) for k in keys}):
        out += [f"**{n:,} world objects**", "", "| case | " + " | ".join(scenes) + " |",
                "|---|" + "---|" * len(scenes)]
        for kind in kinds:
            row = []
            for sc in scenes:
                fcl = [(d["time"], k[3]) for k, d in ((tuple(x.split("/")), v)
                                                      for x, v in raw.items())
                       if k[0] == kind and k[1] == sc and int(k[2]) == n
                       and not k[3].startswith("cube")]
                c1 = get(raw, f"{kind}/{sc}/{n}/cube")
                c2 = get(raw, f"{kind}/{sc}/{n}/cube_t2")
                if not fcl or c1 is None:
                    row.append("–")
                    continue
                t, m = min(fcl)
                fu = get(raw, f"{kind}/{sc}/{n}/{m}", "us_per_state")
                cu = get(raw, f"{kind}/{sc}/{n}/cube", "us_per_state")
                loop = get(raw, f"{kind}/{sc}/{n}/cube_loop")
                kept = get(raw, f"{kind}/{sc}/{n}/cube_kept")
                ku = get(raw, f"{kind}/{sc}/{n}/cube_kept", "us_per_state")
                row.append(f"{t / c1:.2f}x" + (f" / {t / c2:.2f}x" if c2 else "") +
                           f" ({cu:.2f} vs {fu:.2f} µs" +
                           (f"; loop {loop / c1:.2f}x" if loop else "") +
                           (f"; kept scratch {t / kept:.2f}x, {ku:.2f} µs" if kept else "") + ")")
            out.append(f"| {kind[6:]} | " + " | ".join(row) + " |")
        out.append("")
    cont = [tuple(k.split("/")) for k in raw if k.startswith("batch_edges_continuous/")]
    if cont:
        out += ["Continuous edges (`edges_continuous`): microseconds per state the check visits, "
                "continuous on one thread / the same edges discrete (`cube_discrete`), and the "
                "ratio.", "", "| world | " + " | ".join(scenes) + " |",
                "|---|" + "---|" * len(scenes)]
        for n in sorted({int(k[2]) for k in cont}):
            row = []
            for sc in scenes:
                c = get(raw, f"batch_edges_continuous/{sc}/{n}/cube", "us_per_checked_state")
                d = get(raw, f"batch_edges_continuous/{sc}/{n}/cube_discrete",
                        "us_per_checked_state")
                row.append("–" if c is None or d is None else
                           f"{c:.2f} / {d:.2f} µs ({c / d:.2f}x)")
            out.append(f"| {n:,} | " + " | ".join(row) + " |")
        out.append("")
    return out


def feature_text(path, batch_path=None):
    raw = raw_medians(path)
    if batch_path:
        raw.update({k: v for k, v in raw_medians(batch_path).items() if k.startswith("batch_")})
    parts = pair_rules_table(raw) + continuous_table(raw) + spatial_table(raw) + batch_tables(raw)
    return "\n".join(parts)
