#!/usr/bin/env bash
# Renders pbrt-v4's public test scenes with pbrt-v4 and with Prismatic at equal samples per pixel and prints, per
# scene, how far apart the two images are, with the wall and CPU time of both: the table of docs/compatibility.md.
#
#   scripts/compare-pbrt.sh PBRT SCENES [options] [FILTER ...]
#
#   PBRT     the pbrt-v4 binary (built as pbrt-v4's README says)
#   SCENES   a checkout of https://github.com/mmp/pbrt-v4-scenes
#   FILTER   only scenes whose path (relative to SCENES) contains one of these strings
#
# Options:
#   --spp N            samples per pixel of each renderer in total (default 8), rendered as two seeds of N/2 each:
#                      the two halves give each pixel's noise, which the block test needs
#   --threads N        threads for both renderers (default: all cores)
#   --integrator NAME  render with this integrator instead of the scene's (both renderers read the same edited copy)
#   --filter NAME      render with this pixel filter (default parameters) instead of the scene's
#   --scale F          multiply the film's resolution by F (e.g. 0.5) in that copy, for a quicker pass
#   --out DIR          keep the images and timings in DIR (default: a temporary directory, removed at the end)
#   --reuse            with --out: do not render a scene again whose images DIR already holds (re-print the table)
#
# A scene agrees when no channel's image mean differs by more than 2% and 5 standard deviations (a mean that a few
# pixels of a small light dominate varies by per cents from seed to seed at 8 spp) and no 16×16 block's mean differs
# by more than 10% and 5 standard deviations of the difference (`prismatic compare --blocks 16`, both images' noise
# from their two seeds). At 8 spp the noise is far from Gaussian (fireflies), so a scene with off blocks is rendered again with
# seeds 3 and 4 and only blocks off in both passes count. Columns: the relative difference
# (Prismatic − pbrt-v4)/pbrt-v4 of the R, G and B means (and the largest in σ); blocks off (in both passes) of all blocks; the block
# farthest in σ (its top-left pixel, relative difference, σ; first pass); wall and CPU (user + system) seconds of
# seeds 1 and 2 together, loading included.
#
# Both renderers read an edited copy of each scene (beside the original, so that relative paths resolve) whose film
# has "bool savefp16" false: pbrt-v4 writes half floats by default, which turn values beyond 65504 into infinities
# and keep 11 significant bits. Pixels that are still not finite in either image are left out of the comparison and
# counted in the last column.
set -euo pipefail
usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 2; }
[[ $# -ge 2 ]] || usage
pbrt=$(realpath "$1")
scenes=$(realpath "$2")
shift 2
[[ -x "$pbrt" ]] || { echo "compare-pbrt: $pbrt is not an executable" >&2; exit 2; }
[[ -d "$scenes" ]] || { echo "compare-pbrt: $scenes is not a directory" >&2; exit 2; }
spp=8 threads=$(nproc) integrator='' filter='' scale='' out='' reuse=0 filters=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --spp) spp=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --integrator) integrator=$2; shift 2 ;;
    --filter) filter=$2; shift 2 ;;
    --scale) scale=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --reuse) reuse=1; shift ;;
    -h|--help) usage ;;
    -*) echo "compare-pbrt: unknown option $1" >&2; exit 2 ;;
    *) filters+=("$1"); shift ;;
  esac
done
(( spp >= 2 && spp % 2 == 0 )) || { echo "compare-pbrt: --spp must be even and at least 2" >&2; exit 2; }
half=$((spp / 2))

cd "$(dirname "$0")/.."
cargo build --release -q -p prismatic
prismatic=$(realpath target/release/prismatic)
if [[ -z "$out" ]]; then
  out=$(mktemp -d)
  trap 'rm -rf "$out"' EXIT
else
  mkdir -p "$out"
  out=$(realpath "$out")
fi

# The scene files: those that hold a WorldBegin (the others are included by them).
mapfile -t files < <(cd "$scenes" && grep -l --include='*.pbrt' -r '^[[:space:]]*WorldBegin' . | sed 's|^\./||' | sort)

# Writes the copy of scene $1 that both renderers read (beside the original, so that its relative paths still
# resolve): 32-bit float EXRs, and --integrator, --filter and --scale applied. Prints its path.
edited_copy() {
  local scene=$1
  local copy
  copy="$(dirname "$scene")/.compare-pbrt.$(basename "$scene")"
  INTEGRATOR="$integrator" FILTER="$filter" SCALE="$scale" perl -0pe '
    # A directive with its parameters, up to the next directive.
    my $params = qr/(?:\s+"[^"]*"\s*(?:\[[^\]]*\]|"[^"]*"|[-0-9.e]+))*/;
    s/^(\s*Film\s+"[^"]*")/$1 "bool savefp16" false/m;
    if ($ENV{FILTER} ne "") {
      my $new = "PixelFilter \"$ENV{FILTER}\"";
      s/^\s*PixelFilter\s+"[^"]*"$params/$new/m or s/^(\s*WorldBegin)/$new\n$1/m;
    }
    if ($ENV{INTEGRATOR} ne "") {
      # The scene integrator with its parameters (up to the next directive) becomes the requested one; maxdepth is
      # kept, as every integrator of both renderers takes it.
      my ($depth) = /^\s*Integrator\s+"[^"]*"($params)/m ? ($1 =~ /("integer maxdepth"\s*(?:\[[^\]]*\]|[0-9]+))/) : ();
      my $new = "Integrator \"$ENV{INTEGRATOR}\"" . (defined $depth ? " $depth" : "");
      s/^\s*Integrator\s+"[^"]*"$params/$new/m or s/^(\s*WorldBegin)/$new\n$1/m;
    }
    if ($ENV{SCALE} ne "") {
      s/("integer\s+[xy]resolution"\s*\[?\s*)(\d+)/$1 . int($2 * $ENV{SCALE} + 0.5)/ge;
    }
  ' "$scene" > "$copy"
  echo "$copy"
}

# Runs a command in directory $1 with its CPU and wall time appended to file $2.
timed() {
  local dir=$1 times=$2
  shift 2
  (cd "$dir" && /usr/bin/time -f '%e %U %S' -a -o "$times" "$@")
}

# Sums the wall and CPU seconds of a timing file: "wall cpu".
seconds() { awk '{w += $1; c += $2 + $3} END {printf "%.1f %.1f", w, c}' "$1"; }

printf '| scene | mean difference R / G / B | blocks off | worst block | pbrt-v4 wall / CPU s | Prismatic wall / CPU s | agree |\n'
printf '|---|---|---|---|---|---|---|\n'
agree=0 disagree=0 failed=0
for file in "${files[@]}"; do
  if [[ ${#filters[@]} -gt 0 ]]; then
    keep=0
    for f in "${filters[@]}"; do [[ "$file" == *"$f"* ]] && keep=1; done
    (( keep )) || continue
  fi
  scene="$scenes/$file"
  name=${file%.pbrt}
  tag=${name//\//_}
  copy=$(edited_copy "$scene")
  dir=$(dirname "$scene")
  have=0
  if (( reuse )); then
    have=1
    for f in pbrt-1.exr pbrt-2.exr prismatic-1.exr prismatic-2.exr pbrt-time prismatic-time; do
      [[ -f "$out/$tag.$f" ]] || have=0
    done
  fi
  (( have )) || rm -f "$out/$tag".*
  # Renders seeds $1 and $2 with both renderers (timed into $3-time files); sets status on failure.
  render_pair() {
    local seed
    for seed in "$1" "$2"; do
      timed "$dir" "$out/$tag.pbrt-$3" "$pbrt" --quiet --nthreads "$threads" --spp "$half" --seed "$seed" \
        --outfile "$out/$tag.pbrt-$seed.exr" "$(basename "$copy")" >"$out/$tag.pbrt-log" 2>&1 \
        || { status="pbrt-v4 failed"; return; }
      timed "$dir" "$out/$tag.prismatic-$3" "$prismatic" render --quiet --threads "$threads" --spp "$half" \
        --seed "$seed" -o "$out/$tag.prismatic-$seed.exr" "$(basename "$copy")" >"$out/$tag.prismatic-log" 2>&1 \
        || { status="Prismatic failed"; return; }
    done
  }
  # The off blocks of seeds $1 and $2, one "x,y" per line.
  off_blocks() {
    "$prismatic" compare "$out/$tag.prismatic-$1.exr" "$out/$tag.pbrt-$1.exr" --a2 "$out/$tag.prismatic-$2.exr" \
      --b2 "$out/$tag.pbrt-$2.exr" --blocks 16 --list-blocks | awk '/^off_block/ { print $2 }' | sort
  }
  status=ok
  (( have )) || render_pair 1 2 time
  if [[ "$status" != ok ]]; then
    rm -f "$copy"
    printf '| `%s` | | | | | | %s (%s) |\n' "$name" "$status" "$(tail -n 1 "$out/$tag".*-log | tr '|\n' '/ ' | cut -c1-120)"
    failed=$((failed + 1))
    continue
  fi
  report=$("$prismatic" compare "$out/$tag.prismatic-1.exr" "$out/$tag.pbrt-1.exr" --a2 "$out/$tag.prismatic-2.exr" \
    --b2 "$out/$tag.pbrt-2.exr" --blocks 16) || {
    rm -f "$copy"
    printf '| `%s` | | | | | | compare failed |\n' "$name"; failed=$((failed + 1)); continue; }
  read -r _ dr dg db <<<"$(grep '^channel_relative_difference' <<<"$report")"
  read -r _ zr zg zb <<<"$(grep '^channel_difference_sigmas' <<<"$report")"
  read -r _ off _ total _ <<<"$(grep '^blocks_off' <<<"$report")"
  read -r _ worst_at worst_rel worst_z <<<"$(grep '^worst_block' <<<"$report" || echo "- - - -")"
  read -r _ nonfinite_prismatic nonfinite_pbrt _ <<<"$(grep '^non_finite_pixels' <<<"$report" || echo "- 0 0 -")"
  if (( off > 0 )); then
    # The confirming pass: blocks off with seeds 1 and 2 and again with seeds 3 and 4.
    [[ $have == 1 && -f "$out/$tag.pbrt-4.exr" && -f "$out/$tag.prismatic-4.exr" ]] || render_pair 3 4 confirm-time
    if [[ "$status" == ok ]]; then
      off=$(comm -12 <(off_blocks 1 2) <(off_blocks 3 4) | wc -l)
    else
      off="$off (confirming pass: $status)"
    fi
  fi
  rm -f "$copy"
  verdict=$(awk -v r="$dr" -v g="$dg" -v b="$db" -v zr="$zr" -v zg="$zg" -v zb="$zb" -v off="${off%% *}" '
    function abs(x) { return x < 0 ? -x : x }
    function same(d, z) { return abs(d) <= 0.02 || z <= 5 }
    BEGIN { print (same(r, zr) && same(g, zg) && same(b, zb) && off == 0) ? "yes" : "no" }')
  # A pixel Prismatic writes that is not finite is a bug; pbrt-v4's are noted (they are left out of both images).
  (( nonfinite_prismatic > 0 )) && verdict="no ($nonfinite_prismatic Prismatic pixels not finite)"
  (( nonfinite_pbrt > 0 )) && verdict="$verdict ($nonfinite_pbrt pbrt-v4 pixels not finite)"
  [[ "$verdict" == yes* ]] && agree=$((agree + 1)) || disagree=$((disagree + 1))
  pct() { awk -v x="$1" 'BEGIN { printf "%+.1f%%", 100 * x }'; }
  zmax=$(awk -v a="$zr" -v b="$zg" -v c="$zb" 'BEGIN { m = a; if (b > m) m = b; if (c > m) m = c; print m }')
  printf '| `%s` | %s / %s / %s (%sσ) | %s of %s | %s %s %sσ | %s | %s | %s |\n' "$name" "$(pct "$dr")" "$(pct "$dg")" \
    "$(pct "$db")" "$zmax" "$off" "$total" "$worst_at" "$(pct "$worst_rel")" "$worst_z" \
    "$(seconds "$out/$tag.pbrt-time" | sed 's| | / |')" "$(seconds "$out/$tag.prismatic-time" | sed 's| | / |')" \
    "$verdict"
done
echo
echo "$agree agree, $disagree differ, $failed not compared ($spp spp as 2 × $half, $threads threads${integrator:+, integrator $integrator}${filter:+, filter $filter}${scale:+, resolution × $scale})"
