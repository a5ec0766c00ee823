#!/usr/bin/env bash
# Efficiency of a render against a converged reference: renders a scene with several seeds at a fixed sample count,
# and prints per seed the CPU time (user + system), the relative MSE against the reference (MSE / mean(reference)²,
# `prismatic compare`) and the efficiency 1 / (relative MSE × CPU seconds); then the means over the seeds.
# For an unbiased renderer the relative MSE falls as 1/spp, so the efficiency does not depend on spp: two
# techniques compare at equal CPU time by their efficiencies.
#
#   scripts/efficiency.sh                              # the dispersive room, path, 64 spp, 4 seeds
#   scripts/efficiency.sh --seeds 8 --spp 32
#   scripts/efficiency.sh -- --wavelengths cmf         # arguments after -- go to `prismatic render`
#   SCENE=scenes/x.pbrt REFERENCE=x-ref.exr scripts/efficiency.sh
#   scripts/efficiency.sh --variant "old|/tmp/old/target/release/prismatic|scenes/x.pbrt" \
#                         --variant "new|target/release/prismatic|scenes/x.pbrt"
#
# With --variant LABEL|BINARY|SCENE (repeatable) the variants are rendered in turn for each seed, so that a change
# in the machine's load hits them alike, and a summary line is printed per variant.
#
# The reference of the dispersive room (scenes/bench/dispersive-room-ref.exr) was rendered with
#   prismatic render scenes/bench/dispersive-room.pbrt --spp 16384 --seed 1000 -o dispersive-room-ref.exr
# (see BENCHMARKS.md, "Dispersion efficiency", for how it was checked against an independent bidirectional render).
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${SCENE:-scenes/bench/dispersive-room.pbrt}
reference=${REFERENCE:-scenes/bench/dispersive-room-ref.exr}
seeds=4
spp=64
variants=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seeds) seeds=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --variant) variants+=("$2"); shift 2 ;;
    --) shift; break ;;
    *) echo "unknown option $1 (arguments for prismatic render go after --)" >&2; exit 2 ;;
  esac
done
[[ -f "$reference" ]] || { echo "no reference image $reference" >&2; exit 2; }
cargo build --release -q -p prismatic
[[ ${#variants[@]} -gt 0 ]] || variants=("-|target/release/prismatic|$scene")
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

echo "reference $reference, $spp spp, seeds 1..$seeds, extra: $*"
printf '%-12s %5s %8s %8s %12s %12s\n' variant seed wall_s cpu_s rel_mse efficiency
for seed in $(seq 1 "$seeds"); do
  for v in "${variants[@]}"; do
    IFS='|' read -r label bin vscene <<<"$v"
    /usr/bin/time -f '%e %U %S' -o "$out/time" "$bin" render "$vscene" --quiet --spp "$spp" --seed "$seed" "$@" \
      -o "$out/img.exr" 2>"$out/err" || { cat "$out/err" >&2; exit 1; }
    read -r wall user sys <"$out/time"
    cpu=$(echo "$user + $sys" | bc -l)
    mse=$(target/release/prismatic compare "$out/img.exr" "$reference" | sed -n 's/^relative_mse //p')
    eff=$(awk -v m="$mse" -v c="$cpu" 'BEGIN { printf "%.6g", 1 / (m * c) }')
    printf '%-12s %5d %8.2f %8.2f %12.4e %12.4f\n' "$label" "$seed" "$wall" "$cpu" "$mse" "$eff" | tee -a "$out/log"
  done
done
# Per variant: the means over the seeds, and the efficiency 1/(mean MSE x mean CPU).
awk '{ n[$1]++; m[$1] += $5; c[$1] += $4; e[$1] += $6; e2[$1] += $6 * $6; if (!($1 in o)) { o[$1] = ++k; l[k] = $1 } }
END {
  for (i = 1; i <= k; i++) {
    v = l[i]; mm = m[v] / n[v]; mc = c[v] / n[v]; me = e[v] / n[v]
    sd = (n[v] > 1) ? sqrt((e2[v] - n[v] * me * me) / (n[v] - 1)) : 0
    printf "mean %s: relative MSE %.4e, CPU %.2f s, efficiency 1/(mean MSE x mean CPU) = %.4f (per-seed mean %.4f, sd %.4f)\n",
      v, mm, mc, 1 / (mm * mc), me, sd
  }
}' "$out/log"
