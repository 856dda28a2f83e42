#!/usr/bin/env bash
# Submits a cuberay render to Slurm as a job array.
#
#   submit.sh --tiles N SCENE OUTPUT [render options...]
#       On the GPU backend a first job builds the candidate tables once (`cuberay
#       tables`, into OUTPUT.parts/scene.tables). Then N tasks each render a band of the
#       image (--tile I/N, reading those tables) into OUTPUT.parts/, and a merge job, run
#       only if every task succeeded, writes OUTPUT (.png or .exr; the same bytes as one
#       `cuberay render` of the whole image) and OUTPUT.parts/merged.json.
#   submit.sh --frames A..B SCENE OUTPUT [render options...]
#       one task per frame of a glTF animation, each writing its own file (OUTPUT's run of
#       `#`, or `_NNNN`, becomes the frame number).
#
# Prints the job ids (the tables job's on the GPU backend, the array's, the merge's).
# Render options are passed to `cuberay render` as they are (e.g. --width 1024
# --height 768 --sampling corners).
# The cuberay binary is $CUBERAY (default: cuberay on the PATH); the jobs inherit this
# environment. Extra sbatch options for every job (partition, account, time limit, and a
# GPU where the cluster schedules them: --gres=gpu:1) go in $SBATCH_ARGS; options for the
# tables job alone (its build uses every CPU it gets: --cpus-per-task=8) in
# $TABLES_SBATCH_ARGS.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
usage() {
    sed -n '4,12p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}
(($# >= 4)) || usage
mode=$1
count=$2
[[ -f $3 ]] || { echo "submit.sh: no scene file '$3'" >&2; exit 2; }
scene=$(realpath -- "$3")
output=$(realpath -m -- "$4")
shift 4
# sbatch --parsable prints "id" or "id;cluster": the id is what dependencies name.
submit() {
    local out
    out=$(sbatch --parsable "$@")
    echo "${out%%;*}"
}
# Arrays are expanded as ${a[@]+"${a[@]}"}: bash before 4.4 (still on some clusters)
# calls an empty "${a[@]}" unbound under set -u.
read -r -a extra <<<"${SBATCH_ARGS:-}"
read -r -a tables_extra <<<"${TABLES_SBATCH_ARGS:-}"

case $mode in
    --tiles)
        [[ $count =~ ^[1-9][0-9]*$ ]] || { echo "submit.sh: --tiles needs a count, not '$count'" >&2; exit 2; }
        parts=$output.parts
        mkdir -p -- "$parts"
        rm -f -- "$parts"/part_*.exr "$parts"/part_*.json "$parts"/merged.json
        # On the GPU backend with tables one job builds them first and every task reads them
        # (`render --tables`); the CPU reference builds its own acceleration structure, and
        # --accel brute traces no tables.
        gpu=yes
        for ((k = 1; k <= $#; k++)); do
            a=${!k}
            n=$((k + 1))
            case $a in
                --backend=cpu | --accel=brute) gpu=no ;;
                --backend) [[ ${!n:-} == cpu ]] && gpu=no ;;
                --accel) [[ ${!n:-} == brute ]] && gpu=no ;;
            esac
        done
        tables=() after=()
        if [[ $gpu == yes ]]; then
            rm -f -- "$parts/scene.tables"
            build=$(submit ${extra[@]+"${extra[@]}"} ${tables_extra[@]+"${tables_extra[@]}"} --output="$parts/tables.log" \
                "$here/tables.sbatch" "$parts/scene.tables" "$scene" "$@")
            tables=(--tables "$parts/scene.tables")
            after=(--dependency="afterok:$build" --kill-on-invalid-dep=yes)
        fi
        array=$(submit ${extra[@]+"${extra[@]}"} ${after[@]+"${after[@]}"} --array="0-$((count - 1))" \
            --output="$parts/render-%a.log" "$here/render.sbatch" tiles "$count" "$parts" "$scene" "$@" \
            ${tables[@]+"${tables[@]}"})
        merge=$(submit ${extra[@]+"${extra[@]}"} --dependency="afterok:$array" --kill-on-invalid-dep=yes \
            --output="$parts/merge.log" "$here/merge.sbatch" "$parts" "$output")
        echo ${build:-} "$array" "$merge"
        ;;
    --frames)
        [[ $count =~ ^([0-9]+)\.\.([0-9]+)$ ]] || { echo "submit.sh: --frames needs A..B, not '$count'" >&2; exit 2; }
        logs=$(dirname -- "$output")
        mkdir -p -- "$logs"
        first=${BASH_REMATCH[1]} last=${BASH_REMATCH[2]}
        ((first <= last)) || { echo "submit.sh: --frames $count: the first frame is after the last" >&2; exit 2; }
        # Task ids count from 0 (Slurm caps them near 1000 by default), frames from FIRST.
        array=$(submit ${extra[@]+"${extra[@]}"} --array="0-$((last - first))" \
            --output="$logs/render-frame-%a.log" "$here/render.sbatch" frames "$first" "$output" "$scene" "$@")
        echo "$array"
        ;;
    *) usage ;;
esac
