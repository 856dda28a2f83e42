#!/usr/bin/env python3
"""Writes the fuzz targets' seeds that are not scenes of the repository already (run from
the repository root after `cargo build --release`):

- fuzz/seeds/gltf-files/{data.bin,texture.png}: the buffer and image the glTF seeds name,
  copied beside every .gltf input the gltf target reads;
- fuzz/seeds/gltf/textured_tetra.gltf: a textured, lit, camera-framed tetrahedron naming them;
- fuzz/seeds/glb/textured_tetra.glb: the same in one GLB, the image in a buffer view;
- fuzz/seeds/part_exr/*.exr and fuzz/seeds/tables/*.tables: written by cuberay itself.

The campaigns also read scenes/ and scenes/hard/ (NFF and glTF) as seeds; docs/fuzzing.md
gives the commands.
"""
import json
import os
import struct
import subprocess
import zlib

OUT = "fuzz/seeds"
for kind in ["gltf-files", "gltf", "glb", "part_exr", "tables"]:
    os.makedirs(f"{OUT}/{kind}", exist_ok=True)


def png(width, height, rgba):
    """A minimal RGBA8 PNG."""
    raw = b"".join(b"\0" + bytes(rgba[y * width * 4:(y + 1) * width * 4]) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


texture = png(2, 2, [255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128])
positions = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
normals = [(-0.577, -0.577, -0.577), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
uvs = [(0, 0), (1, 0), (0, 1), (0.5, 0.5)]
indices = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]
blob = b"".join(struct.pack("<3f", *p) for p in positions)
blob += b"".join(struct.pack("<3f", *n) for n in normals)
blob += b"".join(struct.pack("<2f", *t) for t in uvs)
blob += struct.pack("<12H", *indices)
views = [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48},
    {"buffer": 0, "byteOffset": 48, "byteLength": 48},
    {"buffer": 0, "byteOffset": 96, "byteLength": 32},
    {"buffer": 0, "byteOffset": 128, "byteLength": 24},
]
accessors = [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]},
    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
    {"bufferView": 3, "componentType": 5123, "count": 12, "type": "SCALAR"},
]


def document(buffer_uri, image):
    return {
        "asset": {"version": "2.0", "generator": "cuberay fuzz/make_seeds.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_transmission"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 20}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0, "rotation": [0, 0.38268343, 0, 0.92387953]},
            {"camera": 0, "translation": [0.4, 0.4, 3]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [2, 2, 2]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "aspectRatio": 1.0}}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "materials": [{
            "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}},
                "metallicFactor": 0.5, "roughnessFactor": 0.3},
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.2}},
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 33648, "wrapT": 33071}],
        "images": [image],
        "buffers": [{"byteLength": len(blob) if buffer_uri else len(blob) + len(texture), **({"uri": buffer_uri} if buffer_uri else {})}],
        "bufferViews": views + ([] if buffer_uri else [{"buffer": 0, "byteOffset": len(blob), "byteLength": len(texture)}]),
        "accessors": accessors,
    }


open(f"{OUT}/gltf-files/data.bin", "wb").write(blob)
open(f"{OUT}/gltf-files/texture.png", "wb").write(texture)
json.dump(document("data.bin", {"uri": "texture.png"}), open(f"{OUT}/gltf/textured_tetra.gltf", "w"), indent=1)

doc = json.dumps(document(None, {"bufferView": 4, "mimeType": "image/png"})).encode()
doc += b" " * (-len(doc) % 4)
bin_chunk = blob + texture
bin_chunk += b"\0" * (-len(bin_chunk) % 4)
glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(doc) + 8 + len(bin_chunk))
glb += struct.pack("<I4s", len(doc), b"JSON") + doc + struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk
open(f"{OUT}/glb/textured_tetra.glb", "wb").write(glb)

cuberay = "target/release/cuberay"
mirrors = "scenes/hard/parallel_mirrors.nff"
subprocess.run([cuberay, "tables", mirrors, "--width", "8", "--height", "8",
                "-o", f"{OUT}/tables/parallel_mirrors.tables"], check=True)
subprocess.run([cuberay, "render", "--backend", "cpu", "--width", "12", "--height", "8", "--tile", "1/2",
                "-o", f"{OUT}/part_exr/showcase_1of2.exr"], check=True)
subprocess.run([cuberay, "render", "--width", "12", "--height", "8", "--crop", "0,0,5,8", "--aov", "depth",
                "-o", f"{OUT}/part_exr/showcase_depth_crop.exr"], check=True)
