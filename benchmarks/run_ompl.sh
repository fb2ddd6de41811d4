#!/usr/bin/env bash
# Runs examples/ompl_planner (its defaults) RUNS times (default 3), each after a line with the
# machine's load, into benchmarks/results/ompl_planner.txt, and regenerates benchmarks/README.md's
# blocks from the kept result files (make_table.py --kept).
#   bash benchmarks/run_ompl.sh [build directory, default build] [runs]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
runs=${2:-3}
binary="$build/examples/ompl_planner"
[ -x "$binary" ] || { echo "$binary not found (built where Debian's libompl-dev is)" >&2; exit 2; }
out=benchmarks/results/ompl_planner.txt
: >"$out.tmp"
for ((i = 1; i <= runs; i++)); do
  read -r l1 l2 l3 running _ </proc/loadavg
  echo "run: load $l1 $l2 $l3, ${running%%/*} threads runnable" >>"$out.tmp"
  "$binary" >>"$out.tmp"
done
mv "$out.tmp" "$out"
python3 benchmarks/make_table.py --kept --readme benchmarks/README.md
