#!/usr/bin/env bash
# Coverage-guided fuzzing of the input readers with AFL++ through `cargo afl` (stable Rust).
#
#   scripts/fuzz.sh TARGET [SECONDS]   fuzz one target (pbrt, ply, png, exr, pfm, tga, bsdf, lens, gltf, jpeg, hdr) from fuzz/corpus/TARGET until
#                                      ten million executions (or SECONDS, whichever comes first); an existing run in
#                                      fuzz/out/TARGET is resumed, so repeated calls add up
#   scripts/fuzz.sh seeds              regenerate the raw seeds (scenes of the repository, generated meshes and
#                                      images) and minimise them into fuzz/corpus/*
#   scripts/fuzz.sh cmin TARGET        minimise the corpus together with the run's queue into fuzz/corpus/TARGET
#   scripts/fuzz.sh replay TARGET FILE...  run inputs through the target once, printing each reader's verdict
#   scripts/fuzz.sh stats              a Markdown table of every target's run so far (for docs/robustness.md)
#
# Installs cargo-afl from crates.io when missing (it builds AFL++ from the source it ships; needs cc and make).
# AFL++'s LLVM plugins are not built: they need nightly (-Z llvm-plugins) and an LLVM matching rustc's, so the
# harnesses are instrumented by rustc's own SanitizerCoverage (trace-pc-guard edge coverage) feeding AFL++'s
# runtime; there is no CmpLog, so each target has a dictionary of its format's keywords (fuzz/dict).
# Runs niced, one target at a time, without CPU binding (the machine is shared). Limits: 1 GiB of memory and
# 1 s per input: more is a finding. Findings land in fuzz/out/TARGET/default/{crashes,hangs}. See docs/robustness.md.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
targets="pbrt ply png exr pfm tga bsdf lens gltf jpeg hdr"
execs=${FUZZ_EXECS:-10000000}

usage() {
    sed -n '3,12p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
}

install() {
    if ! cargo afl --version >/dev/null 2>&1; then
        cargo install cargo-afl --locked --version 0.18.2
    fi
    # Builds AFL++ for the current toolchain unless already built (the first `cargo afl` use may have done it).
    cargo afl config --build >/dev/null 2>&1 || true
    (cd fuzz && nice cargo afl build --release --quiet)
}

# AFL++'s tools as cargo-afl built them for this toolchain (afl-cmin.bash: the Python afl-cmin of this AFL++
# release finds no coverage in these harnesses' traces, its shell version does).
afl_bin() {
    local ver hash
    ver=$(rustc -V | awk '{ print $2 }')
    hash=$(rustc -vV | awk '/^commit-hash/ { print substr($2, 1, 7) }')
    echo "${XDG_DATA_HOME:-$HOME/.local/share}/afl.rs/rustc-$ver-$hash/afl.rs-0.18.2/afl/bin"
}

cmin() { # INPUT_DIR OUTPUT_DIR TARGET
    AFL_PATH=$(afl_bin) nice "$(afl_bin)/afl-cmin.bash" -i "$1" -o "$2" -m 1024 -t 2000 -- "fuzz/target/release/$3" \
        >/dev/null
}

check_target() {
    case " $targets " in *" $1 "*) ;; *) echo "unknown target '$1' (one of: $targets)" >&2; exit 2 ;; esac
}

export AFL_SKIP_CPUFREQ=1 AFL_NO_AFFINITY=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
# The EXR decoder starts a thread pool per file and each thread may get its own 64 MiB glibc arena: in a long
# persistent loop under the 1 GiB address-space limit that can run out, which would explain the EXR "crashes"
# that never reproduced outside the loop (docs/robustness.md). Two arenas keep the address space small.
export MALLOC_ARENA_MAX=2

[ $# -ge 1 ] || usage
case "$1" in
seeds)
    install
    raw=fuzz/out/seeds
    rm -rf "$raw"
    mapfile -t scenes < <(find scenes crates/pbrt/tests/fixtures -name '*.pbrt' -size -8k | sort)
    fuzz/target/release/seeds "$raw" "${scenes[@]}"
    cp "${scenes[@]}" "$raw/pbrt/"
    # Real meshes and textures of the repository that are small enough to be useful seeds.
    find scenes crates -name '*.ply' -size -8k -exec cp {} "$raw/ply/" \;
    find scenes crates -name '*.png' -size -8k -exec cp {} "$raw/png/" \;
    # glTF: the committed seeds (small files of each feature the reader reads, as its tests write them).
    mkdir -p "$raw/gltf" && cp fuzz/corpus/gltf/* "$raw/gltf/"
    # JPEG (and in-memory PNG): the committed seeds, written by Pillow (baseline, progressive, grey, CMYK, restart
    # markers, odd sizes, PNGs with alpha).
    mkdir -p "$raw/jpeg" && cp fuzz/corpus/jpeg/* "$raw/jpeg/"
    # Radiance HDR: the committed seeds (flat, old and adaptive run-length, XYZE, bottom-up).
    mkdir -p "$raw/hdr" && cp fuzz/corpus/hdr/* "$raw/hdr/"
    for t in $targets; do
        rm -rf "fuzz/corpus/$t"
        cmin "$raw/$t" "fuzz/corpus/$t" "$t"
        echo "$t: $(ls "fuzz/corpus/$t" | wc -l) seeds, $(du -sh "fuzz/corpus/$t" | cut -f1)"
    done
    ;;
cmin)
    [ $# -eq 2 ] || usage
    check_target "$2"
    install
    all=fuzz/out/cmin-$2
    rm -rf "$all" && mkdir -p "$all"
    cp "fuzz/corpus/$2"/* "$all/"
    cp "fuzz/out/$2/default/queue"/id:* "$all/" 2>/dev/null || true
    rm -rf "fuzz/corpus/$2"
    cmin "$all" "fuzz/corpus/$2" "$2"
    # Names without the fuzzer's colons, which some file systems and tools dislike.
    (cd "fuzz/corpus/$2" && for f in *; do case "$f" in *:*) mv "$f" "$(echo "$f" | tr ':,' '_-')" ;; esac; done)
    echo "$2: $(ls "fuzz/corpus/$2" | wc -l) inputs, $(du -sh "fuzz/corpus/$2" | cut -f1)"
    ;;
stats)
    echo "| Target | Executions | Time | Executions/s | Edges found / instrumented | Corpus | Crashes saved | Hangs |"
    echo "|---|---|---|---|---|---|---|---|"
    for t in $targets; do
        f=fuzz/out/$t/default/fuzzer_stats
        [ -f "$f" ] || continue
        awk -F' *: *' -v t="$t" '{ v[$1] = $2 } END {
            printf "| %s | %\047d | %d min | %d | %d / %d | %d | %d | %d |\n", t, v["execs_done"], v["run_time"] / 60,
                v["execs_done"] / v["run_time"], v["edges_found"], v["total_edges"], v["corpus_count"],
                v["saved_crashes"], v["saved_hangs"] }' "$f"
    done
    ;;
replay)
    [ $# -ge 3 ] || usage
    check_target "$2"
    install
    t=$2
    shift 2
    for f in "$@"; do
        echo "== $f"
        PRISMATIC_FUZZ_VERBOSE=1 timeout 20 "fuzz/target/release/$t" <"$f" || echo "exit status $?"
    done
    ;;
*)
    check_target "$1"
    install
    t=$1
    seconds=${2:-}
    out=fuzz/out/$t
    mkdir -p "$out"
    dict=()
    [ -f "fuzz/dict/$t.dict" ] && dict=(-x "fuzz/dict/$t.dict")
    limit=(-E "$execs")
    [ -n "$seconds" ] && limit+=(-V "$seconds")
    # A previous run of this target is resumed (its queue and findings kept).
    export AFL_AUTORESUME=1
    echo "fuzzing $t: up to $execs executions${seconds:+ or $seconds s}; output in $out" >&2
    nice -n 10 cargo afl fuzz -i "fuzz/corpus/$t" -o "$out" -m 1024 -t 1000 "${dict[@]}" "${limit[@]}" \
        -- "fuzz/target/release/$t" >"$out/fuzz.log" 2>&1 || { tail -30 "$out/fuzz.log" >&2; exit 1; }
    stats=$out/default/fuzzer_stats
    for k in run_time execs_done execs_per_sec corpus_count bitmap_cvg edges_found total_edges saved_crashes saved_hangs; do
        printf '%-14s %s\n' "$k" "$(awk -F' *: *' -v k="$k" '$1 == k { print $2 }' "$stats")"
    done
    ls "$out/default/crashes" "$out/default/hangs" 2>/dev/null | grep -v README || true
    ;;
esac
