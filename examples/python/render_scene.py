"""Build a scene in Python, save it, render it, and refine it progressively.

    PYTHONPATH=build/release/python /usr/bin/python3 \
        examples/python/render_scene.py --resolution 360 --samples 64

Writes out/python/scene.json (ypathtrace renders it to the same image),
scene.exr (linear) and scene.png (tonemapped).
"""

import argparse
import math
import os
import sys
import time

import implicit as im
from model import make_model


def make_scene():
    scene = im.Scene()
    model = make_model().rotate(math.pi / 5).translate((0, 0.75, 0))
    scene.add(model, {"type": "glossy", "color": (0.8, 0.25, 0.1),
                      "roughness": 0.15}, name="model")
    scene.add(im.sphere(0.35, center=(-1.3, 0.35, 0.6)),
              {"type": "refractive", "color": (1, 1, 1), "ior": 1.5},
              name="glass")
    scene.add(im.torus(0.3, 0.1).translate((1.3, 0.1, 0.7)),
              {"type": "reflective", "color": (0.9, 0.8, 0.5),
               "roughness": 0.1}, name="ring")
    scene.add(im.plane(), {"color": (0.6, 0.6, 0.6)}, name="floor")
    scene.add_light(im.box((1.5, 0.05, 1.5)).translate((0, 3, 1)),
                    (12, 12, 12), name="light")
    scene.add_environment((0.15, 0.2, 0.3))
    scene.add_camera(eye=(0.8, 2.6, 6), target=(0, 0.6, 0), aspect=16 / 9,
                     name="default")
    return scene


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="out/python")
    parser.add_argument("--resolution", type=int, default=360)
    parser.add_argument("--samples", type=int, default=64)
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)

    scene = make_scene()
    path = os.path.join(args.output, "scene.json")
    scene.save(path)
    print("wrote", path)

    def progress(done, total):
        sys.stdout.write(f"\rrender {done}/{total}")
        sys.stdout.flush()

    start = time.perf_counter()
    image = im.render(scene, resolution=args.resolution,
                      samples=args.samples, progress=progress)
    print(f"\nrendered {image.shape[1]}x{image.shape[0]} in "
          f"{time.perf_counter() - start:.2f} s")
    im.save_image(os.path.join(args.output, "scene.exr"), image)
    im.save_image(os.path.join(args.output, "scene.png"), image, filmic=True)

    # Progressive: a few samples at a time, as a notebook would show them.
    renderer = im.Renderer(path, resolution=max(args.resolution // 4, 8))
    for _ in range(3):
        renderer.step(max(args.samples // 8, 1))
        print(f"progressive: {renderer.samples} samples, mean "
              f"{renderer.array[..., :3].mean():.4f}")
    print("wrote scene.exr and scene.png in", args.output)


if __name__ == "__main__":
    main()
