#!/usr/bin/env bash
# Renders the benchmark scenes at fixed settings and prints, per scene: wall time, CPU time (user + system),
# camera samples per CPU-second, rays per second and peak resident memory.
#
#   scripts/bench.sh            # all scenes
#   scripts/bench.sh killeroo   # scenes whose name contains "killeroo"
#   RUSTFLAGS="-C target-cpu=native" CARGO_TARGET_DIR=target/native scripts/bench.sh   # a build for this machine
#
# Numbers depend on the machine: BENCHMARKS.md records them with the machine they were measured on.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p prismatic
bin=${CARGO_TARGET_DIR:-target}/release/prismatic
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# name | scene | extra arguments (fixed spp so runs are comparable)
scenes=(
  "killeroo-simple|crates/pbrt/tests/fixtures/killeroos/killeroo-simple.pbrt|--spp 16"
  "cornell-box|crates/pbrt/tests/fixtures/cornell-box/cornell-box.pbrt|--spp 16"
  "cornell-glass|scenes/cornell-glass.pbrt|"
  "prism-slit|scenes/prism-slit.pbrt|"
  "diamond|scenes/diamond.pbrt|"
  "purple-glass|scenes/purple-glass.pbrt|"
  "metals|scenes/metals.pbrt|"
  "prism-exercise|scenes/prism-exercise.pbrt|"
  "cornell-box-volume|scenes/bench/cornell-box-volume.pbrt|--spp 8"
  "prism-beam|scenes/prism-beam.pbrt|"
  "rainbow|scenes/rainbow.pbrt|"
)

printf '%-18s %9s %5s %8s %8s %14s %9s %9s\n' scene resolution spp wall_s cpu_s samples/cpu_s Mrays/s peak_MB
for entry in "${scenes[@]}"; do
  IFS='|' read -r name scene extra <<<"$entry"
  [[ -n "${1:-}" && "$name" != *"$1"* ]] && continue
  [[ -f "$scene" ]] || { echo "$name: $scene missing, skipped" >&2; continue; }
  # shellcheck disable=SC2086
  /usr/bin/time -f '%e %U %S %M' -o "$out/time" "$bin" render "$scene" $extra -o "$out/$name.exr" >"$out/log" 2>"$out/err" \
    || { echo "$name: render failed:" >&2; cat "$out/err" >&2; continue; }
  read -r wall user sys rss_kb <"$out/time"
  # "wrote FILE (WxH, N spp, ...)" (or "N iterations" for sppm) and "X Msamples/s, Y Mrays/s, ..."
  res=$(sed -n 's/^wrote .* (\([0-9]*x[0-9]*\), \([0-9]*\) \(spp\|iterations\).*/\1 \2/p' "$out/log")
  read -r wh spp <<<"$res"
  w=${wh%x*}; h=${wh#*x}
  mrays=$(sed -n 's/.*Msamples\/s, \([0-9.]*\) Mrays\/s.*/\1/p' "$out/log")
  cpu=$(echo "$user + $sys" | bc -l)
  sps=$(echo "$w * $h * $spp / $cpu" | bc -l)
  printf '%-18s %9s %5s %8.2f %8.2f %14.3e %9s %9.1f\n' "$name" "$wh" "$spp" "$wall" "$cpu" "$sps" "$mrays" \
    "$(echo "$rss_kb / 1000" | bc -l)"
done
