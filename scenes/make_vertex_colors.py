#!/usr/bin/env python3
"""Writes scenes/vertex_colors.gltf: a quad tinted by glTF vertex colours (COLOR_0).

A white, rough, non-metallic quad in the plane z = 0 faces the camera on +Z. Its corners
carry red (-1, -1), green (1, -1), blue (1, 1) and white (-1, 1) as normalised unsigned
bytes (VEC4, alpha 255), so the colour varies across each of its two triangles. A
directional light shines straight down -Z: every point of the quad gets the same light,
and its pixels' colours are the interpolated vertex colours times one number.
Run from the repository root:
    python3 scenes/make_vertex_colors.py
"""
import json

from gltfkit import Blob

blob = Blob()
add = blob.add


corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
rgba = [(255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255, 255, 255, 255)]
position = add([c for x, y in corners for c in (x, y, 0.0)], "f", 4, "VEC3",
               minmax=([-1, -1, 0], [1, 1, 0]))
normal = add([0.0, 0.0, 1.0] * 4, "f", 4, "VEC3")
color = add([c for v in rgba for c in v], "B", 4, "VEC4", comp=5121, normalized=True)
indices = add([0, 1, 2, 0, 2, 3], "H", 6, "SCALAR", comp=5123)

doc = {
    "asset": {"version": "2.0", "generator": "scenes/make_vertex_colors.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "color": [1, 1, 1], "intensity": 0.8}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [
        {"name": "quad", "mesh": 0},
        {"name": "camera", "camera": 0, "translation": [0, 0, 3]},
        {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01, "aspectRatio": 1.0}}],
    "meshes": [{"primitives": [{
        "attributes": {"POSITION": position, "NORMAL": normal, "COLOR_0": color},
        "indices": indices, "material": 0}]}],
    "materials": [{"name": "white", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
    **blob.json(),
}
with open("scenes/vertex_colors.gltf", "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
