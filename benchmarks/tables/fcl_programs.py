"""cube_fcl_programs' run: FCL 0.7's own broadphase test programs with the cube manager added
to their manager lists."""

import json
import os

from .cube_bench import SHORT, fmt_time

FCL_PROGRAMS_SHORT = dict(SHORT, DynamicAABBTree_l2="DynTree l2",
                          DynamicAABBTree_Array_l2="DynTreeArr l2")
FCL_PROGRAMS = [
    ("update", "Update, then collide (`test_fcl_broadphase_collision_1.cpp`)",
     ["register + setup", "update", "self collide", "collide queries"]),
    ("collision", "Collide (`test_fcl_broadphase_collision_2.cpp`)",
     ["register + setup", "self collide", "collide queries"]),
    ("distance", "Query distances (`test_fcl_broadphase_distance.cpp`)",
     ["register + setup", "distance queries"]),
    ("self_distance", "Self distance (`test_fcl_broadphase_distance.cpp`)",
     ["register + setup", "self distance"]),
    ("empty", "Empty managers (`test_fcl_broadphase_collision_2.cpp`'s empty case, distance "
     "added)", ["register + setup", "collide queries", "distance queries"]),
]


def counts_as_best(manager, cell):
    """Naive does no work in a build or an update (it keeps a list); SaP's self collide reads
    the pair list it keeps. Neither is then the best FCL manager (as in cube_fcl_programs)."""
    if manager == "Naive":
        return cell not in ("register + setup", "update")
    if manager == "SaP":
        return cell != "self collide"
    return True


def best_fcl(times, cell):
    fcl = [(t, m) for m, t in times.items()
           if m != "cube" and t is not None and t >= 0 and counts_as_best(m, cell)]
    return min(fcl) if fcl else (None, None)


def request_label(c):
    if c["program"] in ("distance", "self_distance"):
        return "–"
    if c["exhaustive"]:
        return "exhaustive"
    return f"{c['max_contacts']} contact" + ("" if c["max_contacts"] == 1 else "s")


def row_label(c):
    parts = []
    if c["program"] == "distance":
        parts.append(f"{c['scale']:g}")
    if c["program"] != "empty":
        parts.append(f"{c['env_size']:,} ({c['objects']:,})")
    parts.append("meshes" if c["mesh"] else "shapes")
    if c["program"] not in ("distance", "self_distance"):
        parts.append(request_label(c))
    return parts


def row_header(program):
    head = ["scale"] if program == "distance" else []
    if program != "empty":
        head.append("n (objects)")
    head.append("shapes")
    if program not in ("distance", "self_distance"):
        head.append("request")
    return head


def fcl_programs_text(path):
    """Per program of FCL's, a row per case: the cube manager's time per cell and the best FCL
    manager's time over it, that manager named; then every manager's time per cell."""
    with open(path) as f:
        data = json.load(f)
    configs = data["configs"]
    managers = []
    for c in configs:
        for cell in c["cells"]:
            for m in cell["times"]:
                if m not in managers:
                    managers.append(m)
    bad = [c for c in configs if not c["cube_ok"]]
    notes = sum(1 for c in configs for m in c["mismatches"] if not m.startswith("MISMATCH"))
    answers = ("The cube manager's answers agreed with the reference's in every cell (numbers of "
               "contacts of exhaustive requests, collision or not otherwise, distances within "
               "FCL's tolerance of 0.01)" if not bad else
               f"**The cube manager's answers differed from the reference's in {len(bad)} "
               "case(s)** (see the run's output)")
    answers += ("." if not notes else
                f"; FCL managers' answers differed from the reference's {notes} time(s) (the "
                "JSON's `mismatches`).")
    out = ["### FCL's own broadphase test programs (`cube_fcl_programs`)", "",
           f"From `{os.path.basename(path)}` ({data['reps']} repetitions, the minimum of each "
           f"cell; load average at start {data['loadavg'].split(' ')[0]}). Per cell the cube "
           "manager's time, then the best FCL manager's time / cube's (above 1, cube is faster) "
           "and that manager. Naive does not count as best in register + setup and update (it "
           "keeps a list: nothing to build or refit), SaP not in self collide (†: SaP keeps its "
           "overlapping pairs between calls, its self collide reads that list). Reference for "
           "the answers: Naive where it runs, else FCL's dynamic tree. " + answers, ""]
    for program, title, cells in FCL_PROGRAMS:
        rows = [c for c in configs if c["program"] == program]
        if not rows:
            continue
        head = row_header(program)
        out += [f"#### {title}", "",
                "| " + " | ".join(head + cells) + " |",
                "|" + "---|" * len(head) + "---:|" * len(cells)]
        for c in rows:
            by_cell = {x["cell"]: x["times"] for x in c["cells"]}
            texts = []
            for cell in cells:
                times = by_cell.get(cell)
                if not times or times.get("cube") is None:
                    texts.append("–")
                    continue
                cube = times["cube"]
                t, m = best_fcl(times, cell)
                texts.append(fmt_time(cube) if t is None or cube <= 0 else
                             f"{fmt_time(cube)} · {t / cube:.2f}x {FCL_PROGRAMS_SHORT.get(m, m)}")
            out.append("| " + " | ".join(row_label(c) + texts) + " |")
        out.append("")
    out += ["<details><summary>Every manager's time per cell</summary>", "",
            "| program | case | cell | " +
            " | ".join(FCL_PROGRAMS_SHORT.get(m, m) for m in managers) + " | best FCL / cube |",
            "|---|---|---|" + "---:|" * (len(managers) + 1)]
    for c in configs:
        case = " · ".join(row_label(c))
        for cell in c["cells"]:
            times = cell["times"]
            tds = []
            for m in managers:
                t = times.get(m)
                tds.append("–" if t is None or t < 0 else
                           fmt_time(t) + (" †" if m == "SaP" and cell["cell"] == "self collide"
                                          else ""))
            t, _ = best_fcl(times, cell["cell"])
            cube = times.get("cube")
            ratio = "–" if t is None or not cube else f"{t / cube:.2f}x"
            out.append(f"| {c['program']} | {case} | {cell['cell']} | " + " | ".join(tds) +
                       f" | {ratio} |")
    out += ["", "</details>"]
    return "\n".join(out) + "\n"
