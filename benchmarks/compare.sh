#!/usr/bin/env bash
# Before/after: builds cube_bench at two commits, runs the cube manager's cases of both in turn,
# several rounds, and prints each case's median time at each commit and the ratio.
#   bash benchmarks/compare.sh BASE [HEAD]      (HEAD defaults to the work tree as it is)
# CUBE_COMPARE_FILTER (default: every cube case but the drift study), CUBE_COMPARE_ROUNDS
# (default 5) and CUBE_COMPARE_MIN_TIME (default 0.05 s per case and round) set the work;
# CUBE_COMPARE_REUSE=1 runs the binaries of the last run again without building.
# Rounds alternate the two binaries, so that a change in the machine's load hits both alike.
# Each case gets the ratio of the medians of its rounds and the ratio of their minimums: load
# from elsewhere on the machine only ever adds time, so the fastest round is the one least
# disturbed, and a case is called slower only if both ratios say so.
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: compare.sh BASE [HEAD]}
head=${2:-}
rounds=${CUBE_COMPARE_ROUNDS:-5}
min_time=${CUBE_COMPARE_MIN_TIME:-0.05}
filter=${CUBE_COMPARE_FILTER:-^[^d].*/cube(/manual_time)?$}
work=${CUBE_COMPARE_DIR:-/tmp/cube-compare}
mkdir -p "$work"

# build NAME REV: a Release cube_bench of REV (empty: the work tree) in $work/NAME.
build() {
  local name=$1 rev=$2 src
  if [ -n "$rev" ]; then
    src="$work/src-$name"
    rm -rf "$src"
    git worktree remove --force "$src" 2>/dev/null || true
    git worktree add --detach "$src" "$rev" >/dev/null
  else
    src=$(pwd)
  fi
  cmake -S "$src" -B "$work/build-$name" -DCMAKE_BUILD_TYPE=Release \
    -DCUBE_COLLISION_BUILD_TESTS=OFF -DCUBE_COLLISION_BUILD_EXAMPLES=OFF >/dev/null
  cmake --build "$work/build-$name" -j2 --target cube_bench >/dev/null
  echo "$work/build-$name/benchmarks/cube_bench"
}

if [ "${CUBE_COMPARE_REUSE:-0}" = 1 ]; then  # the binaries of the last run, not rebuilt
  before="$work/build-before/benchmarks/cube_bench"
  after="$work/build-after/benchmarks/cube_bench"
else
  before=$(build before "$base")
  after=$(build after "$head")
fi
echo "before: $base ($before)"
echo "after:  ${head:-work tree} ($after)"
for r in $(seq 1 "$rounds"); do
  for side in before after; do
    bin=$before
    [ "$side" = after ] && bin=$after
    "$bin" --benchmark_filter="$filter" --benchmark_min_time="$min_time" \
      --benchmark_format=json >"$work/$side-$r.json" 2>/dev/null
  done
  echo "round $r of $rounds done"
done

python3 - "$work" "$rounds" <<'EOF'
import json, statistics, sys
work, rounds = sys.argv[1], int(sys.argv[2])
times = {"before": {}, "after": {}}
for side in times:
    for r in range(1, rounds + 1):
        with open(f"{work}/{side}-{r}.json") as f:
            for b in json.load(f)["benchmarks"]:
                if b.get("run_type") == "aggregate" or "error_occurred" in b:
                    continue
                scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b["time_unit"]]
                times[side].setdefault(b["name"], []).append(b["real_time"] * scale)
names = [n for n in times["before"] if n in times["after"]]
print(f"\n| case | before (us): median / min of {rounds} | after: median / min | after / before: medians | minimums |")
print("|---|---|---|---|---|")
worst = 0.0
slower = {"median": 0, "min": 0, "both": 0}
for n in names:
    b, a = times["before"][n], times["after"][n]
    med = statistics.median(a) / statistics.median(b)
    low = min(a) / min(b)
    worst = max(worst, min(med, low))
    slower["median"] += med > 1.05
    slower["min"] += low > 1.05
    slower["both"] += med > 1.05 and low > 1.05
    name = n.replace("/manual_time", "")
    print(f"| {name} | {statistics.median(b):.2f} / {min(b):.2f} | "
          f"{statistics.median(a):.2f} / {min(a):.2f} | {med:.3f} | {low:.3f} |")
print(f"\n{len(names)} cases; more than 5% slower by the medians: {slower['median']}, "
      f"by the minimums: {slower['min']}, by both: {slower['both']}")
print(f"slowest change (the smaller of the two ratios): {worst:.3f}")
missing = sorted(set(times["before"]) ^ set(times["after"]))
if missing:
    print("cases in one run only:", ", ".join(missing))
EOF
