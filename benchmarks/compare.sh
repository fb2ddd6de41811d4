#!/usr/bin/env bash
# Before/after: builds cube_bench at two commits and times the cube manager's cases of both,
# each case's two runs back to back, for several rounds; prints each case's median time at
# each commit and the ratios.
#   bash benchmarks/compare.sh BASE [HEAD]      (HEAD defaults to the work tree as it is)
# CUBE_COMPARE_FILTER (default: every cube case but the drift study), CUBE_COMPARE_ROUNDS
# (default 5), CUBE_COMPARE_MIN_TIME (default 0.05 s per case and round) and
# CUBE_COMPARE_WARMUP (default 0.05 s per case and round, untimed: see "Why a warm-up") set the work;
# CUBE_COMPARE_REUSE=1 runs the binaries of the last run again without building.
# CUBE_COMPARE_LAYOUTS=K (default 1) links each side K times, with 0, 16, 32, ... bytes of
# padding ahead of its code, and times every layout in every round: see "Why layouts".
# CUBE_COMPARE_CONFIRM=C (default: as many as CUBE_COMPARE_ROUNDS) gives every case that reads
# more than 5% slower after the rounds (by the ratio of medians or the median paired ratio) C
# more rounds, and judges it on all of them: see "Why a confirmation".
# CUBE_COMPARE_MALLOC=fixed runs both sides with glibc's mmap and trim thresholds fixed at 256 MiB
# (GLIBC_TUNABLES) instead of its dynamic ones: see "Why fixed thresholds".
# CUBE_COMPARE_OUT=FILE also writes the report (the table and the counts) to FILE, headed by the
# two revisions, the settings, the date and the load average at the start and the end; keep it
# as benchmarks/results/compare-NAME.md, named by what it compares. CUBE_COMPARE_TITLE sets its
# title.
#
# Why pairs: this machine shares its cores, and the load from elsewhere drifts over seconds to
# minutes. Running all of one binary and then all of the other puts a minute between the two
# timings of a case; here each case runs in a fresh process of each binary one right after the
# other (which goes first alternates), so the two timings of a round see the same machine.
# Per case the script prints the ratio of the medians, the median of the rounds' paired ratios
# and the ratio of the minimums (load only adds time, so the fastest round is the least
# disturbed). A case counts as slower if the ratio of medians and the median paired ratio
# both exceed 1.05.
#
# Why layouts: where a hot loop falls against 16-, 32- and 64-byte boundaries changes how the
# front end and the branch predictor see it, and any edit anywhere in the binary moves it. Such a
# shift can cost a case more than 5% with not one instruction changed (one binary relinked with a
# few bytes ahead of its code). One link per side then times its layout's luck as much as its
# code. With K layouts, each side's sample holds rounds x K times,
# each round runs layout l of both sides back to back, and a paired ratio compares equal
# paddings; the table adds each side's spread (slowest over fastest layout median).
#
# Why a warm-up: a case whose iteration takes milliseconds (a build of 100,000 objects) runs two or
# three iterations in the timed window, and each fresh process's heap still grows during them:
# page faults whose count differs between two binaries of the same allocations by how their
# allocator's arenas happen to fall. Untimed iterations ahead of the window take those faults.
#
# Why fixed thresholds: glibc moves its mmap threshold up to the largest block freed so far and
# trims the heap's top above twice that, so where a query grows a large vector (FCL's contacts:
# tens of thousands in a motion loop) whether each growth takes fresh pages from the kernel
# depends on the order the process's earlier blocks happened to be freed in. The same binary
# then runs a case at two speeds by the output format asked for alone (a clustered 10,000-object
# motion loop: one binary 22 ms with JSON output and 26-39 ms with the console's, another the
# other way round). Fixed thresholds take that out of both sides; a difference that remains is
# the code's.
#
# Why a confirmation: on this shared machine a case's two sides can drift apart for minutes, and
# among a hundred cases a few read more than 5% slower by chance in any run (benchmarks/README.md
# summarises runs of one binary against itself). A case that is really slower stays slower with more rounds; one
# that read slow by chance moves back towards 1. The confirmation rounds run after the main
# rounds, both sides still back to back, on the flagged cases only; the table marks them with
# the number of rounds they got. Cases not flagged keep the main rounds' figures.
set -euo pipefail
shopt -s inherit_errexit  # a failed build inside $(build ...) stops the script
cd "$(dirname "$0")/.."
base=${1:?usage: compare.sh BASE [HEAD]}
head=${2:-}
rounds=${CUBE_COMPARE_ROUNDS:-5}
min_time=${CUBE_COMPARE_MIN_TIME:-0.05}
warmup=${CUBE_COMPARE_WARMUP:-0.05}
malloc=${CUBE_COMPARE_MALLOC:-default}
case "$malloc" in
  default | fixed) ;;
  *) echo "CUBE_COMPARE_MALLOC: default or fixed, not $malloc" >&2; exit 2 ;;
esac
filter=${CUBE_COMPARE_FILTER:-^[^d].*/cube(/manual_time)?$}
work=${CUBE_COMPARE_DIR:-/tmp/cube-compare}
layouts=${CUBE_COMPARE_LAYOUTS:-1}
confirm=${CUBE_COMPARE_CONFIRM:-$rounds}
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

# relink NAME: cube_bench of $work/build-NAME linked again as cube_bench.L<l> for l = 1 ..
# layouts - 1, with 16 l bytes of padding linked ahead of every other object (so that its .text
# comes first and shifts all code after it), by CMake's own link command.
relink() {
  local dir="$work/build-$1/benchmarks" l
  for ((l = 1; l < layouts; ++l)); do
    # The note section marks the padding's stack as not executable, as the compiler's objects do.
    printf '.section .note.GNU-stack,"",@progbits\n.text\n.skip %d, 0xcc\n' $((16 * l)) |
      as -o "$dir/pad$l.o" -
    (cd "$dir" && eval "$(sed -e "s| CMakeFiles/| pad$l.o CMakeFiles/|" \
      -e "s| -o cube_bench | -o cube_bench.L$l |" CMakeFiles/cube_bench.dir/link.txt)")
  done
}

if [ "${CUBE_COMPARE_REUSE:-0}" = 1 ]; then  # the binaries of the last run, not rebuilt
  before="$work/build-before/benchmarks/cube_bench"
  after="$work/build-after/benchmarks/cube_bench"
else
  before=$(build before "$base")
  after=$(build after "$head")
fi
relink before
relink after
echo "before: $base ($before)"
echo "after:  ${head:-work tree} ($after)"
echo "layouts: $layouts"

echo "confirmation rounds: $confirm"
echo "allocator thresholds: $malloc"
# For the timed runs only (the builds above ran as usual).
if [ "$malloc" = fixed ]; then
  export GLIBC_TUNABLES=glibc.malloc.mmap_threshold=268435456:glibc.malloc.trim_threshold=268435456
fi

python3 - "$before" "$after" "$filter" "$rounds" "$min_time" "$warmup" "$work" "$layouts" "$confirm" \
  "${CUBE_COMPARE_OUT:-}" "${CUBE_COMPARE_TITLE:-compare.sh ${base} against ${head:-the work tree}}" \
  "$base" "${head:-the work tree}" "${CUBE_COMPARE_REUSE:-0}" "$malloc" <<'EOF'
import datetime, json, re, statistics, subprocess, sys
(before, after, pattern, rounds, min_time, warmup, work, layouts, confirm, out_path, title, base_rev,
 head_rev, reuse, malloc) = sys.argv[1:]
rounds, layouts, confirm = int(rounds), int(layouts), int(confirm)

def loadavg():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])

started, load_start = datetime.datetime.now(datetime.timezone.utc), loadavg()
report = []  # the lines of the table and the counts, for CUBE_COMPARE_OUT

def say(line=""):
    print(line)
    report.append(line)
# bins[side][l]: the binary of layout l (0: CMake's own link).
bins = {side: [path] + [f"{path}.L{l}" for l in range(1, layouts)]
        for side, path in (("before", before), ("after", after))}

def cases(binary):
    out = subprocess.run([binary, "--benchmark_list_tests", f"--benchmark_filter={pattern}"],
                         check=True, capture_output=True, text=True).stdout
    return [line.strip() for line in out.splitlines() if line.strip()]

listed = {side: cases(b[0]) for side, b in bins.items()}
names = [n for n in listed["after"] if n in set(listed["before"])]
missing = sorted(set(listed["before"]) ^ set(listed["after"]))
scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}

# A case name as a regular expression for Google Benchmark's filter. Not re.escape: it escapes
# '-' too, which the filter's regex dialect reads as no match (swept-pairs cases ran nothing).
def literal(name):
    return re.sub(r"([.^$*+?()\[\]{}|\\])", r"\\\1", name)

def run(side, layout, name):
    out = subprocess.run([bins[side][layout], f"--benchmark_filter=^{literal(name)}$",
                          f"--benchmark_min_time={min_time}",
                          f"--benchmark_min_warmup_time={warmup}", "--benchmark_format=json"],
                         check=True, capture_output=True, text=True).stdout
    rows = [b for b in json.loads(out)["benchmarks"]
            if b.get("run_type") != "aggregate" and "error_occurred" not in b]
    if len(rows) != 1:
        sys.exit(f"{side}: {name}: expected one result, got {len(rows)}")
    return rows[0]["real_time"] * scale[rows[0]["time_unit"]]

# times[side][name][l]: that layout's times, one per round.
times = {side: {n: [[] for _ in range(layouts)] for n in names} for side in bins}

def play(r, todo, label):
    for i, n in enumerate(todo):
        for l in range(layouts):
            order = ("before", "after") if (r + i + l) % 2 == 0 else ("after", "before")
            for side in order:
                times[side][n][l].append(run(side, l, n))
    print(f"{label} done", flush=True)

def flat(side, n):  # layout 0's rounds, then layout 1's, ...
    return [t for per in times[side][n] for t in per]

def ratios(n):
    b, a = flat("before", n), flat("after", n)
    return (statistics.median(a) / statistics.median(b),
            statistics.median(x / y for x, y in zip(a, b)), min(a) / min(b))

for r in range(rounds):
    play(r, names, f"round {r + 1} of {rounds}")
flagged = [n for n in names if max(ratios(n)[:2]) > 1.05] if confirm > 0 else []
print(f"{len(flagged)} cases read more than 5% slower: {confirm} more rounds each", flush=True)
for r in range(confirm):
    play(rounds + r, flagged, f"confirmation round {r + 1} of {confirm}")
with open(f"{work}/times.json", "w") as f:
    json.dump({"layouts": layouts, "times": times, "flagged": flagged}, f)

def spread(per_layout):
    meds = [statistics.median(t) for t in per_layout]
    return max(meds) / min(meds)

samples = rounds * layouts
extra = " | spread before / after" if layouts > 1 else ""
say()
say(f"| case | before (us): median / min of {samples} (more where marked) | after: median / min "
    f"| after / before: medians | paired (median) | minimums{extra} |")
say("|---|---|---|---|---|---|" + ("---|" if layouts > 1 else ""))
slower = {"median": 0, "paired": 0, "min": 0, "verdict": 0}
worst = 0.0
for n in names:
    b, a = flat("before", n), flat("after", n)
    med, paired, low = ratios(n)
    slower["median"] += med > 1.05
    slower["paired"] += paired > 1.05
    slower["min"] += low > 1.05
    slower["verdict"] += med > 1.05 and paired > 1.05
    worst = max(worst, min(med, paired))
    flag = " **slower**" if med > 1.05 and paired > 1.05 else ""
    more = (f" | {spread(times['before'][n]):.3f} / {spread(times['after'][n]):.3f}"
            if layouts > 1 else "")
    mark = f" ({len(b) // layouts} rounds)" if n in flagged else ""
    say(f"| {n.replace('/manual_time', '')}{mark} | {statistics.median(b):.2f} / {min(b):.2f} | "
        f"{statistics.median(a):.2f} / {min(a):.2f} | {med:.3f}{flag} | {paired:.3f} | "
        f"{low:.3f}{more} |")
say()
say(f"{len(names)} cases; more than 5% slower by the ratio of medians: {slower['median']}, "
    f"by the median paired ratio: {slower['paired']}, by the minimums: {slower['min']}; "
    f"by the first two (the verdict): {slower['verdict']}")
say(f"cases given confirmation rounds: {len(flagged)} (marked with their rounds in the table)")
say(f"slowest case (the smaller of the ratio of medians and the median paired ratio): {worst:.3f}")
if missing:
    say("cases in one binary only: " + ", ".join(missing))
if out_path:
    settings = " ".join(f"CUBE_COMPARE_{k}={v}" for k, v in (
        ("ROUNDS", rounds), ("MIN_TIME", min_time), ("WARMUP", warmup), ("LAYOUTS", layouts),
        ("CONFIRM", confirm), ("REUSE", reuse), ("MALLOC", malloc),
        ("FILTER", "'" + pattern + "'")))
    head = [f"# {title}", "",
            f"- before: {base_rev}; after: {head_rev}",
            "- timing: paired" + (f", {layouts} layouts" if layouts > 1 else ""),
            f"- settings: {settings}",
            f"- date: {started.isoformat(timespec='seconds')}; load average at start "
            f"{load_start}, at end {loadavg()}", ""]
    with open(out_path, "w") as f:
        f.write("\n".join(head + report[1:]) + "\n")
    print(f"report written to {out_path}")
EOF
