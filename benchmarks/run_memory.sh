#!/usr/bin/env bash
# Builds cube_memory (Release), runs it once at 10,000, 100,000, 1,000,000 and 2,000,000 objects
# (about 3 GiB at the largest size: run it on a machine with the memory to spare), keeps its JSON
# in benchmarks/results/memory.json and regenerates the memory table of benchmarks/README.md.
#   bash benchmarks/run_memory.sh [build-dir]      (default: build-bench)
# CUBE_MEMORY_SIZES overrides the sizes.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-bench}
sizes=${CUBE_MEMORY_SIZES:-10000 100000 1000000 2000000}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 --target cube_memory
mkdir -p benchmarks/results
json=benchmarks/results/memory.json
status=0
# shellcheck disable=SC2086
"$build/benchmarks/cube_memory" $sizes --json "$json" || status=$?
python3 benchmarks/make_table.py --memory "$json" --readme benchmarks/README.md || status=1
echo "table: benchmarks/README.md (memory per object)"
exit $status
