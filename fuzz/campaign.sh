#!/usr/bin/env bash
# A fuzz campaign over every reader: each target runs for SECONDS (default 720) from the
# seeds in the repository (fuzz/seeds, scenes/) and, when ../shared/scenes is there, a few
# third-party sample files as extra seeds (copied into the ignored working corpus, never
# committed). Crashes, hangs (-timeout) and oversized allocations (-malloc_limit_mb) land in
# fuzz/artifacts/TARGET/; docs/fuzzing.md says what to do with them. Needs the nightly
# toolchain and cargo-fuzz (`cargo install cargo-fuzz`). Run from the repository root:
#   bash fuzz/campaign.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-720}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(nff gltf glb compressed part_exr tables env)
shared=../../shared/scenes/gltf
for t in "${targets[@]}"; do
    corpus=corpus/$t
    mkdir -p "$corpus"
    seeds=("seeds/$t")
    case $t in
        nff) seeds=(../scenes) ;;
        gltf)
            seeds+=(../scenes)
            [ -f "$shared/Cameras/Cameras.gltf" ] && cp "$shared/Cameras/Cameras.gltf" "$corpus/"
            ;;
        glb)
            for m in Box BoxTextured CornellBox; do
                [ -f "$shared/$m/$m.glb" ] && cp "$shared/$m/$m.glb" "$corpus/"
            done
            ;;
    esac
    echo "== $t: ${seconds}s from ${seeds[*]}" >&2
    started=$(mktemp)
    # Fork mode goes on past a finding (each is saved under artifacts/), so that one crash
    # does not end the target's run or the campaign.
    cargo +nightly fuzz run -O "$t" "$corpus" "${seeds[@]}" -- \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 -malloc_limit_mb=1024 \
        -max_len=1048576 -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 \
        2>&1 | grep -E '^(INFO: (fuzzed|exiting)|#[0-9]+|==[0-9]+== ERROR|.*crash-|.*oom-|.*timeout-)' | tail -n 20 || true
    # This run's findings only: older ones stay in artifacts/ until moved to regressions/.
    find "artifacts/$t" -type f -newer "$started" 2>/dev/null | sed "s|^|$t finding: |" >&2 || true
    rm -f "$started"
done
