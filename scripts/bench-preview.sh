#!/usr/bin/env bash
# The live view's overhead: each scene rendered alternately without and with --preview while a client polls the
# page as the browser does (the status twice a second, the frame whenever it changed), RUNS times each; prints
# each run's CPU time (user + system), the median ratio with/without, and the live view's own account of its work
# (frames, time copying the film, PNGs encoded and their time), which a noisy machine cannot hide.
#
#   scripts/bench-preview.sh                  # the default scenes, 3 runs each
#   RUNS=5 scripts/bench-preview.sh prism     # scenes whose name contains "prism"
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p prismatic
bin=${CARGO_TARGET_DIR:-target}/release/prismatic
runs=${RUNS:-3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# name | scene | extra arguments
scenes=(
  "killeroo-simple|crates/pbrt/tests/fixtures/killeroos/killeroo-simple.pbrt|--spp 32"
  "cornell-glass|scenes/cornell-glass.pbrt|--spp 48"
  "prism-slit|scenes/prism-slit.pbrt|--spp 128"
  "metals|scenes/metals.pbrt|--spp 96"
)

# Polls the preview whose address the render printed in $1 (stderr file) until the render ends.
client() {
  local err=$1 addr="" last=""
  for _ in $(seq 100); do
    addr=$(grep -o '127\.0\.0\.1:[0-9]*' "$err" 2>/dev/null | head -1) && [[ -n "$addr" ]] && break
    sleep 0.1
  done
  [[ -n "$addr" ]] || return 0
  while status=$(curl -s --max-time 5 "http://$addr/status"); do
    version=$(sed -n 's/.*"version":\([0-9]*\).*/\1/p' <<<"$status")
    if [[ -n "$version" && "$version" != "$last" ]]; then
      curl -s --max-time 10 -o /dev/null "http://$addr/frame.png?v=$version&view=oklab&exposure=0" || true
      last=$version
    fi
    sleep 0.5
  done
}

cpu() { awk '{ printf "%.2f", $1 + $2 }' "$1"; }

printf '%-16s %4s %10s %10s %8s\n' scene run cpu_plain cpu_live ratio
for entry in "${scenes[@]}"; do
  IFS='|' read -r name scene extra <<<"$entry"
  [[ -n "${1:-}" && "$name" != *"$1"* ]] && continue
  ratios=()
  for run in $(seq "$runs"); do
    # shellcheck disable=SC2086
    /usr/bin/time -f '%U %S' -o "$out/plain" "$bin" render "$scene" $extra --quiet -o "$out/a.exr" 2>/dev/null
    # shellcheck disable=SC2086
    /usr/bin/time -f '%U %S' -o "$out/live" "$bin" render "$scene" $extra --preview -o "$out/b.exr" \
      >/dev/null 2>"$out/err" &
    pid=$!
    client "$out/err" &
    cpid=$!
    wait "$pid"
    wait "$cpid" 2>/dev/null || true
    plain=$(cpu "$out/plain")
    live=$(tail -1 "$out/live" | awk '{ printf "%.2f", $1 + $2 }')
    ratio=$(awk -v a="$live" -v b="$plain" 'BEGIN { printf "%.4f", a / b }')
    ratios+=("$ratio")
    printf '%-16s %4d %10s %10s %8s   %s\n' "$name" "$run" "$plain" "$live" "$ratio" \
      "$(grep -o 'live view: .*' "$out/err" || echo 'live view: no account')"
  done
  median=$(printf '%s\n' "${ratios[@]}" | sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }')
  printf '%-16s median ratio %s\n' "$name" "$median"
done
