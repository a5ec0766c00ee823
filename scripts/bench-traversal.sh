#!/usr/bin/env bash
# Traversal against Embree 3: runs the geometry crate's `embree` benchmark (the project's BVH and Embree on the
# same ~1M triangles and the same camera, diffuse-bounce and shadow rays; closest hit and occlusion; one and two
# threads) RUNS times, alternating which of the two is timed first in each pair, and prints a Markdown table:
# the median rays per second over the runs with their range, and the ratio project / Embree.
#
#   scripts/bench-traversal.sh                  # 3 runs, 2 s of measurement per benchmark
#   RUNS=5 MEASURE=3 scripts/bench-traversal.sh
#   scripts/bench-traversal.sh bounce           # only the benchmarks whose name matches (criterion's filter)
#   TRAVERSAL_EMBREE_ROBUST=1 TRAVERSAL_EMBREE_QUALITY=high scripts/bench-traversal.sh   # Embree's other modes
#   TRAVERSAL_CPU_TIME=1 scripts/bench-traversal.sh   # one thread, timed by the thread's CPU time (shared machines)
#   INTERLEAVED=20 scripts/bench-traversal.sh   # one thread, project and Embree timed back to back in each of 20
#                                               # rounds (CPU time): the ratio to a few per cent on a noisy machine;
#                                               # ends with the ratios over the runs (median, range, mean ± 95%)
#                                               # and the memory's latency measured before and after each run,
#                                               # with a table of each run's ratios by its latency
#   INTERLEAVED=20 TRAVERSAL_ONLY=occluded_bounce scripts/bench-traversal.sh   # one query and ray set only
#   INTERLEAVED=20 TRAVERSAL_INTERLEAVED_THREADS=2 scripts/bench-traversal.sh   # the same on two threads (rayon,
#                                               # chunks of 256 rays), timed by the wall clock
#
# Installs Embree (scripts/install-embree.sh) if it is missing. Numbers depend on the machine and its load.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${RUNS:-3}
measure=${MEASURE:-2}
if ! ldconfig -p 2>/dev/null | grep -q 'libembree3\.so\b'; then
  scripts/install-embree.sh
fi
target=${CARGO_TARGET_DIR:-target}
cargo build --release -q -p geometry --features embree --bench embree
if [[ -n ${INTERLEAVED:-} ]]; then
  tables=$(mktemp)
  trap 'rm -f "$tables"' EXIT
  for ((run = 1; run <= runs; run++)); do
    echo "run $run of $runs" >&2
    TRAVERSAL_INTERLEAVED=$INTERLEAVED cargo bench -q -p geometry --features embree --bench embree 2>/dev/null |
      grep -E '^(\||memory latency)' | tee -a "$tables"
  done
  # Over the runs: each run's median ratio is one observation (rounds within a run share the machine's state, so
  # runs, not rounds, are the independent samples); their median, range, and a 95% interval for their mean
  # (Student's t), against which a target such as 0.8 can be read.
  python3 - "$tables" "$runs" <<'PY'
import re, statistics, sys
T95 = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 9: 2.26, 10: 2.23}
ratios = {}
for line in open(sys.argv[1]):
    m = re.match(r'\| (closest|occluded) \| (\w+) \| [\d.]+ \| [\d.]+ \| ([\d.]+)', line)
    if m:
        ratios.setdefault((m[1], m[2]), []).append(float(m[3]))
print(f"\nOver {sys.argv[2]} runs: project / Embree, median of the runs' medians (range); mean with its 95% interval")
print("| query | rays | median (range) | mean ± 95% |")
print("|---|---|---|---|")
for (query, rays), v in ratios.items():
    mean = statistics.mean(v)
    half = T95.get(len(v) - 1, 2.0) * statistics.stdev(v) / len(v) ** 0.5 if len(v) > 1 else float('nan')
    print(f"| {query} | {rays} | {statistics.median(v):.3f} ({min(v):.3f}–{max(v):.3f}) | {mean:.3f} ± {half:.3f} |")
# The memory's state during the runs (see the benchmark's `load_latency_ns`): it moves the ratios. Each run prints
# its latency before and after its rounds.
runs = []
for line in open(sys.argv[1]):
    m = re.match(r'memory latency (\w+): (\d+) ns per random load over 64 MB, (\d+) ns over 4 MB', line)
    if m and m[1] == "before":
        runs.append({"64 MB": [int(m[2])], "4 MB": [int(m[3])], "ratios": {}})
    elif m and runs:
        runs[-1]["64 MB"].append(int(m[2]))
        runs[-1]["4 MB"].append(int(m[3]))
    m = re.match(r'\| (closest|occluded) \| (\w+) \| [\d.]+ \| [\d.]+ \| ([\d.]+)', line)
    if m and runs:
        runs[-1]["ratios"][(m[1], m[2])] = m[3]
if runs:
    lat = {size: [x for run in runs for x in run[size]] for size in ("64 MB", "4 MB")}
    print("\nMemory latency over the runs (before and after each), median (range): " + ", ".join(
        f"{size} {statistics.median(v):.0f} ns ({min(v)}–{max(v)})" for size, v in lat.items()))
    # Each run's ratios beside its latency over 64 MB (before / after), lowest latency first: the ratios' spread
    # follows the latency, and the low-latency runs are the harder test.
    keys = list(ratios)
    print("\n| latency over 64 MB, ns | " + " | ".join(f"{q} {r}" for q, r in keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for run in sorted(runs, key=lambda r: statistics.mean(r["64 MB"])):
        print(f"| {' / '.join(map(str, run['64 MB']))} | " + " | ".join(run["ratios"].get(k, "") for k in keys) + " |")
PY
  exit
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for ((run = 1; run <= runs; run++)); do
  first=$(( run % 2 == 0 ))
  echo "run $run of $runs ($([[ $first == 1 ]] && echo Embree || echo project) first in each pair)" >&2
  rm -rf "$target/criterion"/{closest,occluded}_*
  TRAVERSAL_EMBREE_FIRST=$first cargo bench -q -p geometry --features embree --bench embree -- \
    --warm-up-time 0.5 --measurement-time "$measure" --sample-size 10 "$@" >"$out/log-$run" 2>&1 ||
    { cat "$out/log-$run" >&2; exit 1; }
  [[ $run == 1 ]] && grep -E 'triangles;|rays, ' "$out/log-$run" >&2
  # One line per benchmark: group who rays median_ns.
  for est in "$target"/criterion/{closest,occluded}_*/*/new/estimates.json; do
    [[ -f $est ]] || continue
    dir=$(dirname "$est")
    elements=$(jq '.throughput.Elements' "$dir/benchmark.json")
    median=$(jq '.median.point_estimate' "$est")
    echo "$(jq -r '.group_id' "$dir/benchmark.json") $(jq -r '.function_id' "$dir/benchmark.json") $elements $median"
  done >>"$out/results"
done

python3 - "$out/results" "$runs" "${TRAVERSAL_CPU_TIME:-0}" <<'EOF'
import sys, statistics
from collections import defaultdict
rates = defaultdict(list)  # (group, who) -> Mrays/s per run
for line in open(sys.argv[1]):
    group, who, n, ns = line.split()
    rates[(group, who)].append(float(n) / float(ns) * 1e3)
groups = sorted({g for g, _ in rates}, key=lambda g: (g.split('_')[0], ['camera', 'bounce', 'shadow'].index(g.split('_')[1]), g))
def fmt(v):
    return f"{statistics.median(v):.2f} ({min(v):.2f}–{max(v):.2f})" if len(v) > 1 else f"{v[0]:.2f}"
unit = "Mrays/CPU-s" if sys.argv[3] == "1" else "Mrays/s"
print(f"| query | rays | threads | project {unit} | Embree {unit} | project / Embree |")
print("|---|---|---|---|---|---|")
for g in groups:
    query, kind, threads = g.split('_')
    ours, theirs = rates.get((g, 'prismatic')), rates.get((g, 'embree'))
    if not ours or not theirs:
        continue
    ratios = [a / b for a, b in zip(ours, theirs)]
    print(f"| {query} | {kind} | {threads[:-1]} | {fmt(ours)} | {fmt(theirs)} | {fmt(ratios)} |")
print(f"\nMedian over {sys.argv[2]} runs (range in parentheses); ratio per run, project first in odd runs.")
EOF
