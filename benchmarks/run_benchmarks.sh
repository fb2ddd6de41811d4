#!/usr/bin/env bash
# Builds cube_bench (Release), runs the full benchmark, and regenerates the tables in
# benchmarks/README.md, the raw results and the plot in benchmarks/results/.
#   bash benchmarks/run_benchmarks.sh [build-dir]      (default: build-bench)
# CUBE_BENCH_FILTER, CUBE_BENCH_REPS and CUBE_BENCH_MIN_TIME override the defaults below.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-bench}
reps=${CUBE_BENCH_REPS:-3}
min_time=${CUBE_BENCH_MIN_TIME:-0.02}

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 --target cube_bench

mkdir -p benchmarks/results
json=benchmarks/results/cube_bench.json
# The drift study (bench_drift.cpp, the rebuild threshold's choice) is left out: it has its own table.
filter=${CUBE_BENCH_FILTER:--^drift/}
cmd="$build/benchmarks/cube_bench --benchmark_filter=$filter --benchmark_repetitions=$reps --benchmark_min_time=$min_time --benchmark_out=$json --benchmark_out_format=json"
echo "+ $cmd"
status=0
$cmd || status=$?

machine="$(lscpu | sed -n 's/^Model name: *//p' | head -1), $(nproc) CPUs ($(lscpu | sed -n 's/^Thread(s) per core: *//p') thread(s) per core), $(uname -sr)"
python3 benchmarks/make_table.py "$json" --readme benchmarks/README.md \
  --plot-data benchmarks/results/time_vs_n.dat --command "$cmd" --machine "$machine" || status=1
gzip -f "$json"  # kept compressed in the repository; make_table.py reads .json.gz
if command -v gnuplot >/dev/null; then
  gnuplot -e "data='benchmarks/results/time_vs_n.dat'; out='benchmarks/results/time_vs_n.png'" \
    benchmarks/plot.gp
  echo "tables: benchmarks/README.md; plot: benchmarks/results/time_vs_n.png"
else
  echo "tables: benchmarks/README.md; no plot: gnuplot is missing (apt-get install gnuplot-nox)"
fi
# Bullet's broadphases, where Debian's libbullet-dev is installed.
if pkg-config --exists bullet; then
  bash benchmarks/run_bullet.sh "$build" || status=1
fi
exit $status
