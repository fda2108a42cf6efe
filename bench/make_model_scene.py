#!/usr/bin/python3
"""Writes a scene file of one large CSG model (issue 22's build-cost measure).

The models of src/sdf/sdf_models.cpp as a scene's `operands` list, so that
the whole process (loading, building, rendering) can be timed through the
CLI:
- smooth_union: `count` spheres (radius 0.3 x the spacing) at jittered points
  of an n^3 lattice over [-1,1]^3, blended with 0.6 x the spacing;
- perforated_slab: a slab 0.2 thick minus `count` cylinders on a square grid.
`--order random` lists the operands in a seeded random order instead of
lattice order (the slab stays first in its list).

Usage: bench/make_model_scene.py smooth_union|perforated_slab COUNT
           [--order lattice|random] > scene.json
"""
import json
import math
import random
import sys


def frame_at(x, y, z):
    return [1, 0, 0, 0, 1, 0, 0, 0, 1, round(x, 6), round(y, 6), round(z, 6)]


def lookat(eye, target, up):
    z = [e - t for e, t in zip(eye, target)]
    n = math.sqrt(sum(c * c for c in z))
    z = [c / n for c in z]
    x = [up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2], up[0] * z[1] - up[1] * z[0]]
    n = math.sqrt(sum(c * c for c in x))
    x = [c / n for c in x]
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]
    return [round(c, 6) for c in x + y + z] + list(eye)


def smooth_union(count, rng):
    n = math.ceil(round(count ** (1 / 3), 9))
    spacing = 2 / n
    operands = []
    for i in range(count):
        cell = (i % n, i // n % n, i // n // n)
        at = [(c + 0.5 + 0.3 * (rng.random() - 0.5)) * spacing - 1 for c in cell]
        operands.append({"type": "sphere", "radius": round(0.3 * spacing, 6),
                         "world_from_local": frame_at(*at)})
    return {"type": "smooth_union", "blend": round(0.6 * spacing, 6)}, operands, 0


def perforated_slab(count, rng):
    n = math.ceil(round(math.sqrt(count), 9))
    spacing = 2 / n
    operands = [{"type": "box", "whd": [2, 0.2, 2], "world_from_local": frame_at(-1, -0.1, -1)}]
    for i in range(count):
        at = ((i % n + 0.5) * spacing - 1, 0, (i // n + 0.5) * spacing - 1)
        operands.append({"type": "cylinder", "height": 0.2, "radius": round(0.3 * spacing, 6),
                         "world_from_local": frame_at(*at)})
    return {"type": "subtraction"}, operands, 1


def main():
    args = sys.argv[1:]
    order = "lattice"
    if "--order" in args:
        k = args.index("--order")
        order = args[k + 1]
        del args[k:k + 2]
    if len(args) != 2 or args[0] not in ("smooth_union", "perforated_slab") or \
            order not in ("lattice", "random"):
        sys.exit(__doc__)
    rng = random.Random(7)
    model, operands, fixed = globals()[args[0]](int(args[1]), rng)
    if order == "random":
        rest = operands[fixed:]
        random.Random(11).shuffle(rest)
        operands = operands[:fixed] + rest
    model.update({"name": "model", "material": 0, "operands": "@operands"})
    scene = {
        "asset": {"version": "4.2", "generator": "bench/make_model_scene.py"},
        "cameras": [{"name": "default", "frame": lookat((1.6, 1.9, 3.2), (0, 0, 0), (0, 1, 0)),
                     "aspect": 1, "focus": 4}],
        "environments": [{"name": "sky", "emission": [1, 1, 1]}],
        "materials": [{"name": "model", "color": [0.7, 0.6, 0.5]}],
        "sdfunctions": [model],
    }
    # One operand per line keeps large files quick to write and read.
    lines = ",\n    ".join(json.dumps(o, separators=(",", ":")) for o in operands)
    text = json.dumps(scene, indent=1).replace('"@operands"', "[\n    " + lines + "\n   ]")
    sys.stdout.write(text + "\n")


if __name__ == "__main__":
    main()
