"""Where a denoiser's error lies: bias against variance, edges, silhouettes.

    PYTHONPATH=build/release/python /usr/bin/python3 \
        bench/denoise_error_split.py SCENE.json REFERENCE.exr \
        [--resolution 128] [--samples 64] [--seeds 8] [--denoiser nlm]

Renders the scene with `seeds` seeds, denoises each render, and splits the
relative MSE against the reference (bench_denoise writes one:
denoise_bench/NAME_reference_RES_16384.exr) per pixel into the squared bias
of the renders' mean and their variance. Then by pixel class:
- edge: the reference's 3x3 range of luminance above 10% of its level + 0.1;
- silhouette: the camera depth differs from a 4-neighbour's by over 10%
  (a pixel that mixes two surfaces), with the error left if those pixels
  were exact (an upper bound of what handling them better can give).
"""

import argparse
import warnings

import numpy as np

import implicit as im


def rel_error(x, reference):
    return ((x - reference) ** 2 / (reference ** 2 + 0.01)).mean(axis=-1)


def neighbours(a):
    """The 3x3 neighbourhood of each pixel (edges repeated), stacked."""
    h, w = a.shape
    pad = np.pad(a, 1, mode="edge")
    return np.array([pad[dy:dy + h, dx:dx + w]
                     for dy in range(3) for dx in range(3)])


def silhouettes(depth):
    """Whether a 4-neighbour's depth differs by over 10% of the nearer."""
    around = neighbours(depth)[[1, 3, 5, 7]]
    near = np.maximum(np.minimum(around, depth), 1e-3)
    return (np.abs(around - depth) > 0.1 * near).any(axis=0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scene")
    parser.add_argument("reference")
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--denoiser", default="nlm")
    args = parser.parse_args()
    if args.seeds < 2:
        parser.error("--seeds must be at least 2")
    warnings.simplefilter("ignore")  # the seed scenes' missing textures
    reference = im.load_image(args.reference)[..., :3].astype(np.float64)
    images, depth = [], None
    for seed in range(args.seeds):
        out = im.render(args.scene, resolution=args.resolution,
                        samples=args.samples, seed=seed + 11, denoise=True,
                        denoiser=args.denoiser, aov=["depth"])
        images.append(out["image"][..., :3].astype(np.float64))
        if depth is None:
            depth = np.asarray(out["depth"], np.float64)
            depth = depth[..., 0] if depth.ndim == 3 else depth
    if images[0].shape != reference.shape:
        parser.error("the reference is %s, the renders %s" %
                     (reference.shape, images[0].shape))
    images = np.array(images)
    error = np.mean([rel_error(x, reference) for x in images], axis=0)
    mean = images.mean(axis=0)
    # The renders' mean still holds 1/seeds of their variance.
    spread = np.mean([rel_error(x, mean) for x in images], axis=0)
    variance = spread * args.seeds / (args.seeds - 1)
    bias = np.maximum(rel_error(mean, reference) - variance / args.seeds, 0)
    luminance = reference.mean(axis=-1)
    around = neighbours(luminance)
    edge = (around.max(0) - around.min(0)) / (luminance + 0.1) > 0.1
    mixed = silhouettes(depth)
    total = error.sum()
    print("%s: relMSE %.5f = bias^2 %.5f + variance %.5f (%d seeds)" %
          (args.scene, error.mean(), bias.mean(), variance.mean(),
           args.seeds))
    for name, where in (("edge", edge), ("flat", ~edge),
                        ("silhouette", mixed)):
        print("  %-10s %5.1f%% of pixels, %3.0f%% of the error: bias^2 %.5f "
              "variance %.5f" %
              (name, 100 * where.mean(), 100 * error[where].sum() / total,
               bias[where].sum() / error.size,
               variance[where].sum() / error.size))
    print("  silhouettes exact: relMSE %.5f (%.2fx lower)" %
          (error[~mixed].sum() / error.size,
           total / max(error[~mixed].sum(), 1e-30)))


if __name__ == "__main__":
    main()
