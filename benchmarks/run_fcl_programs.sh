#!/usr/bin/env bash
# Builds cube_fcl_programs (Release), runs FCL 0.7's own broadphase test programs at their
# Release sizes with the cube manager added (three repetitions, several minutes: Naive's
# queries at 3,000 objects take most of them), keeps its JSON in benchmarks/results/fcl_programs.json
# and regenerates the FCL programs table of benchmarks/README.md.
#   bash benchmarks/run_fcl_programs.sh [build-dir]      (default: build-bench)
# CUBE_FCL_PROGRAMS_ARGS overrides the options (default: --reps 3).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-bench}
args=${CUBE_FCL_PROGRAMS_ARGS:---reps 3}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j2 --target cube_fcl_programs
mkdir -p benchmarks/results
json=benchmarks/results/fcl_programs.json
status=0
# shellcheck disable=SC2086
"$build/benchmarks/cube_fcl_programs" $args --json "$json" || status=$?
python3 benchmarks/make_table.py --fcl-programs "$json" --readme benchmarks/README.md || status=1
echo "table: benchmarks/README.md (FCL's own broadphase test programs)"
exit $status
