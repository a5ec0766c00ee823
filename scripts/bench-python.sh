#!/usr/bin/env bash
# What rendering through the Python package costs against the command line: each benchmark scene of
# scripts/bench.sh rendered by `prismatic render` and by `prismatic.load(...).render(...).save(...)` in turn, ROUNDS
# times (interleaved, so drift in the machine's speed hits both alike), whole processes timed with /usr/bin/time.
# Prints per scene the mean CPU time (user + system) of each, their ratio, and each one's peak resident memory.
#
#   scripts/bench-python.sh                         # all of scripts/bench.sh's scenes, 3 rounds
#   ROUNDS=5 scripts/bench-python.sh cornell metals # scenes whose name contains "cornell" or "metals"
#
# Both are release builds (the wheel built with maturin --release into a virtual environment in a temporary
# directory, or the one in PRISMATIC_VENV if set, which is then reused).
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${ROUNDS:-3}
cargo build --release -q -p prismatic
bin=${CARGO_TARGET_DIR:-target}/release/prismatic
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
venv=${PRISMATIC_VENV:-$out/venv}
if [[ ! -x "$venv/bin/python" ]]; then
  python3 -m venv "$venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.5,<2" numpy
fi
(cd python && "$venv/bin/python" -m maturin build -q --release --out "$out/dist")
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$out"/dist/prismatic-*.whl
py="$venv/bin/python"

# The scenes and their fixed options, as scripts/bench.sh has them (only --spp is used there).
mapfile -t scenes < <(sed -n 's/^  "\([^|]*\)|\([^|]*\)|\(.*\)"$/\1|\2|\3/p' scripts/bench.sh)

cpu_of() { awk '{ print $2 + $3 }' "$1"; }
printf '%-18s %10s %10s %7s %10s %10s\n' scene cli_cpu_s py_cpu_s ratio cli_MB py_MB
for entry in "${scenes[@]}"; do
  IFS='|' read -r name scene extra <<<"$entry"
  if (($# > 0)); then
    wanted=0
    for pattern in "$@"; do [[ "$name" == *"$pattern"* ]] && wanted=1; done
    ((wanted)) || continue
  fi
  [[ -f "$scene" ]] || { echo "$name: $scene missing, skipped" >&2; continue; }
  spp=$(sed -n 's/.*--spp \([0-9]*\).*/\1/p' <<<"$extra")
  spp_arg=${spp:+spp=$spp}
  cli_sum=0 py_sum=0 cli_mb=0 py_mb=0
  for ((r = 0; r < rounds; r++)); do
    # shellcheck disable=SC2086
    /usr/bin/time -f '%e %U %S %M' -o "$out/cli" "$bin" render "$scene" $extra --quiet -o "$out/cli.exr"
    /usr/bin/time -f '%e %U %S %M' -o "$out/py" "$py" -c \
      "import sys, prismatic; prismatic.load(sys.argv[1]).render($spp_arg).save(sys.argv[2])" "$scene" "$out/py.exr"
    cli_sum=$(echo "$cli_sum + $(cpu_of "$out/cli")" | bc -l)
    py_sum=$(echo "$py_sum + $(cpu_of "$out/py")" | bc -l)
    cli_mb=$(awk -v m="$cli_mb" '{ v = $4 / 1000; print (v > m ? v : m) }' "$out/cli")
    py_mb=$(awk -v m="$py_mb" '{ v = $4 / 1000; print (v > m ? v : m) }' "$out/py")
  done
  printf '%-18s %10.2f %10.2f %7.3f %10.1f %10.1f\n' "$name" "$(echo "$cli_sum / $rounds" | bc -l)" \
    "$(echo "$py_sum / $rounds" | bc -l)" "$(echo "$py_sum / $cli_sum" | bc -l)" "$cli_mb" "$py_mb"
done

# What an edit between renders costs against a build with the BVH, on killeroo-simple's 66,532 triangles (medians of
# five fresh scenes, each built once and then edited once).
"$py" - crates/pbrt/tests/fixtures/killeroos/killeroo-simple.pbrt <<'PY'
import statistics, sys, time
import prismatic
builds, edits = [], []
for _ in range(5):
    scene = prismatic.load(sys.argv[1])
    builds.append(scene.render(spp=1, resolution=(32, 32)).stats["build_seconds"])
    key = [k for k in scene.materials if k != 0][0]
    start = time.perf_counter()
    scene.set_material(key, "diffuse", '"rgb reflectance" [ 0.2 0.5 0.8 ]')
    edits.append(time.perf_counter() - start)
    assert scene.builds == 1
print(f"killeroo-simple: build with the BVH {statistics.median(builds) * 1e3:.1f} ms, "
      f"set_material and rebuild {statistics.median(edits) * 1e3:.2f} ms")
PY
