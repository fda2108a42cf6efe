"""Model a shape as in fogleman/sdf, query it and mesh it.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/model.py

Writes out/python/model.stl, model.obj and model.vdb (a grid that scenes can
place with vol_instances).
"""

import argparse
import math
import os

import numpy as np

import implicit as im


def make_model():
    """fogleman/sdf's README example: a sphere and a box intersected, minus
    three crossing cylinders (Y is up here)."""
    f = im.sphere(1) & im.box(1.5)
    c = im.cylinder(0.5, 3)
    f -= c.orient(im.X) | c.orient(im.Y) | c.orient(im.Z)
    return f


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="out/python")
    parser.add_argument("--voxel", type=float, default=0.01)
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)

    f = make_model()
    points = np.array([[0, 0, 0], [0.75, 0, 0], [0.9, 0.9, 0.9]])
    print("distances at", points.tolist(), "=", f(points).round(4).tolist())
    print("bounds", f.bounds())

    # A smooth variant: the right operand's .k() blends.
    g = im.sphere(0.6) | im.torus(0.8, 0.15).rotate(math.pi / 4, im.X).k(0.2)
    print("smooth union at the origin", float(g([[0, 0, 0]])[0]))

    vertices, faces = f.mesh(args.voxel)
    print(f"mesh: {len(vertices)} vertices, {len(faces)} triangles, largest "
          f"|distance| at a vertex {np.abs(f(vertices)).max():.2e}")
    f.save(os.path.join(args.output, "model.stl"), voxel=args.voxel)
    f.save(os.path.join(args.output, "model.obj"), voxel=args.voxel)
    f.save_grid(os.path.join(args.output, "model.vdb"), voxel=args.voxel)
    print("wrote model.stl, model.obj and model.vdb in", args.output)


if __name__ == "__main__":
    main()
