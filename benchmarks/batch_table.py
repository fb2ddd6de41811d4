#!/usr/bin/env python3
"""The batched-check tables of benchmarks/README.md from a cube_bench JSON run of the batch_ cases
(--benchmark_filter=batch_ --benchmark_repetitions=3 --benchmark_out=run.json
--benchmark_out_format=json). Per case and world: best FCL manager's time / cube's on one thread
and on two (medians of the repetitions), and the microseconds per state of cube (one thread)
and of that FCL manager. Python 3 standard library only: batch_table.py run.json[.gz]
"""
import gzip
import json, statistics, sys
from collections import defaultdict
d = json.load((gzip.open if sys.argv[1].endswith(".gz") else open)(sys.argv[1], "rt"))
t = defaultdict(list); ups = defaultdict(list)
for b in d["benchmarks"]:
    if b.get("run_type") != "iteration" or not b["name"].startswith("batch_"): continue
    if b.get("error_occurred"): print("ERROR", b["name"]); continue
    p = b["run_name"].split("/")
    key = (p[0], p[1], int(p[2]), p[3])
    t[key].append(b["real_time"]); ups[key].append(b["us_per_state"])
med = {k: statistics.median(v) for k, v in t.items()}
mups = {k: statistics.median(v) for k, v in ups.items()}
kinds = ["batch_states_free", "batch_states_hit", "batch_states_self", "batch_edges",
         "batch_edges_free", "batch_single", "batch_states_long"]
for n in (1000, 2000, 10000, 100000):
  print(f"\n### {n}")
  print("| case | " + " | ".join(f"{sc}" for sc in ("uniform","clustered","meshes")) + " |")
  print("|---|---|---|---|")
  for k in kinds:
    row = []
    for sc in ("uniform","clustered","meshes"):
      fcl = [(v, m) for (kk, s, nn, m), v in med.items() if kk == k and s == sc and nn == n and not m.startswith("cube")]
      c1 = med.get((k, sc, n, "cube")); c2 = med.get((k, sc, n, "cube_t2"))
      if not fcl or c1 is None: row.append("–"); continue
      best, bm = min(fcl)
      fu = mups[(k, sc, n, bm)]; cu = mups[(k, sc, n, "cube")]
      s = f"{best/c1:.2f}x" + (f" / {best/c2:.2f}x" if c2 else "") + f" ({cu:.2f} vs {fu:.2f} µs)"
      row.append(s)
    print(f"| {k[6:]} | " + " | ".join(row) + " |")
