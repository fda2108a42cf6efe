#!/usr/bin/env python3
"""Write the example scenes' textures (procedural, made by the project):
examples/materials/textures/sky.hdr  a lat-long sky with a sun (Radiance RGBE)
examples/materials/textures/checker.tga  an 8-bit checker board (uncompressed TGA)
"""
import math
import os
import struct

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "materials", "textures")
os.makedirs(root, exist_ok=True)


def rgbe(r, g, b):
    v = max(r, g, b)
    if v < 1e-32:
        return bytes((0, 0, 0, 0))
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes((int(r * scale), int(g * scale), int(b * scale), e + 128))


def sky(u, v):
    """Radiance along lat-long (u, v): v = 0 is straight up (+y)."""
    theta, phi = v * math.pi, u * 2 * math.pi
    d = (math.cos(phi) * math.sin(theta), math.cos(theta), math.sin(phi) * math.sin(theta))
    if d[1] < 0:  # ground: dim warm grey
        return (0.12, 0.1, 0.08)
    t = d[1]
    horizon, zenith = (0.9, 0.95, 1.0), (0.25, 0.45, 0.9)
    c = [h * (1 - t) + z * t for h, z in zip(horizon, zenith)]
    sun = (math.cos(0.9) * math.cos(2.2), math.sin(0.9), math.cos(0.9) * math.sin(2.2))
    cos_sun = sum(a * b for a, b in zip(d, sun))
    if cos_sun > math.cos(0.05):
        c = [x + 120.0 for x in c]
    return tuple(c)


width, height = 256, 128
with open(os.path.join(root, "sky.hdr"), "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
    f.write(b"-Y %d +X %d\n" % (height, width))
    for j in range(height):
        for i in range(width):
            f.write(rgbe(*sky((i + 0.5) / width, (j + 0.5) / height)))

size = 64
with open(os.path.join(root, "checker.tga"), "wb") as f:
    f.write(struct.pack("<BBBHHBHHHHBB", 0, 0, 2, 0, 0, 0, 0, 0, size, size, 24, 0x20))
    for j in range(size):
        for i in range(size):
            on = ((i // 32) + (j // 32)) % 2 == 0
            f.write(bytes((200, 200, 200) if on else (60, 60, 60)))  # BGR
print("wrote", root)
