#!/usr/bin/env bash
# Submits a cuberay render to Slurm as a job array.
#
#   submit.sh --tiles N SCENE OUTPUT [render options...]
#       N tasks each render a band of the image (--tile I/N) into OUTPUT.parts/, then a
#       merge job, run only if every task succeeded, writes OUTPUT (.png or .exr; the
#       same bytes as one `cuberay render` of the whole image) and OUTPUT.parts/merged.json.
#   submit.sh --frames A..B SCENE OUTPUT [render options...]
#       one task per frame of a glTF animation, each writing its own file (OUTPUT's run of
#       `#`, or `_NNNN`, becomes the frame number).
#
# Prints the job ids (the array's, then the merge's). Render options are passed to
# `cuberay render` as they are (e.g. --width 1024 --height 768 --sampling corners).
# The cuberay binary is $CUBERAY (default: cuberay on the PATH); the jobs inherit this
# environment. Extra sbatch options (partition, account, time limit) go in $SBATCH_ARGS.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
usage() {
    sed -n '4,11p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}
(($# >= 4)) || usage
mode=$1 count=$2 scene=$(realpath -- "$3") output=$(realpath -m -- "$4")
shift 4
read -r -a extra <<<"${SBATCH_ARGS:-}"

case $mode in
    --tiles)
        [[ $count =~ ^[1-9][0-9]*$ ]] || { echo "submit.sh: --tiles needs a count, not '$count'" >&2; exit 2; }
        parts=$output.parts
        mkdir -p -- "$parts"
        rm -f -- "$parts"/part_*.exr "$parts"/part_*.json "$parts"/merged.json
        array=$(sbatch --parsable "${extra[@]}" --array="0-$((count - 1))" \
            --output="$parts/render-%a.log" "$here/render.sbatch" tiles "$parts" "$scene" "$@")
        merge=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
            --output="$parts/merge.log" "$here/merge.sbatch" "$parts" "$output")
        echo "$array $merge"
        ;;
    --frames)
        [[ $count =~ ^([0-9]+)\.\.([0-9]+)$ ]] || { echo "submit.sh: --frames needs A..B, not '$count'" >&2; exit 2; }
        logs=$(dirname -- "$output")
        mkdir -p -- "$logs"
        array=$(sbatch --parsable "${extra[@]}" --array="${BASH_REMATCH[1]}-${BASH_REMATCH[2]}" \
            --output="$logs/render-frame-%a.log" "$here/render.sbatch" frames "$output" "$scene" "$@")
        echo "$array"
        ;;
    *) usage ;;
esac
