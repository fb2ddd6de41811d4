"""Runs about the machine: threads_vs_one.py's default against one thread, compare.sh's
runs of one binary against itself."""

import gzip
import json
import os
import re
import statistics
import sys
from collections import defaultdict

from .cube_bench import *  # noqa: F401,F403


def span(values, fmt="{:.1f}"):
    values = [v for v in values if v is not None]
    if not values:
        return "?"
    lo, hi = min(values), max(values)
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else \
        f"{fmt.format(lo)}-{fmt.format(hi)}"


def threads_text(path):
    """threads_vs_one.py's kept run: per case and load, the default threads' time, one thread's,
    their ratio, the forced team's time, and the OpenMP regions opened per call."""
    with open(path) as f:
        data = json.load(f)
    cases, ways, load = data["cases"], data["ways"], data["load"]
    loads = ["0", str(load)] if load > 0 else ["0"]
    forced = "forced" in ways
    counted = data.get("regions_counted", False)

    def runs(case, l, w):
        return cases[case].get(l, {}).get(w, [])

    def best(case, l, w):
        rs = runs(case, l, w)
        return min(r["time_us"] for r in rs) if rs else None

    def per_call(case, l, w):
        rs = runs(case, l, w)
        if not rs or "regions" not in rs[0]:
            return None
        return sum(r["regions"] for r in rs) / max(1, sum(r["iterations"] for r in rs))

    def fmt_regions(v):
        return "–" if v is None else ("0" if v == 0 else f"{v:.2g}")

    def background(l):
        rs = [r for c in cases for w in ways for r in runs(c, l, w)]
        avg = [r["loadavg_before"][0] for r in rs]
        # The runnable count includes the script reading it.
        others = [r["loadavg_before"][3] - 1 for r in rs]
        return span(avg, "{:.2f}"), span(others, "{:.0f}")

    label = {"0": "idle", str(load): "loaded"}
    head = ["case"]
    for l in loads:
        head += [f"{label[l]}: default", "1 thread", "speed"] + (["forced"] if forced else []) + \
            ([f"regions a call: default{' / forced' if forced else ''}"] if counted else [])
    per_load = 3 + forced + counted
    out = ["### Default threads against one thread, by case (`threads_vs_one.py`)", ""]
    bg = {l: background(l) for l in loads}
    caption = (
        f"From `results/threads_vs_one.json`: run {data['date']} ({data['wall_seconds'] / 60:.0f} "
        f"minutes), {data['machine']}; `{data['command']}`. Each case ran {data['reps']} times "
        "each way, one process a run, the ways in turn case by case; times are wall time per "
        "call, the minimum of the runs. Speed = one thread's time / the default's (above 1 the "
        "default's threads pay). Idle: no busy process of ours beside the benchmark; other work on "
        f"the machine: load average {bg['0'][0]} at the start of these runs, {bg['0'][1]} other "
        "threads runnable.")
    if load > 0:
        caption += (f" Loaded: {load} busy processes beside the benchmark "
                    f"(`--load {load}`); load average {bg[str(load)][0]} at the start of these "
                    f"runs, {bg[str(load)][1]} other threads runnable before the busy processes "
                    "started.")
    if forced:
        caption += (" Forced: the default threads with `CUBE_THREADS_IGNORE_LOAD=1`, the team "
                    "as asked whatever the load.")
    if counted:
        caption += (" Regions: OpenMP regions opened per timed call (`count_regions.c`, counted "
                    "over the whole process, so the untimed calls count too: an upper bound).")
    out += [caption, "", "| " + " | ".join(head) + " |",
            "|---|" + "---:|" * (per_load * len(loads))]
    for case in cases:
        cells = []
        for l in loads:
            d, o = best(case, l, "default"), best(case, l, "one_thread")
            cells += [fmt_time(d), fmt_time(o),
                      fmt_ratio(None if d is None or o is None else o / d)]
            if forced:
                cells.append(fmt_time(best(case, l, "forced")))
            if counted:
                r = fmt_regions(per_call(case, l, "default"))
                if forced:
                    r += " / " + fmt_regions(per_call(case, l, "forced"))
                cells.append(r)
        out.append(f"| {case.replace('/manual_time', '')} | " + " | ".join(cells) + " |")
    # What the rows say together, from the same data.
    control = [c for c in cases if c.startswith("batch_") and "/cube/" in c + "/"]
    notes = []
    for l in loads:
        said = []
        if counted:
            opened = {w: sum(any(r.get("regions", 0) for r in runs(c, l, w)) for c in cases)
                      for w in ["default"] + (["forced"] if forced else [])}
            said.append(f"the default opened regions in {opened['default']} of the "
                        f"{len(cases)} cases" +
                        (f", forced in {opened['forced']}" if forced else ""))
        sp = [best(c, l, "one_thread") / best(c, l, "default") for c in control
              if best(c, l, "default") and best(c, l, "one_thread")]
        if sp:
            said.append("the `batch_*/cube` rows (one thread asked explicitly: default and one "
                        f"thread do the same work) read {span(sp, '{:.2f}x')}, this run's noise")
        if said:
            notes.append(f"{label[l].capitalize()}: " + "; ".join(said) + ".")
    if notes:
        out += ["", "In this run: " + " ".join(notes)]
    return "\n".join(out) + "\n"


def _compare_row(path, named):
    """One kept compare.sh report as a table row; with `named`, the cases it calls slower."""
    text = open(path).read()
    setting = dict(re.findall(r"CUBE_COMPARE_([A-Z_]+)=(\S+)", text))
    timing = re.search(r"^- timing: (.+)$", text, re.M)
    rounds = setting.get("ROUNDS", "5")
    layouts = setting.get("LAYOUTS", "1")
    confirm = setting.get("CONFIRM")
    shape = f"{rounds} x {layouts}" + (f" (+ {confirm})" if confirm and confirm != "0" else "")
    summary = re.search(r"^(\d+) cases; more than 5% slower (.+)$", text, re.M)
    counts = {}
    if summary:
        for what, n in re.findall(r"by ([^:,;]+): (\d+)", summary.group(2)):
            counts[what.strip()] = n
    slowest = re.search(r"^slowest (?:case|change)[^:]*: ([\d.]+)", text, re.M)
    med = counts.get("the ratio of medians", counts.get("the medians", "–"))
    paired = counts.get("the median paired ratio", "–")
    mins = counts.get("the minimums", "–")
    verdict = counts.get("the first two (the verdict)", counts.get("both", "–"))
    row = (f"| [{os.path.basename(path)}](results/{os.path.basename(path)}) | "
           f"{timing.group(1) if timing else '?'} | {shape} | "
           f"{summary.group(1) if summary else '?'} | {med} | {paired} | {mins} | "
           f"{verdict} | {slowest.group(1) if slowest else '?'} |")
    if named:
        slow = re.findall(r"^\| (\S+?)(?:/manual_time)?(?: \(\d+ rounds\))? \|.*\*\*slower\*\*",
                          text, re.M)
        row += " " + (", ".join(f"`{n}`" for n in slow) if slow else "none") + " |"
    return row


def compare_text(paths, before_after=()):
    """A summary of kept compare.sh reports: per file, its settings and how many cases it read
    more than 5% slower by each measure; then the before/after runs, with the cases each calls
    slower."""
    head = ("| file | timing | rounds x layouts (+ confirmation) | cases | > 5% by medians | "
            "by paired ratios | by minimums | called slower | slowest case |")
    rule = "|---|---|---|---:|---:|---:|---:|---:|---:|"
    out = ["### How far apart compare.sh reads identical binaries (`results/compare-aa-*.md`)", "",
           "Each file is one run of `compare.sh` with the same binary on both sides: every case "
           "it reads slower is the machine. Rounds x layouts per side (+ confirmation rounds for "
           "the cases flagged after them); a case is called slower when both the ratio of "
           "medians and the median paired ratio exceed 1.05 (in a sequential run, which has no "
           "pairs: the medians and the minimums).", "", head, rule]
    out += [_compare_row(p, False) for p in paths]
    if before_after:
        out += ["", "### Before and after the single pair judge (`results/compare-before-*.md`)",
                "", "Each file is one run of `compare.sh` of the commit before the single pair "
                "judge and rules object against main as it then stood, in the order they were "
                "run; its title says what it times. The cases each calls slower are named.", "",
                head + " cases called slower |", rule + "---|"]
        out += [_compare_row(p, True) for p in before_after]
    return "\n".join(out) + "\n"


def ompl_text(path):
    """examples/ompl_planner's output, one or more runs in one file (each after a "run:" line
    with the load average): per run the planning times of the cube checkers and of FCL's, the
    time inside the checks, the planner's own time, the continuous run, and whether the paths
    were the same."""
    runs = []
    for line in open(path):
        m = re.match(r"^run: load (\S+) \S+ \S+, (\d+) threads runnable", line)
        if m:
            runs.append({"load": f"{m.group(1)} ({int(m.group(2)) - 1} other threads runnable)"})
            continue
        if not runs:
            continue
        r = runs[-1]
        m = re.match(r"^RRTConnect, (\d+)-joint arm, (\d+) obstacles, (\d+) problems", line)
        if m:
            r["about"] = tuple(int(m.group(i)) for i in (1, 2, 3))
        m = re.match(r"^planning time: cube ([\d.]+) ms, FCL DynamicAABBTree ([\d.]+) ms: "
                     r"[\d.]+x less; cube continuous ([\d.]+) ms", line)
        if m:
            r["plan"] = tuple(float(m.group(i)) for i in (1, 2, 3))
        m = re.match(r"^inside the checks: cube ([\d.]+) ms, FCL ([\d.]+) ms .*the planner's own "
                     r"time: ([\d.]+) ms .*would plan ([\d.]+)x faster", line)
        if m:
            r["checks"] = tuple(float(m.group(i)) for i in (1, 2, 3, 4))
        m = re.match(r"^paths touching an obstacle on a 100x finer subdivision: discrete (\d+) of "
                     r"(\d+), continuous (\d+) of (\d+)", line)
        if m:
            r["fine"] = tuple(int(m.group(i)) for i in (1, 2, 3, 4))
        m = re.match(r"^same paths: (\d+) of (\d+) problems.*?; (\d+) motion checks, ([\d.]+) "
                     r"states an edge", line)
        if m:
            r["same"] = (int(m.group(1)), int(m.group(2)), int(m.group(3)), float(m.group(4)))
    runs = [r for r in runs if "plan" in r and "checks" in r and "same" in r]
    if not runs:
        return ""
    joints, obstacles, problems = runs[0].get("about", (0, 0, 0))
    out = ["### OMPL's RRTConnect with the batched checks (`examples/ompl_planner`)", "",
           f"From `{os.path.relpath(path, os.path.join(HERE, '..'))}`, {len(runs)} runs of "
           f"the example with its defaults ({joints}-joint arm, {obstacles:,} obstacles, "
           f"{problems} problems, the same seeds for every checker; load average at the start of "
           f"each: {', '.join(r['load'] for r in runs)}). Cube: `checkStates` / `checkMotion` "
           "with one `BatchScratch` per planner thread; FCL: the checker FCL users write "
           "(`DynamicAABBTreeCollisionManager`, OMPL's `DiscreteMotionValidator`). Planning "
           "time is the planner's `solve`; the checks' time includes the kinematics; the "
           "planner's own time (the rest, the same exploration in both runs) bounds the ratio: "
           "'checks free' is FCL's planning time over it.", "",
           "| run | planning: cube / FCL | ratio | inside the checks: cube / FCL | ratio | "
           "planner's own time | checks free | continuous planning | same paths | motion "
           "checks (states an edge) |",
           "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for i, r in enumerate(runs, 1):
        cube, fcl, cont = r["plan"]
        cc, fc, own, free = r["checks"]
        same, total, motions, per_edge = r["same"]
        out.append(f"| {i} | {cube:.1f} / {fcl:.1f} ms | {fcl / cube:.2f}x | {cc:.1f} / "
                   f"{fc:.1f} ms | {fc / cc:.2f}x | {own:.1f} ms | {free:.1f}x | {cont:.1f} ms | "
                   f"{same} of {total} | {motions:,} ({per_edge:.1f}) |")
    fine = [r["fine"] for r in runs if "fine" in r]
    if fine:
        d, n, c, m = fine[0]
        out += ["", f"Paths that touch an obstacle on a subdivision 100 times finer than OMPL's "
                f"(run 1): discrete checks {d} of {n}, continuous checks {c} of {m}."]
    return "\n".join(out) + "\n"
