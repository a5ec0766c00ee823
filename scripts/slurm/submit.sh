#!/usr/bin/env bash
# Render a scene on a Slurm cluster as N shards (a job array) and merge them (a dependent job).
#
#   scripts/slurm/submit.sh [OPTIONS] SCENE OUT.exr [-- RENDER_ARGS...]
#
#   --tasks N            shards, one array task each (default 4)
#   --cpus-per-task C    CPUs (and render threads) per task (default 1)
#   --parts DIR          where the parts go (default OUT's directory/OUT-parts); must be on a shared file system
#   --partition P        Slurm partition (default: the cluster's default)
#   --time T             time limit per task (sbatch --time)
#   --wait               return when the merge job has finished, with its status
#
# RENDER_ARGS go to every `prismatic render` (e.g. --spp 4096 --seed 3). PRISMATIC names the binary (default
# `prismatic` on PATH). Prints the two job ids. Other sbatch options through Slurm's SBATCH_* environment variables.
# Example: scripts/slurm/submit.sh --tasks 16 --cpus-per-task 8 scenes/diamond.pbrt /shared/diamond.exr -- --spp 65536
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)

tasks=4 cpus=1 parts= partition= time_limit= wait=0
while [ $# -gt 0 ]; do
    case "$1" in
    --tasks) tasks=$2; shift 2 ;;
    --cpus-per-task) cpus=$2; shift 2 ;;
    --parts) parts=$2; shift 2 ;;
    --partition) partition=$2; shift 2 ;;
    --time) time_limit=$2; shift 2 ;;
    --wait) wait=1; shift ;;
    -h | --help) sed -n '3,16p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --) break ;;
    -*) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
    *) break ;;
    esac
done
[ $# -ge 2 ] || { echo "usage: $0 [OPTIONS] SCENE OUT.exr [-- RENDER_ARGS...]" >&2; exit 2; }
scene=$(realpath "$1")
out=$(realpath -m "$2")
shift 2
[ "${1:-}" = -- ] && shift
case "$tasks" in '' | *[!0-9]* | 0) echo "--tasks must be a positive integer" >&2; exit 2 ;; esac
[ -f "$scene" ] || { echo "no scene file $scene" >&2; exit 1; }
parts=$(realpath -m "${parts:-${out%.*}-parts}")
mkdir -p "$parts"
rm -f "$parts"/part-*.exr "$parts"/part-*.ckpt

opts=()
[ -n "$partition" ] && opts+=(--partition "$partition")
[ -n "$time_limit" ] && opts+=(--time "$time_limit")
export PRISMATIC_SCENE=$scene PRISMATIC_PARTS=$parts PRISMATIC_OUT=$out PRISMATIC_SHARDS=$tasks
export PRISMATIC=${PRISMATIC:-prismatic}

array=$(sbatch --parsable "${opts[@]}" --array="1-$tasks" --cpus-per-task="$cpus" \
    --output="$parts/shard-%a.log" --export=ALL "$here/render-shards.sbatch" "$@")
array=${array%%;*}
merge_opts=(--dependency="afterok:$array" --kill-on-invalid-dep=yes --output="$parts/merge.log" --export=ALL)
echo "array job $array: $tasks shards of $scene into $parts"
merge=$(sbatch --parsable "${opts[@]}" "${merge_opts[@]}" "$here/merge.sbatch")
merge=${merge%%;*}
echo "merge job $merge: writes $out when every shard has finished"
[ "$wait" -eq 1 ] || exit 0
# Polled once a second (sbatch --wait backs off to several seconds between polls, which would blur timings).
while squeue -h -j "$merge" 2>/dev/null | grep -q .; do sleep 1; done
state=$(scontrol show job "$merge" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -1)
if [ "$state" != COMPLETED ]; then
    echo "the merge job ended ${state:-in an unknown state}: see $parts/*.log" >&2
    exit 1
fi
echo "merged: $out"
