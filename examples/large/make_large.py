#!/usr/bin/env python3
"""Writes examples/large/large.json: one object of thousands of CSG operands.

A (2,3) torus knot covered in 4,000 smooth-unioned bubbles (one
sdfunction: spheres at seeded random places around the knot's core, blend
0.6 x their mean spacing) standing on a plate drilled with 900 holes (a slab
minus 900 cylinders, another single sdfunction), on a floor, under a
spherical light and a sky. Seeded: running it again gives the same file.

Usage: python3 examples/large/make_large.py [count] > examples/large/large.json
"""
import json
import math
import random
import sys


def frame_at(x, y, z):
    return [1, 0, 0, 0, 1, 0, 0, 0, 1, round(x, 5), round(y, 5), round(z, 5)]


def main():
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    rng = random.Random(7)
    scale, lift, tube = 0.22, 0.62, 0.09

    def knot(t):
        r = math.cos(3 * t) + 2
        return (scale * r * math.cos(2 * t), lift - scale * math.sin(3 * t),
                scale * r * math.sin(2 * t))

    # Bubbles on the surface of a tube about the knot: a point of the knot,
    # a random direction across it, radii 0.02-0.04.
    spheres = []
    for i in range(count):
        t = 2 * math.pi * rng.random()
        p, q = knot(t), knot(t + 1e-3)
        d = [b - a for a, b in zip(p, q)]
        n = math.sqrt(sum(c * c for c in d))
        d = [c / n for c in d]
        # Two unit vectors across the tangent.
        a = [d[1] * 0 - d[2] * 1, d[2] * 0 - d[0] * 0, d[0] * 1 - d[1] * 0]
        n = math.sqrt(sum(c * c for c in a))
        a = [c / n for c in a]
        b = [d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0]]
        angle = 2 * math.pi * rng.random()
        off = [tube * (math.cos(angle) * x + math.sin(angle) * y) for x, y in zip(a, b)]
        radius = 0.02 + 0.02 * rng.random()
        spheres.append((t, {"type": "sphere", "radius": round(radius, 4),
                            "world_from_local": frame_at(*[c + o for c, o in zip(p, off)])}))
    # Listed along the knot: the renderer pairs neighbours of a smooth union's
    # list into a balanced tree, and neighbours in space then prune together.
    spheres = [sphere for _, sphere in sorted(spheres, key=lambda item: item[0])]
    # Mean spacing of the bubbles: the tube's area per bubble, square-rooted.
    length = sum(math.dist(knot(2 * math.pi * i / 2000), knot(2 * math.pi * (i + 1) / 2000))
                 for i in range(2000))
    spacing = math.sqrt(2 * math.pi * tube * length / count)
    holes = 30
    plate = [{"type": "box", "whd": [1.6, 0.08, 1.6], "world_from_local": frame_at(-0.8, 0.0, -0.8)}]
    for i in range(holes * holes):
        u, v = i % holes, i // holes
        plate.append({"type": "cylinder", "height": 0.06, "radius": 0.012,
                      "world_from_local": frame_at(-0.8 + 1.6 * (u + 0.5) / holes, 0.04,
                                                   -0.8 + 1.6 * (v + 0.5) / holes)})
    eye, target = (2.2, 1.6, 2.9), (0, 0.4, 0)
    w = [e - t for e, t in zip(eye, target)]
    n = math.sqrt(sum(c * c for c in w))
    w = [c / n for c in w]
    u = [w[2], 0, -w[0]]
    n = math.sqrt(sum(c * c for c in u))
    u = [c / n for c in u]
    v = [w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2], w[0] * u[1] - w[1] * u[0]]
    scene = {
        "asset": {"version": "4.2", "generator": "examples/large/make_large.py",
                  "copyright": "implicit example: one object of thousands of operands"},
        "cameras": [{"name": "default", "frame": [round(c, 6) for c in u + v + w] + list(eye),
                     "aspect": 1.5, "lens": 0.05, "focus": 3.6}],
        "environments": [{"name": "sky", "emission": [0.22, 0.26, 0.32]}],
        "materials": [
            {"name": "floor", "color": [0.5, 0.5, 0.5]},
            {"name": "light", "emission": [40, 36, 30]},
            {"name": "knot", "type": "glossy", "color": [0.75, 0.3, 0.2], "roughness": 0.25},
            {"name": "plate", "type": "gltfpbr", "color": [0.85, 0.85, 0.88], "metallic": 1,
             "roughness": 0.3},
        ],
        "sdfunctions": [
            {"name": "floor", "type": "plane", "material": 0},
            {"name": "light", "type": "sphere", "radius": 0.25, "material": 1,
             "world_from_local": frame_at(-1.2, 2.6, 1.4)},
            {"name": "knot", "type": "smooth_union", "blend": round(0.6 * spacing, 5),
             "material": 2, "operands": spheres},
            {"name": "plate", "type": "subtraction", "material": 3, "operands": plate},
        ],
    }
    # One operand per line keeps the file small and diffable.
    lists = {}
    for function in scene["sdfunctions"]:
        if "operands" in function:
            key = "@" + function["name"]
            lists[key] = function["operands"]
            function["operands"] = key
    text = json.dumps(scene, indent=1)
    for key, operands in lists.items():
        lines = ",\n    ".join(json.dumps(o, separators=(",", ":")) for o in operands)
        text = text.replace(json.dumps(key), "[\n    " + lines + "\n   ]")
    sys.stdout.write(text + "\n")


if __name__ == "__main__":
    main()
