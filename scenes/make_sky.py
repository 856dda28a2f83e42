#!/usr/bin/env python3
"""Writes scenes/sky.hdr: an equirectangular environment map (512x256, Radiance RGBE) of a
clear afternoon sky over a dim ground, with a sun, for `cuberay render --env scenes/sky.hdr`.

It is analytic, so that it can live in the repository with the script that made it: a sky
whose blue deepens from a pale horizon to the zenith, a warm glow around the sun, a sun disc
of 1.5 degrees' radius 35 degrees above the horizon, and a grey-brown ground. The map follows
the convention in docs/usage.md ("The camera and the environment"): up is the top row, glTF
+X the centre column, and u = 0.75 is glTF +Z, so the sun (at u = 0.68) lights a glTF model
from its front (+Z) and a little from its side.

Run: python3 scenes/make_sky.py   (needs numpy)
"""

import math
import os

import numpy as np

W, H = 512, 256
SUN_U, SUN_ELEVATION_DEG, SUN_RADIUS_DEG = 0.68, 35.0, 1.5
SUN_RADIANCE = np.array([2600.0, 2350.0, 2000.0])  # about 20x the sky's power in all


def directions():
    """Unit directions of the texel centres, as (x front, y up, z side)."""
    u = (np.arange(W) + 0.5) / W
    v = (np.arange(H) + 0.5) / H
    phi = (u - 0.5) * 2.0 * math.pi  # u = 0.5 + atan2(z, x) / 2pi
    theta = v * math.pi  # v = acos(y) / pi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    return np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1)


def sun_direction():
    phi = (SUN_U - 0.5) * 2.0 * math.pi
    el = math.radians(SUN_ELEVATION_DEG)
    return np.array([math.cos(el) * math.cos(phi), math.sin(el), math.cos(el) * math.sin(phi)])


def radiance():
    d = directions()
    up = d[..., 1:2]
    zenith = np.array([0.18, 0.36, 0.85])
    horizon = np.array([0.85, 0.9, 1.0])
    t = np.clip(up, 0.0, 1.0) ** 0.45
    sky = horizon * (1.0 - t) + zenith * t
    cos_sun = np.clip(d @ sun_direction(), -1.0, 1.0)[..., None]
    glow = 0.9 * np.array([1.0, 0.8, 0.55]) * np.exp((cos_sun - 1.0) * 12.0)
    sky = sky + glow
    ground = np.array([0.16, 0.14, 0.11]) * (0.6 + 0.4 * np.clip(-up, 0.0, 1.0))
    img = np.where(up >= 0.0, sky, ground)
    in_sun = cos_sun >= math.cos(math.radians(SUN_RADIUS_DEG))
    return np.where(in_sun, SUN_RADIANCE, img)


def rgbe(img):
    """Radiance RGBE bytes (flat scanlines, which every reader accepts)."""
    m = img.max(axis=-1)
    out = np.zeros(img.shape[:2] + (4,), dtype=np.uint8)
    nz = m > 1e-32
    mant, exp = np.frexp(m[nz])
    scale = mant * 256.0 / m[nz]
    out[nz, :3] = np.floor(img[nz] * scale[:, None]).astype(np.uint8)
    out[nz, 3] = (exp + 128).astype(np.uint8)
    return out.tobytes()


def main():
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sky.hdr")
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {H} +X {W}\n".encode())
        f.write(rgbe(radiance()))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
