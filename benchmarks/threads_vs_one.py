#!/usr/bin/env python3
"""Each cube_bench case with the default threads against one thread, idle and loaded.

Runs cube_bench (or any Google Benchmark executable that takes --load=N) case by case, four ways
in turn, --reps times: idle and with --load busy processes beside it, each with the default threads (the
hardware's) and with OMP_NUM_THREADS=1 (every default becomes one thread). Prints a markdown
table of each case's minimum time and the ratio one-thread time / default time ("speed": >= 0.95
is the target; above 1 the threads pay).

  python3 benchmarks/threads_vs_one.py build/benchmarks/cube_bench \\
      --filter '_mt/.*/cube$|distance/.*/cube$' [--reps 3] [--load 2] [--min-time 0.05]
      [--json out.json]
"""

import argparse
import json
import os
import re
import subprocess
import sys


def run(bench, filt, min_time, load, one_thread):
    env = dict(os.environ)
    if one_thread:
        env["OMP_NUM_THREADS"] = "1"
    else:
        env.pop("OMP_NUM_THREADS", None)
    cmd = [bench, f"--benchmark_filter={filt}", f"--benchmark_min_time={min_time}",
           "--benchmark_format=json"]
    if load > 0:
        cmd.append(f"--load={load}")
    out = subprocess.run(cmd, env=env, check=False, stdout=subprocess.PIPE, text=True)
    if out.returncode != 0:
        print(f"warning: {' '.join(cmd)} exited with {out.returncode}", file=sys.stderr)
    data = json.loads(out.stdout)
    return {b["name"]: b["real_time"] for b in data["benchmarks"] if b.get("run_type") != "aggregate"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bench")
    ap.add_argument("--filter", default="_mt/.*/cube$|distance/.*/cube$")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--load", type=int, default=2)
    ap.add_argument("--min-time", default="0.05")
    ap.add_argument("--json")
    args = ap.parse_args()
    ways = [(0, False), (0, True), (args.load, False), (args.load, True)]
    best = {w: {} for w in ways}
    # Case by case, the four ways in turn: a busy machine's background changes over minutes.
    listed = subprocess.run([args.bench, f"--benchmark_filter={args.filter}",
                             "--benchmark_list_tests=true"], stdout=subprocess.PIPE, text=True,
                            check=True).stdout.split()
    for case in listed:
        one = "^" + re.escape(case) + "$"
        for _ in range(args.reps):
            for w in ways:
                for name, t in run(args.bench, one, args.min_time, *w).items():
                    best[w][name] = min(t, best[w].get(name, float("inf")))
    names = [n for n in listed if n in best[ways[0]]]
    print(f"| case | idle: default | idle: 1 thread | speed | {args.load} busy: default | "
          f"{args.load} busy: 1 thread | speed |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for n in names:
        cells = []
        for load in (0, args.load):
            d, o = best[(load, False)].get(n), best[(load, True)].get(n)
            if d is None or o is None:
                cells += ["-", "-", "-"]
                continue
            cells += [f"{d:.1f} us", f"{o:.1f} us", f"{o / d:.2f}x"]
        print(f"| {n} | " + " | ".join(cells) + " |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({f"load={w[0]},one={w[1]}": best[w] for w in ways}, f, indent=1)


if __name__ == "__main__":
    main()
