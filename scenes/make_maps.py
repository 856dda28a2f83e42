#!/usr/bin/env python3
"""Writes the glTF scenes that test per-hit maps (tests/it/gpu/closed_forms.rs):

- scenes/alpha_mask.gltf: a red-glowing quad cut out by an alpha-masked 4x4 checker
  (nearest filtering, alphaCutoff 0.5) in front of a blue-glowing, lit white wall, seen
  straight on by an orthographic camera: the wall shows through exactly the clear texels.
- scenes/metal_half.gltf: a floor whose metallic-roughness texture is smooth metal on its
  left half (x < 0) and rough dielectric on its right, below a light and in front of a
  green-glowing card: the card is mirrored on the metal half only.
- scenes/normal_tilt.gltf: a grey, half-rough dielectric quad whose one-texel normal map
  tilts every normal towards +x and up the image (+y), close to the half-way vector of a
  directional light from (1, 1, 1) and a viewer on +z: each pixel is the closed form's
  diffuse and Phong highlight for the tilted normal n' (a flat normal would show no
  highlight). Its left half carries a TANGENT attribute, its right half none (tangents from
  MikkTSpace), and both must agree on which way +y is.

Run from the repository root:
    python3 scenes/make_maps.py
"""
import json

from gltfkit import Blob, png


class Doc:
    """A glTF document of quads: its buffer (gltfkit.Blob) and meshes."""

    def __init__(self, generator):
        self.blob = Blob()
        self.meshes = []
        self.generator = generator

    def add(self, *args, **kw):
        return self.blob.add(*args, **kw)

    def quad(self, corners, normal, uvs, material, tangent=None):
        """A mesh of one quad (corners counter-clockwise seen from `normal`); its index."""
        lo = [min(c[k] for c in corners) for k in range(3)]
        hi = [max(c[k] for c in corners) for k in range(3)]
        attrs = {
            "POSITION": self.add([x for c in corners for x in c], "f", 4, "VEC3", minmax=(lo, hi)),
            "NORMAL": self.add(list(normal) * 4, "f", 4, "VEC3"),
            "TEXCOORD_0": self.add([x for uv in uvs for x in uv], "f", 4, "VEC2"),
        }
        if tangent:
            attrs["TANGENT"] = self.add(list(tangent) * 4, "f", 4, "VEC4")
        indices = self.add([0, 1, 2, 0, 2, 3], "H", 6, "SCALAR", comp=5123)
        self.meshes.append({"primitives": [{"attributes": attrs, "indices": indices, "material": material}]})
        return len(self.meshes) - 1

    def write(self, path, rest):
        doc = {"asset": {"version": "2.0", "generator": self.generator}, "scene": 0, **rest,
                "meshes": self.meshes, **self.blob.json()}
        with open(path, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")


NEAREST = {"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}
ORTHO = {"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.01, "zfar": 100.0}}
SUN = {"KHR_lights_punctual": {"lights": [{"type": "directional", "color": [1, 1, 1], "intensity": 1.0}]}}


def sun_node(rotation):
    return {"name": "sun", "rotation": rotation, "extensions": {"KHR_lights_punctual": {"light": 0}}}


# The quad's UVs: (0, 0) at its top-left corner (-1, 1), v downwards as in glTF.
QUAD = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
QUAD_UV = [(0, 1), (1, 1), (1, 0), (0, 0)]

# alpha_mask.gltf
d = Doc("scenes/make_maps.py")
checker = [[(255, 255, 255, 255 if (i + j) % 2 == 0 else 0) for i in range(4)] for j in range(4)]
d.quad(QUAD, (0, 0, 1), QUAD_UV, 0)
d.quad([(-3, -3, -1), (3, -3, -1), (3, 3, -1), (-3, 3, -1)], (0, 0, 1), QUAD_UV, 1)
# The sun shines down -z turned 20° about y (half-angle 10°), so that the checker's shadow falls on the wall
# beside the holes.
d.write("scenes/alpha_mask.gltf", {
    "extensionsUsed": ["KHR_lights_punctual"], "extensions": SUN,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [{"name": "checker", "mesh": 0}, {"name": "wall", "mesh": 1},
              {"name": "camera", "camera": 0, "translation": [0, 0, 3]}, sun_node([0, 0.17364817766693033, 0, 0.984807753012208])],
    "cameras": [ORTHO],
    "images": [{"uri": png(4, 4, checker)}], "samplers": [NEAREST], "textures": [{"source": 0, "sampler": 0}],
    "materials": [
        {"name": "checker", "alphaMode": "MASK", "alphaCutoff": 0.5, "emissiveFactor": [1, 0, 0],
         "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "baseColorTexture": {"index": 0},
                                  "metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "wall", "emissiveFactor": [0, 0, 0.5],
         "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0,
                                  "roughnessFactor": 1.0}},
    ],
})

# metal_half.gltf
d = Doc("scenes/make_maps.py")
mr = [[(0, 0, 255, 255), (0, 255, 0, 255)]]
d.quad([(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)], (0, 1, 0), [(0, 1), (1, 1), (1, 0), (0, 0)], 0)
d.quad([(-2, 0.2, -2.5), (2, 0.2, -2.5), (2, 1.5, -2.5), (-2, 1.5, -2.5)], (0, 0, 1), QUAD_UV, 1)
# The sun shines straight down (-y): a quarter turn about x turns -z to -y.
d.write("scenes/metal_half.gltf", {
    "extensionsUsed": ["KHR_lights_punctual"], "extensions": SUN,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [{"name": "floor", "mesh": 0}, {"name": "card", "mesh": 1},
              {"name": "camera", "camera": 0, "translation": [0, 1.2, 3], "rotation": [-0.17, 0, 0, 0.9854]},
              sun_node([-0.7071067811865476, 0, 0, 0.7071067811865476])],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01, "aspectRatio": 1.0}}],
    "images": [{"uri": png(2, 1, mr)}], "samplers": [NEAREST], "textures": [{"source": 0, "sampler": 0}],
    "materials": [
        {"name": "half metal", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                        "metallicRoughnessTexture": {"index": 0}}},
        {"name": "green glow", "emissiveFactor": [0, 1, 0],
         "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
    ],
})

# normal_tilt.gltf
d = Doc("scenes/make_maps.py")
d.quad([(-1, -1, 0), (0, -1, 0), (0, 1, 0), (-1, 1, 0)], (0, 0, 1), [(0, 1), (0.5, 1), (0.5, 0), (0, 0)], 0,
       tangent=(1, 0, 0, 1))
d.quad([(0, -1, 0), (1, -1, 0), (1, 1, 0), (0, 1, 0)], (0, 0, 1), [(0.5, 1), (1, 1), (1, 0), (0.5, 0)], 0)
# The sun shines along (-1, -1, -1)/√3: a turn about (-1, 1, 0) takes -z there.
d.write("scenes/normal_tilt.gltf", {
    "extensionsUsed": ["KHR_lights_punctual"], "extensions": SUN,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [{"name": "left, TANGENT", "mesh": 0}, {"name": "right, MikkTSpace", "mesh": 1},
              {"name": "camera", "camera": 0, "translation": [0, 0, 3]},
              sun_node([-0.3250575836718681, 0.3250575836718681, 0.0, 0.8880738339771153])],
    "cameras": [ORTHO],
    "images": [{"uri": png(1, 1, [[(169, 169, 241, 255)]])}], "samplers": [NEAREST],
    "textures": [{"source": 0, "sampler": 0}],
    "materials": [{"name": "tilted", "normalTexture": {"index": 0},
                   "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0,
                                            "roughnessFactor": 0.4}}],
})
