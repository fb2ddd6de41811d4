"""cube_bench's JSON run: the broadphase, narrow-phase, motion, scene, call-count and memory
tables, and the plot's data."""

import gzip
import json
import os
import re
import statistics
import sys
from collections import defaultdict

# benchmarks/, where the result files and README.md are.
HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

MANAGERS = ["cube", "DynamicAABBTree", "DynamicAABBTree_Array", "SaP", "SSaP", "IntervalTree",
            "SpatialHashing", "Naive"]
SHORT = {"cube": "cube", "DynamicAABBTree": "DynTree", "DynamicAABBTree_Array": "DynTreeArr",
         "SaP": "SaP", "SSaP": "SSaP", "IntervalTree": "Interval", "SpatialHashing": "SpHash",
         "Naive": "Naive"}
FCL = MANAGERS[1:]
TREES = ["DynamicAABBTree", "DynamicAABBTree_Array"]
CASES = ["build", "selfcollide", "selfcollide_narrow", "queries", "robot", "selfdistance",
         "objdistance", "update", "update_vector", "churn", "churn_nosetup",
         "selfcollide_narrow_mt", "queries_narrow", "motion_narrow", "robot_narrow",
         "selfcollide_cullcb", "queries_narrow_mt", "robot_narrow_mt", "objdistance_mt"]
# Cube-only cases read against the FCL managers of another case of the same run.
FCL_ROW_OF = {"selfcollide_narrow_mt": "selfcollide_narrow",
              "selfcollide_cullcb": "selfcollide_narrow",
              "queries_narrow_mt": "queries_narrow", "robot_narrow_mt": "robot_narrow",
              "objdistance_mt": "objdistance"}
SCENES = ["uniform", "clustered", "meshes", "thin"]
MOTION = ["update", "update_vector", "churn", "churn_nosetup"]

COUNTERS = {}  # filled by load(); read by best()
TO_US = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}


def load(path, clock="cpu"):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        data = json.load(f)
    times = defaultdict(list)  # (case, scene, n, manager) -> [us]
    counters = {}
    errors = {}
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration":
            continue  # aggregates: we take our own medians
        parts = b["run_name"].split("/")
        if len(parts) < 4 or parts[0] not in CASES or not parts[2].isdigit():
            continue  # not a case/scene/n/manager benchmark (e.g. the drift study)
        key = (parts[0], parts[1], int(parts[2]), parts[3])
        if b.get("error_occurred"):
            errors[key] = b.get("error_message", "error")
            continue
        # On a shared machine the process's CPU time is the robust figure (wall time includes
        # the time other processes held the core). Cases timed by hand (build, motion) only
        # have the hand-measured wall time, which Google Benchmark puts in real_time.
        field = "real_time" if clock == "real" or "manual_time" in b["name"] else "cpu_time"
        times[key].append(b[field] * TO_US[b["time_unit"]])
        counters[key] = {k: v for k, v in b.items() if isinstance(v, (int, float)) and k not in (
            "real_time", "cpu_time", "iterations", "repetitions", "repetition_index",
            "threads", "family_index", "per_family_instance_index")}
    medians = {k: statistics.median(v) for k, v in times.items()}
    COUNTERS.update(counters)
    reps = max((len(v) for v in times.values()), default=0)
    return data.get("context", {}), medians, counters, errors, reps


def fmt_time(us):
    if us is None:
        return "–"
    if us >= 1e6:
        return f"{us / 1e6:.2f} s"
    if us >= 1e3:
        return f"{us / 1e3:.3g} ms"
    return f"{us:.3g} µs"


def fmt_ratio(r):
    return "–" if r is None else f"{r:.2f}x"


def rows_of(medians):
    return sorted({(c, s, n) for (c, s, n, _) in medians},
                  key=lambda r: (CASES.index(r[0]) if r[0] in CASES else 99,
                                 SCENES.index(r[1]) if r[1] in SCENES else 99, r[2]))


def best(medians, row, managers):
    # A manager whose answer differs from the reference's does not count: a fast wrong answer
    # is worthless.
    cands = [(medians[row + (m,)], m) for m in managers
             if row + (m,) in medians and not disagrees(COUNTERS, row + (m,))]
    return min(cands) if cands else (None, None)


def ratio(medians, row, managers=FCL):
    cube = medians.get(row + ("cube",))
    t, m = best(medians, (FCL_ROW_OF.get(row[0], row[0]),) + row[1:], managers)
    if cube is None or t is None or cube <= 0:
        return None, m
    return t / cube, m


def disagrees(counters, key):
    return counters.get(key, {}).get("agree", 1) == 0


def full_table(medians, counters, errors):
    out = ["| case | scene | n | " + " | ".join(SHORT[m] for m in MANAGERS) +
           " | best FCL | best FCL / cube | best tree / cube |",
           "|" + "---|" * (len(MANAGERS) + 6)]
    for row in rows_of(medians):
        cells = []
        for m in MANAGERS:
            key = row + (m,)
            if key in errors:
                cells.append("**FAILED**")
            elif key in medians:
                cells.append(fmt_time(medians[key]) + (" †" if disagrees(counters, key) else ""))
            else:
                cells.append("–")
        r, bm = ratio(medians, row)
        rt, _ = ratio(medians, row, TREES)
        out.append(f"| {row[0]} | {row[1]} | {row[2]} | " + " | ".join(cells) +
                   f" | {SHORT.get(bm, '–')} | {fmt_ratio(r)} | {fmt_ratio(rt)} |")
    return "\n".join(out)


# SaP's self-collide walks the overlap list that its setup() and update() maintain: its cost is
# in the update rows. The self-collide targets are therefore read against the other managers
# (the "best FCL manager" there is the tree manager); the full table shows SaP too.
NO_SAP = [m for m in FCL if m != "SaP"]
TARGETS = [
    ("self-collide 10,000 (SaP excluded)", ("selfcollide", 10000), 5),
    ("self-collide 100,000 (SaP excluded)", ("selfcollide", 100000), 5),
    ("1,000 queries at 10,000", ("queries", 10000), 5),
    ("update() 1% + self-collide, 10,000", ("update", 10000), 5),
    ("build 10,000", ("build", 10000), 3),
    ("build 100,000", ("build", 100000), 3),
    ("self distance 10,000", ("selfdistance", 10000), 3),
    ("100 object distances at 10,000", ("objdistance", 10000), 3),
    ("32 objects, update() + self-collide", ("update", 32), 3),
]


# With FCL's narrow phase in the loop (cube: its pipeline; FCL: its default callback).
NARROW_TARGETS = [
    ("self-collide + narrow phase, 1 thread", "selfcollide_narrow", 3),
    ("self-collide + narrow phase, hardware threads", "selfcollide_narrow_mt", 5),
    ("1,000 object queries + narrow phase, 1 thread", "queries_narrow", 3),
    ("the same with the default options (hardware threads)", "queries_narrow_mt", 3),
    ("motion loop: 1% move, update, self-collide + narrow phase (cube: cache)", "motion_narrow",
     10),
    ("robot loop: 30-object robot, 'does it collide?' per pose, 1 thread", "robot_narrow", 3),
    ("the same with the default options (hardware threads)", "robot_narrow_mt", 3),
    ("100 object distances, cube::minimumDistance with the default options", "objdistance_mt",
     1),
    ("self-collide, your own callback (FCL's default) behind Config::cull_pairs, 1 thread",
     "selfcollide_cullcb", 2),
]


def narrow_table(medians):
    sizes = sorted({k[2] for k in medians if k[0] in [c for _, c, _ in NARROW_TARGETS]})
    out = ["| case | goal | scene | " + " | ".join(f"{n:,}" for n in sizes) + " |",
           "|---|---|---|" + "---|" * len(sizes)]
    for label, case, goal in NARROW_TARGETS:
        for sc in SCENES:
            cells = []
            for n in sizes:
                r, m = ratio(medians, (case, sc, n))
                cells.append("–" if r is None else f"{fmt_ratio(r)} ({SHORT[m]})")
            if all(c == "–" for c in cells):
                continue
            out.append(f"| {label} | ≥ {goal}x | {sc} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def target_table(medians):
    out = ["| target | goal | " + " | ".join(f"{s}: best FCL / cube" for s in SCENES) +
           " | uniform: best tree / cube |",
           "|---|---|" + "---|" * (len(SCENES) + 1)]
    for label, (case, n), goal in TARGETS:
        cells = []
        pool = NO_SAP if "SaP excluded" in label else FCL
        for s in SCENES:
            r, m = ratio(medians, (case, s, n), pool)
            cells.append("–" if r is None else
                         f"{fmt_ratio(r)} ({SHORT[m]}){'' if r >= goal else ' ✗'}")
        rt, mt = ratio(medians, (case, "uniform", n), TREES)
        out.append(f"| {label} | ≥ {goal}x | " + " | ".join(cells) + f" | {fmt_ratio(rt)} |")
    return "\n".join(out)


def memory_table(counters, sizes):
    out = ["| n | " + " | ".join(SHORT[m] for m in MANAGERS) + " | cube bytes() |",
           "|---|" + "---|" * (len(MANAGERS) + 1)]
    for n in sizes:
        cells = []
        for m in MANAGERS:
            c = counters.get(("build", "uniform", n, m), {})
            cells.append(f"{c['heap_B_per_obj']:.0f}" if "heap_B_per_obj" in c else "–")
        t = counters.get(("build", "uniform", n, "cube"), {}).get("tree_B_per_obj")
        out.append(f"| {n} | " + " | ".join(cells) + f" | {'–' if t is None else f'{t:.0f}'} |")
    return "\n".join(out)


def motion_table(medians, counters):
    out = ["| case | scene | n | objects moved | cube per moved object | DynTree per moved object"
           " | DynTree / cube | best FCL / cube |", "|---|---|---|---|---|---|---|---|"]
    for row in rows_of(medians):
        if row[0] not in MOTION or row[2] not in (1000, 10000):
            continue
        cube = medians.get(row + ("cube",))
        moved = counters.get(row + ("cube",), {}).get("updated_per_step")
        if cube is None or not moved:
            continue
        dt = medians.get(row + ("DynamicAABBTree",))
        r, bm = ratio(medians, row)
        out.append(f"| {row[0]} | {row[1]} | {row[2]} | {moved:.0f} | {fmt_time(cube / moved)} | "
                   f"{fmt_time(None if dt is None else dt / moved)} | "
                   f"{fmt_ratio(None if dt is None else dt / cube)} | "
                   f"{fmt_ratio(r)} ({SHORT.get(bm, '–')}) |")
    return "\n".join(out)


def scene_table(counters, sizes):
    out = ["| scene | n | AABB overlaps per object | cube box tests per object (self-collide)"
           " | cube box tests per query (1,000 queries) |", "|---|---|---|---|---|"]
    for s in SCENES:
        for n in sizes:
            c = counters.get(("selfcollide", s, n, "cube"))
            if not c:
                continue
            q = counters.get(("queries", s, n, "cube"), {}).get("box_tests_per_query")
            out.append(f"| {s} | {n} | {c.get('overlaps_per_obj', float('nan')):.2f} | "
                       f"{c.get('box_tests_per_obj', float('nan')):.1f} | "
                       f"{'–' if q is None else f'{q:.1f}'} |")
    return "\n".join(out)


def calls_table(counters):
    """FCL's narrow-phase calls made by the cube manager's pipeline and by FCL's dynamic tree with
    FCL's default callbacks, per scene at 1,000 and 10,000 objects (counts: the same every run)."""
    sizes = [1000, 10000]
    rows = [("selfcollide_narrow", "self-collide + narrow phase: FCL calls (contacts)",
             "narrow_calls"),
            ("selfdistance", "self distance: FCL calls", "narrow_calls"),
            ("objdistance", "object distance: FCL calls per query", "narrow_calls_per_query")]
    out = ["| case | scene | " + " | ".join(f"{n:,}: cube / DynTree" for n in sizes) + " |",
           "|---|---|" + "---|" * len(sizes)]
    for case, label, field in rows:
        for sc in SCENES:
            cells = []
            for n in sizes:
                c = counters.get((case, sc, n, "cube"), {})
                d = counters.get((case, sc, n, "DynamicAABBTree"), {})
                if field not in c or field not in d:
                    cells.append("–")
                    continue
                num = (lambda v: f"{v:,.0f}") if field == "narrow_calls" else (lambda v: f"{v:.2f}")
                cell = f"{num(c[field])} / {num(d[field])}"
                if "contacts" in c:
                    cell += f" ({c['contacts']:,.0f})"
                cells.append(cell)
            if any(x != "–" for x in cells):
                out.append(f"| {label} | {sc} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def render(context, medians, counters, errors, reps, command, machine):
    sizes = sorted({k[2] for k in medians})
    parts = []
    parts.append(f"Run: {context.get('date', '?')}; {reps} repetitions, medians; "
                 f"load average at start {context.get('load_avg', '?')}. Times are the "
                 "process's CPU time per call, except `build`, the motion cases (`update`, "
                 "`update_vector`, `churn*`, `motion_narrow`), `robot_narrow` and the threaded "
                 "`selfcollide_narrow_mt`, which are wall time measured by hand around the "
                 "timed part and so include any time other processes held the core.")
    if machine:
        parts.append(f"Machine: {machine}.")
    if command:
        parts.append(f"Command: `{command}`")
    if errors:
        parts.append("**Correctness checks failed:** " +
                     ", ".join("/".join(map(str, k)) for k in sorted(errors)))
    else:
        parts.append("Every correctness check of the cube manager passed in this run.")
    parts.append("### With FCL's narrow phase in the loop (ratio = best FCL manager / "
                 "cube, same run, best FCL manager in brackets)\n\n" + narrow_table(medians))
    sap_same = [counters[k].get("narrow_calls") ==
                counters.get(k[:3] + ("DynamicAABBTree",), {}).get("narrow_calls")
                for k in counters if k[0] == "selfcollide_narrow" and k[3] == "SaP"]
    parts.append("### FCL calls with the narrow phase (cube's pipeline against FCL's dynamic tree "
                 "with FCL's default callbacks" +
                 ("; SaP's self-collide makes as many calls as the tree in every scene"
                  if sap_same and all(sap_same) else "") + ")\n\n" + calls_table(counters))
    parts.append("### Broadphase alone against its targets (ratio = best FCL manager / cube, same "
                 "run; ✗ = not met)\n\n" + target_table(medians))
    parts.append("### Memory per object after build (live heap growth, bytes per object)\n\n" +
                 memory_table(counters, sizes))
    parts.append("### Cost per object updated (time of one step / objects moved)\n\n" +
                 motion_table(medians, counters))
    parts.append("### Scenes: overlaps and cube box tests\n\n" + scene_table(counters, sizes))
    parts.append("### Every case (median time per call; † = that FCL manager's answer differs "
                 "from the reference's, see notes)\n\n" + full_table(medians, counters, errors))
    return "\n\n".join(parts) + "\n"


def plot_data(medians, path):
    # One block per case (gnuplot index 0, 1, ...): n, then one column per manager.
    with open(path, "w") as f:
        for case in ("selfcollide", "queries"):
            f.write(f"# {case} uniform: n " + " ".join(MANAGERS) + "\n")
            for n in sorted({k[2] for k in medians if k[0] == case and k[1] == "uniform"}):
                vals = [medians.get((case, "uniform", n, m)) for m in MANAGERS]
                f.write(f"{n} " + " ".join("NaN" if v is None else f"{v:.6g}" for v in vals) + "\n")
            f.write("\n\n")
