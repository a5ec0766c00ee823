#!/usr/bin/env bash
# Before/after on the benchmark scenes: renders each scene of scripts/bench.sh with two prismatic binaries,
# alternating A and B (so that a change in the machine's load hits both), RUNS times each, and prints a Markdown
# table of the median CPU seconds (user + system, /usr/bin/time) with their range and B's change against A.
# The images of A and B are compared too (`prismatic compare`): "identical" when every value agrees.
#
#   scripts/bench-ab.sh OLD_BINARY NEW_BINARY            # 3 runs per binary and scene
#   RUNS=5 scripts/bench-ab.sh OLD NEW killeroo          # only scenes whose name contains "killeroo"
#
# A binary of an older commit: `git worktree add /tmp/old COMMIT && cargo build --release --manifest-path
# /tmp/old/Cargo.toml -p prismatic` gives /tmp/old/target/release/prismatic. The scenes and their sample counts (a
# quarter of scripts/bench.sh's) are in scripts/bench-scenes.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $# -ge 2 ]] || { sed -n '2,12p' "$0" >&2; exit 2; }
a=$(realpath "$1")
b=$(realpath "$2")
filter=${3:-}
runs=${RUNS:-3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

source scripts/bench-scenes.sh

echo "| scene | spp | A CPU s | B CPU s | change | images |"
echo "|---|---|---|---|---|---|"
for entry in "${bench_scenes[@]}"; do
  IFS='|' read -r name scene spp <<<"$entry"
  [[ -n "$filter" && "$name" != *"$filter"* ]] && continue
  [[ -f "$scene" ]] || { echo "$name: $scene missing, skipped" >&2; continue; }
  : >"$out/A" && : >"$out/B"
  for ((run = 1; run <= runs; run++)); do
    for who in A B; do
      bin=$a && [[ $who == B ]] && bin=$b
      /usr/bin/time -f '%U %S' -o "$out/time" "$bin" render "$scene" --spp "$spp" --quiet -o "$out/$who.exr" \
        >/dev/null 2>"$out/err" || { echo "$name: $who failed:" >&2; cat "$out/err" >&2; continue 2; }
      awk '{print $1 + $2}' "$out/time" >>"$out/$who"
    done
  done
  same=$("$b" compare "$out/A.exr" "$out/B.exr" 2>/dev/null | awk '/^relative_rmse/ {print ($2 == 0 ? "identical" : "differ (rel. RMSE " $2 ")")}')
  python3 - "$name" "$spp" "$out/A" "$out/B" "$same" <<'EOF'
import sys, statistics
name, spp, fa, fb, same = sys.argv[1:]
ta = [float(x) for x in open(fa)]
tb = [float(x) for x in open(fb)]
ma, mb = statistics.median(ta), statistics.median(tb)
fmt = lambda v, m: f"{m:.2f} ({min(v):.2f}–{max(v):.2f})"
print(f"| {name} | {spp} | {fmt(ta, ma)} | {fmt(tb, mb)} | {100 * (mb / ma - 1):+.1f}% | {same} |")
EOF
done
