#!/usr/bin/env bash
# Checks that a change leaves every image bit for bit as it was: renders the gallery scenes, the benchmark scenes
# and the real scenes of crates/pbrt/tests/fixtures with two prismatic binaries, each scene with the integrator it
# names and again with every integrator (and path/volpath without dispersion splitting), small and at a few samples
# per pixel, with AOVs, and compares the EXRs value by value (`prismatic compare`).
#
#   scripts/images-identical.sh OLD_BINARY NEW_BINARY          # every scene, every integrator
#   scripts/images-identical.sh OLD NEW prism                  # only scenes whose path contains "prism"
#   SPP=4 RES=64x48 scripts/images-identical.sh OLD NEW        # more samples, a larger image
#
# Prints one line per render that differs or fails and a closing count; exits 1 if any image differs. A binary of
# an older commit: `git worktree add /tmp/old COMMIT && cargo build --release --manifest-path /tmp/old/Cargo.toml
# -p prismatic`.
set -euo pipefail
cd "$(dirname "$0")/.."
[[ $# -ge 2 ]] || { sed -n '2,13p' "$0" >&2; exit 2; }
a=$(realpath "$1")
b=$(realpath "$2")
filter=${3:-}
spp=${SPP:-2}
res=${RES:-40x30}
out=$(mktemp -d)
tmp_scenes=()
cleanup() { rm -rf "$out"; rm -f "${tmp_scenes[@]}"; }
trap cleanup EXIT

integrators=(
  ""
  'Integrator "path" "integer maxdepth" 8'
  'Integrator "path" "integer maxdepth" 8 "bool splitdispersion" false'
  'Integrator "path" "integer maxdepth" 8 "bool manifoldnee" true'
  'Integrator "volpath" "integer maxdepth" 8'
  'Integrator "volpath" "integer maxdepth" 8 "bool splitdispersion" false'
  'Integrator "lightpath" "integer maxdepth" 8'
  'Integrator "bdpt" "integer maxdepth" 6'
  'Integrator "sppm" "integer maxdepth" 6 "integer photonsperiteration" 4000 "float radius" 0.05'
)

same=0
differ=0
for scene in scenes/*.pbrt scenes/bench/*.pbrt crates/pbrt/tests/fixtures/*/*.pbrt; do
  [[ -n "$filter" && "$scene" != *"$filter"* ]] && continue
  for k in "${!integrators[@]}"; do
    line=${integrators[$k]}
    file=$scene
    if [[ -n "$line" ]]; then
      # A copy beside the scene (its includes are relative to it) whose last Integrator directive, just before
      # WorldBegin, is the one to test: a later directive replaces an earlier one.
      file="$(dirname "$scene")/.identical-$k-$(basename "$scene")"
      tmp_scenes+=("$file")
      awk -v line="$line" '/^WorldBegin/ && !done { print line; done = 1 } { print }' "$scene" >"$file"
    fi
    name="$scene [${line:-as written}]"
    ok=1
    for who in A B; do
      bin=$a && [[ $who == B ]] && bin=$b
      if ! "$bin" render "$file" --spp "$spp" --resolution "$res" --aovs --quiet -o "$out/$who.exr" \
        >/dev/null 2>"$out/err-$who"; then
        ok=0
      fi
    done
    if [[ $ok == 0 ]]; then
      # Both failing the same way (e.g. an orthographic camera for a light tracer) is the same result.
      if [[ ! -s "$out/err-A" ]] || ! diff -q <(sed 's/\.identical-[0-9]*-//' "$out/err-A") \
        <(sed 's/\.identical-[0-9]*-//' "$out/err-B") >/dev/null; then
        echo "FAILED: $name"
        cat "$out/err-A" "$out/err-B" | head -5
        differ=$((differ + 1))
      else
        same=$((same + 1))
      fi
      continue
    fi
    # Every channel (colour, spectral buckets, AOVs) and every attribute must agree: the header's attributes as a
    # set (their order in the file may differ from build to build), everything after the header byte for byte.
    if python3 - "$out/A.exr" "$out/B.exr" <<'PY'
import struct, sys

def split(path):
    data = open(path, 'rb').read()
    at, attributes = 8, []
    while data[at] != 0:
        name_end = data.index(0, at)
        type_end = data.index(0, name_end + 1)
        (size,) = struct.unpack_from('<i', data, type_end + 1)
        attributes.append(data[at:type_end + 5 + size])
        at = type_end + 5 + size
    return sorted(attributes), data[at:]

sys.exit(0 if split(sys.argv[1]) == split(sys.argv[2]) else 1)
PY
    then
      same=$((same + 1))
    else
      rel=$("$b" compare "$out/A.exr" "$out/B.exr" 2>/dev/null | awk '/^relative_rmse/ {print $2}')
      echo "DIFFERS: $name (relative RMSE ${rel:-?})"
      differ=$((differ + 1))
    fi
  done
done
echo "identical: $same, differing or failing: $differ"
[[ $differ == 0 ]]
