#!/usr/bin/env bash
# A profile-guided release build of prismatic (optional; `cargo build --release` remains the build the README and
# the tests use). Three steps: a build that counts its branches and calls, renders of the benchmark scenes with it
# at a few samples per pixel (the profile), and the release build again, optimised with that profile. The images
# are identical to the plain release build's; the time saved is in BENCHMARKS.md ("A profile-guided build").
#
#   scripts/build-pgo.sh                 # leaves target/pgo/optimized/release/prismatic
#   PGO_DIR=/tmp/pgo scripts/build-pgo.sh
#   PGO_SKIP=killeroo scripts/build-pgo.sh   # leaves scenes whose name contains "killeroo" out of the profile
#
# Needs llvm-profdata of the LLVM version rustc was built with (`rustc -vV`); if it is missing, the script installs
# Debian's llvm-N package for it (as root, or through sudo).
set -euo pipefail
cd "$(dirname "$0")/.."

major=$(rustc -vV | sed -n 's/^LLVM version: \([0-9]*\).*/\1/p')
[[ -n "$major" ]] || { echo "build-pgo: rustc -vV names no LLVM version" >&2; exit 1; }
profdata=$(command -v "llvm-profdata-$major" || true)
if [[ -z "$profdata" ]]; then
  echo "build-pgo: installing llvm-$major for llvm-profdata-$major" >&2
  sudo=""
  [[ $(id -u) -eq 0 ]] || sudo=sudo
  $sudo apt-get update -q >&2
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "llvm-$major" >&2
  profdata=$(command -v "llvm-profdata-$major")
fi

dir=$(mkdir -p "${PGO_DIR:-target/pgo}" && cd "${PGO_DIR:-target/pgo}" && pwd)
rm -rf "$dir/profiles" "$dir/merged.profdata"
# RUSTFLAGS replaces the rustflags of .cargo/config.toml, so its target CPU is repeated here.
cpu=(-C target-cpu=x86-64-v2)

echo "build-pgo: 1/3 instrumented build" >&2
RUSTFLAGS="${cpu[*]} -C profile-generate=$dir/profiles" \
  cargo build --release -q -p prismatic --target-dir "$dir/instrumented"

echo "build-pgo: 2/3 profile renders" >&2
# The benchmark scenes (scripts/bench-scenes.sh) at a sixteenth of scripts/bench.sh's samples per pixel: every
# integrator, material family, light and medium the gallery uses.
source scripts/bench-scenes.sh
for entry in "${bench_scenes[@]}"; do
  IFS='|' read -r name scene spp <<<"$entry"
  [[ -n "${PGO_SKIP:-}" && "$name" == *"$PGO_SKIP"* ]] && continue
  spp=$(( spp / 4 > 0 ? spp / 4 : 1 ))
  "$dir/instrumented/release/prismatic" render "$scene" --spp "$spp" --quiet -o "$dir/profile-render.exr"
done
rm -f "$dir/profile-render.exr"
"$profdata" merge -o "$dir/merged.profdata" "$dir/profiles"

echo "build-pgo: 3/3 optimised build" >&2
RUSTFLAGS="${cpu[*]} -C profile-use=$dir/merged.profdata" \
  cargo build --release -q -p prismatic --target-dir "$dir/optimized"
echo "$dir/optimized/release/prismatic"
