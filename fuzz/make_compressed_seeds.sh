#!/usr/bin/env bash
# Writes the `compressed` fuzz target's seeds, fuzz/seeds/compressed/*.glb: the glb seed's
# textured tetrahedron (fuzz/seeds/glb/textured_tetra.glb, the project's own) as the glTF
# optimizers write it, each a kilobyte or two:
#   quantized.glb          gltfpack (KHR_mesh_quantization)
#   meshopt.glb            gltfpack -c (EXT_meshopt_compression, its fallback buffer)
#   meshopt_filters.glb    gltfpack -cc (the OCTAHEDRAL and EXPONENTIAL filters too)
#   draco.glb              gltf-transform draco (KHR_draco_mesh_compression)
#   instanced_meshopt.glb  gltfpack -mi -c of four copies of the tetrahedron (EXT_mesh_gpu_instancing)
#   webp.glb               gltf-transform webp (EXT_texture_webp)
# Needs gltfpack and @gltf-transform/cli, e.g. from `npm install --prefix target/npm
# gltfpack@1.3.0 @gltf-transform/cli@4.5.1` (.ci/setup installs them there). Run from the
# repository root.
set -euo pipefail
bin=${NPM_BIN:-target/npm/node_modules/.bin}
out=fuzz/seeds/compressed
src=fuzz/seeds/glb/textured_tetra.glb
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$bin/gltfpack" -i "$src" -o "$out/quantized.glb" >/dev/null
"$bin/gltfpack" -i "$src" -o "$out/meshopt.glb" -c >/dev/null
"$bin/gltfpack" -i "$src" -o "$out/meshopt_filters.glb" -cc >/dev/null
"$bin/gltf-transform" draco "$src" "$out/draco.glb" >/dev/null
"$bin/gltf-transform" webp "$src" "$out/webp.glb" >/dev/null
# Four nodes drawing the one mesh, which gltfpack -mi turns into one instanced node.
cp fuzz/seeds/gltf-files/data.bin fuzz/seeds/gltf-files/texture.png "$tmp/"
python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
doc = json.load(open("fuzz/seeds/gltf/textured_tetra.gltf"))
first = len(doc["nodes"])
doc["nodes"] += [{"mesh": 0, "translation": [1.5 * k, 0, 0], "scale": [1, 1 + k, 1]} for k in range(1, 4)]
doc["scenes"][0]["nodes"] += list(range(first, first + 3))
json.dump(doc, open(f"{tmp}/four.gltf", "w"))
PY
"$bin/gltfpack" -i "$tmp/four.gltf" -o "$out/instanced_meshopt.glb" -mi -c >/dev/null
ls -l "$out"
