#!/usr/bin/env bash
# Time to a stated noise level for each integrator on the caustic scene scenes/prism-exercise.pbrt (issue 4).
#
#   scripts/bench-caustics.sh [SPP] [TARGET]     # defaults: 8 samples (iterations for sppm), target 2% noise
#
# For each integrator the scene is rendered twice at SPP with different seeds (800x600, both cores). The two renders
# differ only by noise, so the relative RMS noise of one render over the spectrum on the screen (pixels 585-695 x
# 175-225) is rms(a - b) / mean / sqrt(2) (`prismatic compare`). Monte Carlo noise falls as 1/sqrt(time), so the
# time to reach TARGET is time * (noise / TARGET)^2. For sppm this extrapolation ignores its bias, which also shrinks
# with the iterations. `path` cannot render the spectrum at all (the light is a point seen through glass): its mean
# over the region is ~0 and it is listed for completeness.
set -euo pipefail
cd "$(dirname "$0")/.."
spp=${1:-8}
target=${2:-0.02}
cargo build --release -q -p prismatic
bin=target/release/prismatic
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
region=585,175,695,225

printf '%-10s %5s %8s %8s %10s %12s %14s\n' integrator spp wall_s cpu_s mean noise time_to_target_s
for integrator in lightpath bdpt sppm path; do
  case $integrator in
    sppm) line='Integrator "sppm" "integer maxdepth" 8 "float radius" 0.01' ;;
    *) line="Integrator \"$integrator\" \"integer maxdepth\" 8" ;;
  esac
  sed "s/^Integrator .*/$line/" scenes/prism-exercise.pbrt >"$out/scene.pbrt"
  for seed in 1 2; do
    /usr/bin/time -f '%e %U %S' -o "$out/time$seed" "$bin" render "$out/scene.pbrt" --spp "$spp" --seed "$seed" \
      -o "$out/$seed.exr" --quiet
  done
  read -r wall user sys <"$out/time1"
  cpu=$(echo "$user + $sys" | bc -l)
  stats=$("$bin" compare "$out/1.exr" "$out/2.exr" --region "$region")
  mean=$(echo "$stats" | awk '/^mean/ { print ($2 + $3) / 2 }')
  rel=$(echo "$stats" | awk '/^relative_rmse/ { print $2 }')
  if [[ "$rel" == "inf" ]]; then
    printf '%-10s %5s %8.2f %8.2f %10.3e %12s %14s\n' "$integrator" "$spp" "$wall" "$cpu" "$mean" "-" "never"
    continue
  fi
  noise=$(echo "$rel / sqrt(2)" | bc -l)
  t=$(echo "$wall * ($noise / $target)^2" | bc -l)
  printf '%-10s %5s %8.2f %8.2f %10.3e %12.4f %14.1f\n' "$integrator" "$spp" "$wall" "$cpu" "$mean" "$noise" "$t"
done
