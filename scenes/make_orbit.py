#!/usr/bin/env python3
"""Writes scenes/orbit.gltf: a small animated glTF scene for `cuberay render --frames`.

A floor, three boxes (one metallic, so reflection rays are traced) and a point light. The
camera sits on a rig node that turns once about +Y in 4 s (LINEAR rotation keyframes every
90 degrees); the camera itself dollies in and out along its rig (CUBICSPLINE translation),
and the red box turns in steps (STEP rotation). Run from the repository root:
    python3 scenes/make_orbit.py
"""
import json
import math

from gltfkit import Blob

blob = Blob()
add = blob.add


def box_mesh(material):
    """A unit cube centred on the origin, 24 vertices (flat normals), 12 triangles."""
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]
            n[axis] = sign
            u, v = [a for a in range(3) if a != axis]
            base = len(pos) // 3
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis] = 0.5 * sign
                p[u] = 0.5 * du
                p[v] = 0.5 * dv
                pos += p
                nrm += n
            # Counter-clockwise seen from outside.
            quad = [0, 1, 2, 0, 2, 3]
            if (sign > 0) != ((axis == 1)):
                quad = [0, 2, 1, 0, 3, 2]
            idx += [base + q for q in quad]
    return mesh(pos, nrm, idx, material)


def mesh(pos, nrm, idx, material):
    n = len(pos) // 3
    lo = [min(pos[i::3]) for i in range(3)]
    hi = [max(pos[i::3]) for i in range(3)]
    p = add(pos, "f", n, "VEC3", target=34962, minmax=(lo, hi))
    q = add(nrm, "f", n, "VEC3", target=34962)
    i = add(idx, "H", len(idx), "SCALAR", comp=5123, target=34963)
    return {"primitives": [{"attributes": {"POSITION": p, "NORMAL": q}, "indices": i, "material": material}]}


def quat_y(deg):
    a = math.radians(deg) / 2
    return [0.0, math.sin(a), 0.0, math.cos(a)]


materials = [
    {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.75, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    {"name": "mirror", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1], "metallicFactor": 1, "roughnessFactor": 0}},
    {"name": "blue", "pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.2, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}},
]
floor = mesh([-8, 0, -8, 8, 0, -8, 8, 0, 8, -8, 0, 8], [0, 1, 0] * 4, [0, 2, 1, 0, 3, 2], 0)
meshes = [floor, box_mesh(1), box_mesh(2), box_mesh(3)]

# Keyframes: the rig turns 360 degrees in 4 s, the camera dollies, the red box steps.
rig_t = add([0.0, 1.0, 2.0, 3.0, 4.0], "f", 5, "SCALAR", minmax=([0.0], [4.0]))
rig_r = add(sum((quat_y(d) for d in (0, 90, 180, 270, 360)), []), "f", 5, "VEC4")
dolly_t = add([0.0, 2.0, 4.0], "f", 3, "SCALAR", minmax=([0.0], [4.0]))
# CUBICSPLINE: in-tangent, value, out-tangent per keyframe.
dolly = [0, 0, 0, 0, 1.5, 6.0, 0, 0, 0,
         0, 0, 0, 0, 1.2, 4.5, 0, 0, 0,
         0, 0, 0, 0, 1.5, 6.0, 0, 0, 0]
dolly_v = add(dolly, "f", 9, "VEC3")
step_t = add([0.0, 1.0, 2.0, 3.0], "f", 4, "SCALAR", minmax=([0.0], [3.0]))
step_r = add(sum((quat_y(d) for d in (0, 30, 60, 90)), []), "f", 4, "VEC4")

pitch = math.atan2(1.5, 6.0)
cam_rot = [-math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
nodes = [
    {"name": "floor", "mesh": 0},
    {"name": "red box", "mesh": 1, "translation": [-1.2, 0.5, 0.3], "rotation": quat_y(0)},
    {"name": "mirror box", "mesh": 2, "translation": [1.0, 0.75, -0.5], "scale": [1.5, 1.5, 1.5]},
    {"name": "blue box", "mesh": 3, "translation": [0.2, 0.35, 1.4], "scale": [0.7, 0.7, 0.7]},
    {"name": "light", "translation": [2.0, 5.0, 3.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "rig", "children": [6], "rotation": quat_y(0)},
    {"name": "camera", "camera": 0, "translation": [0.0, 1.5, 6.0], "rotation": cam_rot},
]
gltf = {
    "asset": {"version": "2.0", "generator": "cuberay scenes/make_orbit.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 25}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
    "nodes": nodes,
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 1.333}}],
    "meshes": meshes,
    "materials": materials,
    "animations": [{
        "name": "orbit",
        "samplers": [
            {"input": rig_t, "output": rig_r, "interpolation": "LINEAR"},
            {"input": dolly_t, "output": dolly_v, "interpolation": "CUBICSPLINE"},
            {"input": step_t, "output": step_r, "interpolation": "STEP"},
        ],
        "channels": [
            {"sampler": 0, "target": {"node": 5, "path": "rotation"}},
            {"sampler": 1, "target": {"node": 6, "path": "translation"}},
            {"sampler": 2, "target": {"node": 1, "path": "rotation"}},
        ],
    }],
    **blob.json(),
}
with open("scenes/orbit.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
