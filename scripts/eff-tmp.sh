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
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seeds) seeds=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --) shift; break ;;
    *) echo "unknown option $1 (arguments for prismatic render go after --)" >&2; exit 2 ;;
  esac
done
[[ -f "$reference" ]] || { echo "no reference image $reference" >&2; exit 2; }

bin=${BIN:-target/release/prismatic}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

echo "scene $scene, reference $reference, $spp spp, seeds 1..$seeds, extra: $*"
printf '%5s %8s %8s %12s %12s\n' seed wall_s cpu_s rel_mse efficiency
sum_mse=0; sum_cpu=0; sum_eff=0; sum_eff2=0
for seed in $(seq 1 "$seeds"); do
  /usr/bin/time -f '%e %U %S' -o "$out/time" "$bin" render "$scene" --quiet --spp "$spp" --seed "$seed" "$@" \
    -o "$out/img.exr" 2>"$out/err" || { cat "$out/err" >&2; exit 1; }
  read -r wall user sys <"$out/time"
  cpu=$(echo "$user + $sys" | bc -l)
  mse=$("$bin" compare "$out/img.exr" "$reference" | sed -n 's/^relative_mse //p')
  eff=$(awk -v m="$mse" -v c="$cpu" 'BEGIN { printf "%.6g", 1 / (m * c) }')
  printf '%5d %8.2f %8.2f %12.4e %12.4f\n' "$seed" "$wall" "$cpu" "$mse" "$eff"
  sum_mse=$(awk -v a="$sum_mse" -v b="$mse" 'BEGIN { print a + b }')
  sum_cpu=$(awk -v a="$sum_cpu" -v b="$cpu" 'BEGIN { print a + b }')
  sum_eff=$(awk -v a="$sum_eff" -v b="$eff" 'BEGIN { print a + b }')
  sum_eff2=$(awk -v a="$sum_eff2" -v b="$eff" 'BEGIN { print a + b * b }')
done
awk -v n="$seeds" -v m="$sum_mse" -v c="$sum_cpu" -v e="$sum_eff" -v e2="$sum_eff2" 'BEGIN {
  mm = m / n; mc = c / n; me = e / n
  sd = (n > 1) ? sqrt((e2 - n * me * me) / (n - 1)) : 0
  printf "mean: relative MSE %.4e, CPU %.2f s, efficiency 1/(mean MSE x mean CPU) = %.4f (per-seed mean %.4f, sd %.4f)\n",
    mm, mc, 1 / (mm * mc), me, sd
}'
