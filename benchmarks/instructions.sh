#!/usr/bin/env bash
# Instruction counts of the cube manager on fixed workloads (benchmarks/instructions.cpp), under
# callgrind (Debian's valgrind): one line per case and size, instructions per call. Judge a
# refactor's cost by these, not by timings (this machine's move 10-20% between runs).
#   bash benchmarks/instructions.sh [BUILD_DIR]                  counts of one build
#   bash benchmarks/instructions.sh BUILD_DIR_BEFORE BUILD_DIR_AFTER   both, and after / before
# Each build directory must hold benchmarks/cube_instructions (cmake --build DIR --target
# cube_instructions). CUBE_INSTRUCTION_CASES overrides the list ("case:objects ...").
set -euo pipefail
command -v valgrind >/dev/null || { echo "needs valgrind (Debian: apt-get install valgrind)" >&2; exit 2; }
cases=${CUBE_INSTRUCTION_CASES:-"self:32 self:1000 self:10000 queries:1000 queries:10000 robot:1000 robot:10000 update:1000 update:10000 still:10000 keep:10000 keepstill:10000 distance:1000 contacts:1000 states:1000 states:10000 edges:1000 edges:10000 single:10000 singlekept:10000 edgeeach:10000 edgekept:10000 se3edges:10000 boundedges:10000 long:1000 first:10000 merged:1000 pairs:1000 callback:1000 margins:1000 fcltree:1000 cullpairs:170 build:10000 turn:3000 armstates:2000 armedges:2000"}
count() {  # build dir, case, objects -> "instructions calls checksum"
  local out
  out=$(valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=/dev/null \
        "$1/benchmarks/cube_instructions" "$2" "$3" 2>&1)
  local ir calls sum
  ir=$(echo "$out" | sed -n 's/.*Collected : \([0-9]*\).*/\1/p')
  calls=$(echo "$out" | sed -n 's/^calls \([0-9]*\) checksum.*/\1/p')
  sum=$(echo "$out" | sed -n 's/^calls [0-9]* checksum \([0-9]*\)/\1/p')
  [ -n "$calls" ] || { echo "0 0 -"; return; }  # a case this build does not have
  echo "$ir $calls $sum"
}
before=${1:-build}
after=${2:-}
if [ -z "$after" ]; then
  printf '%-10s %8s %14s %10s\n' case objects "Ir/call" checksum
else
  printf '%-10s %8s %14s %14s %8s\n' case objects "before Ir/call" "after Ir/call" "after/before"
fi
for c in $cases; do
  name=${c%%:*}
  n=${c##*:}
  read -r ir calls sum <<<"$(count "$before" "$name" "$n")"
  if [ -z "$after" ]; then
    printf '%-10s %8s %14d %10s\n' "$name" "$n" $((calls ? ir / calls : 0)) "$sum"
  else
    read -r ir2 calls2 sum2 <<<"$(count "$after" "$name" "$n")"
    if [ "$calls" = 0 ] || [ "$calls2" = 0 ]; then
      printf '%-10s %8s %14s %14s\n' "$name" "$n" "$((calls ? ir / calls : 0))" \
        "$((calls2 ? ir2 / calls2 : 0))  (a case one build lacks)"
      continue
    fi
    note=""
    [ "$sum" != "$sum2" ] && note="  (answers differ: $sum vs $sum2)"
    printf '%-10s %8s %14d %14d %8s%s\n' "$name" "$n" $((ir / calls)) $((ir2 / calls2)) \
      "$(awk -v a="$ir" -v b="$ir2" 'BEGIN { printf "%.4f", b / a }')" "$note"
  fi
done
