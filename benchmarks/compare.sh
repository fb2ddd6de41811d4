#!/usr/bin/env bash
# Before/after: builds cube_bench at two commits and times the cube manager's cases of both,
# each case's two runs back to back, for several rounds; prints each case's median time at
# each commit and the ratios.
#   bash benchmarks/compare.sh BASE [HEAD]      (HEAD defaults to the work tree as it is)
# CUBE_COMPARE_FILTER (default: every cube case but the drift study), CUBE_COMPARE_ROUNDS
# (default 5) and CUBE_COMPARE_MIN_TIME (default 0.05 s per case and round) set the work;
# CUBE_COMPARE_REUSE=1 runs the binaries of the last run again without building.
#
# Why pairs: this machine shares its cores, and the load from elsewhere drifts over seconds to
# minutes. Running all of one binary and then all of the other puts a minute between the two
# timings of a case; here each case runs in a fresh process of each binary one right after the
# other (which goes first alternates), so the two timings of a round see the same machine.
# Per case the script prints the ratio of the medians, the median of the rounds' paired ratios
# and the ratio of the minimums (load only adds time, so the fastest round is the least
# disturbed). A case counts as slower if the ratio of medians and the median paired ratio
# both exceed 1.05.
set -euo pipefail
shopt -s inherit_errexit  # a failed build inside $(build ...) stops the script
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
  # A fresh build directory: one configured from another source tree (the work tree, or a
  # worktree since removed) would make CMake refuse the new one and build the old.
  rm -rf "$work/build-$name"
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

python3 - "$before" "$after" "$filter" "$rounds" "$min_time" "$work" <<'EOF'
import json, re, statistics, subprocess, sys
before, after, pattern, rounds, min_time, work = sys.argv[1:]
rounds = int(rounds)
bins = {"before": before, "after": after}

def cases(binary):
    out = subprocess.run([binary, "--benchmark_list_tests", f"--benchmark_filter={pattern}"],
                         check=True, capture_output=True, text=True).stdout
    return [line.strip() for line in out.splitlines() if line.strip()]

listed = {side: cases(b) for side, b in bins.items()}
names = [n for n in listed["after"] if n in set(listed["before"])]
missing = sorted(set(listed["before"]) ^ set(listed["after"]))
scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}

def run(side, name):
    out = subprocess.run([bins[side], f"--benchmark_filter=^{re.escape(name)}$",
                          f"--benchmark_min_time={min_time}", "--benchmark_format=json"],
                         check=True, capture_output=True, text=True).stdout
    rows = [b for b in json.loads(out)["benchmarks"]
            if b.get("run_type") != "aggregate" and "error_occurred" not in b]
    if len(rows) != 1:
        sys.exit(f"{side}: {name}: expected one result, got {len(rows)}")
    return rows[0]["real_time"] * scale[rows[0]["time_unit"]]

times = {side: {n: [] for n in names} for side in bins}
for r in range(rounds):
    for i, n in enumerate(names):
        order = ("before", "after") if (r + i) % 2 == 0 else ("after", "before")
        for side in order:
            times[side][n].append(run(side, n))
    print(f"round {r + 1} of {rounds} done", flush=True)
with open(f"{work}/times.json", "w") as f:
    json.dump(times, f)

print(f"\n| case | before (us): median / min of {rounds} | after: median / min "
      "| after / before: medians | paired (median) | minimums |")
print("|---|---|---|---|---|---|")
slower = {"median": 0, "paired": 0, "min": 0, "verdict": 0}
worst = 0.0
for n in names:
    b, a = times["before"][n], times["after"][n]
    med = statistics.median(a) / statistics.median(b)
    paired = statistics.median(x / y for x, y in zip(a, b))
    low = min(a) / min(b)
    slower["median"] += med > 1.05
    slower["paired"] += paired > 1.05
    slower["min"] += low > 1.05
    slower["verdict"] += med > 1.05 and paired > 1.05
    worst = max(worst, min(med, paired))
    flag = " **slower**" if med > 1.05 and paired > 1.05 else ""
    print(f"| {n.replace('/manual_time', '')} | {statistics.median(b):.2f} / {min(b):.2f} | "
          f"{statistics.median(a):.2f} / {min(a):.2f} | {med:.3f}{flag} | {paired:.3f} | {low:.3f} |")
print(f"\n{len(names)} cases; more than 5% slower by the ratio of medians: {slower['median']}, "
      f"by the median paired ratio: {slower['paired']}, by the minimums: {slower['min']}; "
      f"by the first two (the verdict): {slower['verdict']}")
print(f"slowest case (the smaller of the ratio of medians and the median paired ratio): {worst:.3f}")
if missing:
    print("cases in one binary only:", ", ".join(missing))
EOF
