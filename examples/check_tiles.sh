#!/usr/bin/env bash
# Checks that tiles merged by `cuberay merge` equal the whole render byte for byte, and that
# their counts add up (comparing the EXRs, f32 as rendered), on the seven SPD canonical scenes (the SPD procedure: corner rays,
# depth 5), on both backends. The test suite does this on the size-1 databases; this is
# the full-size check. Usage (from the repository, after `cargo build --release`):
#   bash examples/check_tiles.sh [SIZE [TILES]]      # default 256 and 3
set -euo pipefail
size=${1:-256}
tiles=${2:-3}
root=$(cd "$(dirname "$0")/.." && pwd)
cuberay=${CUBERAY:-$root/target/release/cuberay}
spd=${CUBERAY_SHARED_SCENES:-$root/../shared/scenes}/spd/nff
[[ -d $spd ]] || { echo "check_tiles.sh: the SPD scenes are not in $spd" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
counts() { python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); print(json.dumps([s["rays"], s["tests"]], sort_keys=True))' "$1"; }
status=0
for scene in balls_s4 gears_s4 mount_s6 rings_s7 teapot_s12 tetra_s6 tree_s11; do
    for backend in gpu cpu; do
        image=(--width "$size" --height "$size" --sampling corners --max-depth 5)
        opts=(--backend "$backend" "${image[@]}")
        start=$SECONDS
        "$cuberay" render "$spd/$scene.nff" "${opts[@]}" -o "$work/whole.exr" --stats json >"$work/whole.json"
        # On the GPU the tiles read tables built once, as submit.sh's jobs do.
        shared=()
        if [[ $backend == gpu ]]; then
            "$cuberay" tables "$spd/$scene.nff" "${image[@]}" -o "$work/scene.tables" 2>/dev/null
            shared=(--tables "$work/scene.tables")
        fi
        parts=()
        for ((i = 0; i < tiles; i++)); do
            "$cuberay" render "$spd/$scene.nff" "${opts[@]}" "${shared[@]}" --tile "$i/$tiles" -o "$work/part$i.exr"
            parts+=("$work/part$i.exr")
        done
        "$cuberay" merge "${parts[@]}" -o "$work/merged.exr" --stats json >"$work/merged.json"
        # The EXRs hold the f32 values as rendered: equal files, equal pixels to the last bit.
        if cmp -s "$work/whole.exr" "$work/merged.exr" && [[ "$(counts "$work/whole.json")" == "$(counts "$work/merged.json")" ]]; then
            verdict="identical, counts equal"
        else
            verdict="DIFFERENT"
            status=1
        fi
        rays=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["rays"]["total"])' "$work/whole.json")
        printf '%-11s %-3s %dx%d, %d tiles: %s (%s rays; %d s)\n' "$scene" "$backend" "$size" "$size" "$tiles" "$verdict" "$rays" $((SECONDS - start))
    done
done
exit $status
