#!/usr/bin/env python3
# implicit crosscheck: examples/sdfunction as a Cycles scene.
#
# Reads examples/sdfunction/sdfunction.json (our scene) and writes
# OUT/sdfunction.cycles.json, the description blender_render.py turns into
# meshes: every sdfunction becomes the mesh of its primitive in its own
# space (box, sphere, torus, capped cone, box frame), placed by the inverse
# of its `frame` (which maps world to local, the seed's convention), with
# the Cycles node setup of its material (see README.md for which are exact:
# the coloured rough metal of the cone is not). The noise comparison
# (noise_sdfunction.sh) renders both scenes with each renderer against its
# own reference.
#
# Python 3 standard library only.

import argparse
import json
import os

MATERIALS = {
    # ours -> Cycles, by our material type
    "matte": lambda m: {"node": "diffuse", "color": m.get("color", [0, 0, 0])},
    "glossy": lambda m: {"node": "plastic", "color": m["color"],
                         "roughness": m.get("roughness", 0.0),
                         "ior": m.get("ior", 1.5)},
    # Exact for gray (see make_scenes.py's metal); a coloured conductor
    # would need one ior per channel, so the cone uses its mean.
    "reflective": lambda m: {"node": "principled_metal", "color": m["color"],
                             "roughness": m.get("roughness", 0.0),
                             "specular": min(sum(m["color"]) / 3, 0.999) / 0.08},
}


def invert_frame(f):
    # f: 12 floats, columns x, y, z then origin; returns world_from_local
    # as a 4x4 row-major matrix.
    m = [[f[0], f[3], f[6]], [f[1], f[4], f[7]], [f[2], f[5], f[8]]]
    det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    inv = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            a = [[m[r][c] for c in range(3) if c != i] for r in range(3) if r != j]
            cof = a[0][0] * a[1][1] - a[0][1] * a[1][0]
            inv[i][j] = cof / det * (-1 if (i + j) % 2 else 1)
    o = f[9:12]
    t = [-sum(inv[r][c] * o[c] for c in range(3)) for r in range(3)]
    return [inv[0] + [t[0]], inv[1] + [t[1]], inv[2] + [t[2]], [0, 0, 0, 1]]


def material_spec(material):
    if max(material.get("emission", [0, 0, 0])) > 0:
        return {"node": "emission", "color": material["emission"]}
    return MATERIALS[material.get("type", "matte")](material)


def shape_spec(function):
    kind = function["type"]
    if kind == "box":
        return {"shape": "box", "min": [0, 0, 0], "max": function["whd"]}
    if kind == "sphere":
        return {"shape": "sphere", "radius": function["radius"]}
    if kind == "torus":
        return {"shape": "torus", "r1": function["r1"], "r2": function["r2"]}
    if kind == "capped_cone":
        return {"shape": "capped_cone", "height": function["height"],
                "r1": function["r1"], "r2": function["r2"]}
    if kind == "bbox":
        return {"shape": "box_frame", "half": function["whd"],
                "thickness": function["thickness"]}
    raise ValueError("make_sdfunction.py: no mesh for type " + kind)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", default=os.path.join(
        os.path.dirname(__file__), "../../examples/sdfunction/sdfunction.json"))
    parser.add_argument("--out", default="tools/crosscheck/out")
    parser.add_argument("--width", type=int, default=240)
    args = parser.parse_args()
    with open(args.scene) as f:
        scene = json.load(f)
    camera = scene["cameras"][0]
    aspect = camera.get("aspect", 1.5)
    objects = []
    for function in scene["sdfunctions"]:
        material = scene["materials"][function["material"]]
        spec = shape_spec(function)
        spec["name"] = function["name"]
        spec["matrix"] = invert_frame(function["frame"])
        spec["material"] = material_spec(material)
        objects.append(spec)
    desc = {
        "width": args.width, "height": round(args.width / aspect),
        "camera_frame": camera["frame"],
        "lens_mm": camera.get("lens", 0.050) * 1000,
        "sensor_mm": camera.get("film", 0.036) * 1000,
        "environment": scene["environments"][0]["emission"],
        "objects": objects,
    }
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "sdfunction.cycles.json"), "w") as f:
        json.dump(desc, f, indent=1)


main()
