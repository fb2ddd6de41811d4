#!/usr/bin/env bash
# Builds bench_bullet (Release; needs Debian's libbullet-dev), runs it, keeps its JSON in
# benchmarks/results/bench_bullet.json.gz and regenerates the Bullet table of benchmarks/README.md.
#   bash benchmarks/run_bullet.sh [build-dir]      (default: build-bench)
# CUBE_BENCH_REPS, CUBE_BENCH_MIN_TIME and CUBE_BULLET_FILTER override the defaults below.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-bench}
reps=${CUBE_BENCH_REPS:-3}
min_time=${CUBE_BENCH_MIN_TIME:-0.2}
pkg-config --exists bullet || { echo "needs Bullet (apt-get install libbullet-dev)" >&2; exit 2; }
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 --target bench_bullet
mkdir -p benchmarks/results
json=benchmarks/results/bench_bullet.json
filter=${CUBE_BULLET_FILTER:-/(10000|100000)/}
status=0
"$build/benchmarks/bench_bullet" "--benchmark_filter=$filter" --benchmark_repetitions="$reps" \
  --benchmark_min_time="$min_time" --benchmark_out="$json" --benchmark_out_format=json || status=$?
gzip -f "$json"
python3 benchmarks/make_table.py --bullet "$json.gz" --readme benchmarks/README.md || status=1
echo "table: benchmarks/README.md (Bullet's broadphases)"
exit $status
