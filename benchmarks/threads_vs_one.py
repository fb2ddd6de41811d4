#!/usr/bin/env python3
"""Each cube_bench case with the default threads against one thread, idle and loaded; results kept.

Runs cube_bench (or any Google Benchmark executable that takes --load=N) case by case, every way
in turn, --reps times: idle and with --load busy processes beside it (cube_bench's own --load),
each with the default threads (the hardware's), with OMP_NUM_THREADS=1 (every default becomes
one thread) and, with --forced, with the default threads and CUBE_THREADS_IGNORE_LOAD=1 (the
team as asked, whatever the load). Case by case and the ways in turn, because a shared machine's
background changes over minutes.

Each run is one process; the script keeps its wall time per call (Google Benchmark's real_time),
its iterations, /proc/loadavg read just before and just after it and, unless --no-regions, the
OpenMP regions it opened (benchmarks/count_regions.c, compiled here with cc and preloaded: every
region of the process, the untimed calls included). Everything goes to --out as JSON;
make_table.py --threads renders it into benchmarks/README.md. A summary table is printed too.

  python3 benchmarks/threads_vs_one.py build/benchmarks/cube_bench \\
      [--filter REGEX] [--reps 3] [--load 2] [--min-time 0.05] [--forced] \\
      [--out benchmarks/results/threads_vs_one.json]
"""

import argparse
import datetime
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
# The cases of the README's table: batched checks (cube: one thread asked explicitly, cube_t2: two),
# the threaded self-collide, object queries and robot loop, and both distance queries.
DEFAULT_FILTER = ("^(batch_states_free|batch_edges|batch_single)/(uniform/(1000|10000)|meshes/1000)"
                  "/cube(_t2)?/|^(selfdistance|selfcollide_narrow_mt|queries_narrow_mt|"
                  "robot_narrow_mt|objdistance_mt)/(uniform|clustered)/(1000|10000)/cube|"
                  "^(selfdistance|selfcollide_narrow_mt|queries_narrow_mt|robot_narrow_mt|"
                  "objdistance_mt)/meshes/1000/cube")
WAYS = {"default": {}, "one_thread": {"OMP_NUM_THREADS": "1"},
        "forced": {"CUBE_THREADS_IGNORE_LOAD": "1"}}


def loadavg():
    """/proc/loadavg as [1 min, 5 min, 15 min, runnable threads (this reader included)]."""
    with open("/proc/loadavg") as f:
        fields = f.read().split()
    return [float(fields[0]), float(fields[1]), float(fields[2]), int(fields[3].split("/")[0])]


def literal(name):
    # Google Benchmark's filter is a regex; re.escape would escape '-', which it reads as no match.
    return re.sub(r"([.^$*+?()\[\]{}|\\])", r"\\\1", name)


def build_shim(directory):
    src = os.path.join(HERE, "count_regions.c")
    so = os.path.join(directory, "count_regions.so")
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", src, "-o", so, "-ldl"], check=True)
    return so


def run(bench, case, min_time, load, way, shim):
    env = dict(os.environ)
    for k in ("OMP_NUM_THREADS", "CUBE_THREADS_IGNORE_LOAD", "LD_PRELOAD"):
        env.pop(k, None)
    env.update(WAYS[way])
    if shim:
        env["LD_PRELOAD"] = shim
    cmd = [bench, f"--benchmark_filter=^{literal(case)}$", f"--benchmark_min_time={min_time}",
           "--benchmark_format=json"]
    if load > 0:
        cmd.append(f"--load={load}")
    before = loadavg()
    out = subprocess.run(cmd, env=env, check=False, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    after = loadavg()
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)} ({way}) exited with {out.returncode}:\n{out.stderr}")
    rows = [b for b in json.loads(out.stdout)["benchmarks"]
            if b.get("run_type") != "aggregate" and not b.get("error_occurred")]
    if len(rows) != 1:
        sys.exit(f"{case} ({way}): expected one result, got {len(rows)}")
    b = rows[0]
    scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b["time_unit"]]
    result = {"time_us": b["real_time"] * scale, "iterations": b["iterations"],
              "loadavg_before": before, "loadavg_after": after}
    m = re.search(r"regions: (\d+) \(threads asked: (\d+)\)", out.stderr)
    if shim:
        if not m:
            sys.exit(f"{case} ({way}): no region count on stderr (is the shim preloaded?)")
        result["regions"] = int(m.group(1))
        result["threads_asked"] = int(m.group(2))
    return result


def machine():
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} CPUs, {platform.system()} {platform.release()}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bench")
    ap.add_argument("--filter", default=DEFAULT_FILTER)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--load", type=int, default=2)
    ap.add_argument("--min-time", default="0.05")
    ap.add_argument("--forced", action="store_true",
                    help="also the default threads with CUBE_THREADS_IGNORE_LOAD=1")
    ap.add_argument("--no-regions", action="store_true", help="do not count OpenMP regions")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "threads_vs_one.json"))
    args = ap.parse_args()
    ways = ["default", "one_thread"] + (["forced"] if args.forced else [])
    loads = [0, args.load] if args.load > 0 else [0]
    listed = subprocess.run([args.bench, f"--benchmark_filter={args.filter}",
                             "--benchmark_list_tests=true"], stdout=subprocess.PIPE, text=True,
                            check=True).stdout.split()
    tmp = tempfile.TemporaryDirectory()
    shim = None if args.no_regions else build_shim(tmp.name)
    started = datetime.datetime.now(datetime.timezone.utc)
    t0 = time.monotonic()
    cases = {}
    for i, case in enumerate(listed):
        per = cases.setdefault(case, {str(l): {w: [] for w in ways} for l in loads})
        for _ in range(args.reps):
            for load in loads:
                for way in ways:
                    per[str(load)][way].append(
                        run(args.bench, case, args.min_time, load, way, shim))
        print(f"{i + 1}/{len(listed)} {case}", file=sys.stderr, flush=True)
    result = {
        "script": "benchmarks/threads_vs_one.py",
        "command": " ".join(["python3", "benchmarks/threads_vs_one.py",
                             os.path.relpath(args.bench)] +
                            (["--filter", f"'{args.filter}'"] if args.filter != DEFAULT_FILTER
                             else []) +
                            ["--reps", str(args.reps), "--load", str(args.load), "--min-time",
                             str(args.min_time)] + (["--forced"] if args.forced else [])),
        "date": started.isoformat(timespec="seconds"),
        "machine": machine(),
        "reps": args.reps, "load": args.load, "min_time": args.min_time, "ways": ways,
        "regions_counted": shim is not None,
        "wall_seconds": round(time.monotonic() - t0, 1),
        "cases": cases,
    }
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(f"| case | " + " | ".join(f"load {l}: {w}" for l in loads for w in ways) + " |")
    print("|---|" + "---:|" * (len(loads) * len(ways)))
    for case, per in cases.items():
        cells = [f"{min(r['time_us'] for r in per[str(l)][w]):.1f} us" for l in loads for w in ways]
        print(f"| {case} | " + " | ".join(cells) + " |")
    print(f"wall time {result['wall_seconds']} s; kept in {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
