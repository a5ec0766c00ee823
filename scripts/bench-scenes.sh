# The benchmark scenes of scripts/bench.sh at a quarter of its samples per pixel (name | scene | spp). Sourced by
# scripts/bench-ab.sh (before/after timings; figures in BENCHMARKS.md) and scripts/build-pgo.sh (the profile renders,
# at a quarter of these counts again).
# shellcheck disable=SC2034  # used by the scripts that source this file
bench_scenes=(
  "killeroo-simple|crates/pbrt/tests/fixtures/killeroos/killeroo-simple.pbrt|16"
  "cornell-box|crates/pbrt/tests/fixtures/cornell-box/cornell-box.pbrt|4"
  "cornell-glass|scenes/cornell-glass.pbrt|36"
  "prism-slit|scenes/prism-slit.pbrt|128"
  "diamond|scenes/diamond.pbrt|56"
  "purple-glass|scenes/purple-glass.pbrt|40"
  "metals|scenes/metals.pbrt|72"
  "prism-exercise|scenes/prism-exercise.pbrt|16"
  "cornell-box-volume|scenes/bench/cornell-box-volume.pbrt|2"
  "prism-beam|scenes/prism-beam.pbrt|16"
  "rainbow|scenes/rainbow.pbrt|16"
)
