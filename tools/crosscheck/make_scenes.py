#!/usr/bin/env python3
# implicit crosscheck: scene generator.
#
# One scene, one sphere per material case, written twice from the same
# numbers:
#   <case>.json         our scene (analytic sphere, thin boxes)
#   <case>.cycles.json  the description blender_render.py turns into a Cycles
#                       scene (tessellated sphere, box mesh floor, emissive
#                       quad, Cycles shader nodes)
# and the region mask shared by all cases:
#   regions.pgm         8-bit PGM, 0 = not counted, k = region k
#   regions.txt         region names, line k-1 = region k
#
# The mask is computed here by casting rays with our camera model
# (eval_camera in src/scene/scene.cpp) at each pixel's centre and 4 corners;
# a pixel counts only when all 5 agree, so anti-aliased edges (where a
# tessellated silhouette could differ) are left out.
#
# Coordinates are ours (y up). Blender is z up: blender_render.py applies
# the rotation (x, y, z) -> (x, -z, y) to every object and the camera.
#
# Python 3 standard library only.

import argparse
import json
import math
import os
import struct

# -----------------------------------------------------------------------------
# SCENE NUMBERS (ours: metres, y up)
# -----------------------------------------------------------------------------

WIDTH, HEIGHT = 200, 150
CAMERA_FROM = (0.0, 1.0, 4.5)
CAMERA_TO = (0.0, 0.45, 0.0)
LENS, FILM = 0.050, 0.036  # 50 mm lens, 36 mm film along the width

SPHERE_CENTER = (0.0, 0.5, 0.0)
SPHERE_RADIUS = 0.5

FLOOR_HALF = 20.0  # floor: box [-20, 20] x [-0.02, 0] x [-20, 20]
FLOOR_THICKNESS = 0.02
FLOOR_COLOR = [0.6, 0.55, 0.5]

LIGHT_MIN = (1.0, 2.5, -2.0)  # emissive rectangle y = 2.5, x in [1, 2], z in [-2, -1]
LIGHT_SIZE = (1.0, 1.0)
LIGHT_EMISSION = [32.0, 30.0, 28.0]
ENVIRONMENT = [0.4, 0.45, 0.5]

# Material cases. `ours` is our material; `cycles` names the node setup of
# blender_render.py and its parameters.
MATTE_COLOR = [0.7, 0.3, 0.2]
METAL_GRAY = 0.8
PLASTIC_COLOR = [0.2, 0.4, 0.7]
CASES = {
    "matte": {
        "ours": {"type": "matte", "color": MATTE_COLOR},
        "cycles": {"node": "diffuse", "color": MATTE_COLOR},
    },
    "emission": {
        "ours": {"type": "matte", "color": [0, 0, 0], "emission": [2.0, 1.5, 1.0]},
        "cycles": {"node": "emission", "color": [2.0, 1.5, 1.0]},
    },
    # Our conductor Fresnel is the dielectric Fresnel of
    # eta = reflectivity_to_eta(color) at the half vector. Cycles' Principled
    # metallic Fresnel is cspec0 + (1 - cspec0) * FH with
    # FH = (F(ior) - F0(ior)) / (1 - F0(ior)) and ior from `specular`:
    # with cspec0 = gray and specular = gray / 0.08 the ior equals our eta,
    # F0(ior) = gray, and the two Fresnel terms are identical.
    "metal": {
        "ours": {"type": "reflective", "color": [METAL_GRAY] * 3, "roughness": 0.5},
        "cycles": {"node": "principled_metal", "color": [METAL_GRAY] * 3,
                   "specular": METAL_GRAY / 0.08, "roughness": 0.5},
    },
    # The same metal against Cycles' Glossy BSDF, which has no Fresnel term
    # (constant reflectance = color): a model difference, shown for scale.
    "metal_glossybsdf": {
        "ours": {"type": "reflective", "color": [METAL_GRAY] * 3, "roughness": 0.5},
        "cycles": {"node": "glossy", "color": [METAL_GRAY] * 3, "roughness": 0.5},
    },
    "glass": {
        "ours": {"type": "refractive", "color": [1, 1, 1], "roughness": 0, "ior": 1.5},
        "cycles": {"node": "glass", "color": [1, 1, 1], "ior": 1.5},
    },
    # Ours: color (1 - F(n.o)) / pi * cos + F(h.i) * GGX, ior 1.5. Cycles:
    # Mix(fac = Fresnel(1.5)) of Diffuse(color) and nothing, i.e.
    # (1 - F(n.o)) * Diffuse, plus a Principled BSDF with black base color
    # and specular 0.5 (F0 0.04, ior 1.5), whose Fresnel is then exactly the
    # dielectric F(h.i).
    "plastic": {
        "ours": {"type": "glossy", "color": PLASTIC_COLOR, "roughness": 0.3, "ior": 1.5},
        "cycles": {"node": "plastic", "color": PLASTIC_COLOR, "roughness": 0.3,
                   "ior": 1.5},
    },
}


# Media: our refractive, subsurface and volumetric materials fill the object
# with extinction sigma_t = -log(color) / trdepth and scattering albedo
# `scattering` (make_material_point in src/trace/shading.h); Cycles gets the
# same coefficients as sigma_a = (1 - albedo) sigma_t (Volume Absorption) and
# sigma_s = albedo sigma_t (Volume Scatter, Henyey-Greenstein).
def medium(color, trdepth, albedo=(0.0, 0.0, 0.0), anisotropy=0.0):
    sigma_t = [-math.log(min(max(c, 1e-4), 1.0)) / trdepth for c in color]
    return {"absorption": [t * (1 - a) for t, a in zip(sigma_t, albedo)],
            "scattering": [t * a for t, a in zip(sigma_t, albedo)],
            "anisotropy": anisotropy}


TINT = [0.5, 0.7, 0.9]
SSS_COLOR, SSS_ALBEDO = [0.6, 0.7, 0.8], [0.9, 0.8, 0.7]
VOL_COLOR, VOL_ALBEDO = [0.5, 0.6, 0.7], [0.8, 0.9, 0.95]
THIN_COLOR = [0.6, 0.9, 0.6]
CASES.update({
    # Delta conductor: the same exact Fresnel match as "metal".
    "mirror": {
        "ours": {"type": "reflective", "color": [METAL_GRAY] * 3, "roughness": 0},
        "cycles": {"node": "principled_metal", "color": [METAL_GRAY] * 3,
                   "specular": METAL_GRAY / 0.08, "roughness": 0.0},
    },
    # Delta dielectric filled with an absorbing medium.
    "glass_tinted": {
        "ours": {"type": "refractive", "color": TINT, "roughness": 0, "ior": 1.5,
                 "trdepth": 0.5},
        "cycles": {"node": "glass", "color": [1, 1, 1], "ior": 1.5,
                   "volume": medium(TINT, 0.5)},
    },
    # Thin sheet: Cycles Mix(Fresnel) of Transparent(color) and a sharp
    # mirror, with the Fresnel IOR kept at 1.5 on back faces as ours is.
    "transparent": {
        "ours": {"type": "transparent", "color": THIN_COLOR, "roughness": 0,
                 "ior": 1.5},
        "cycles": {"node": "thin_dielectric", "color": THIN_COLOR, "ior": 1.5},
    },
    # Index-matched boundary around a scattering medium (HG g = 0.5).
    "volumetric": {
        "ours": {"type": "volumetric", "color": VOL_COLOR, "trdepth": 0.4,
                 "scattering": VOL_ALBEDO, "scanisotropy": 0.5},
        "cycles": {"node": "none", "volume": medium(VOL_COLOR, 0.4, VOL_ALBEDO, 0.5)},
    },
    # Delta dielectric around a scattering medium.
    "subsurface": {
        "ours": {"type": "subsurface", "color": SSS_COLOR, "roughness": 0,
                 "ior": 1.5, "trdepth": 0.3, "scattering": SSS_ALBEDO},
        "cycles": {"node": "glass", "color": [1, 1, 1], "ior": 1.5,
                   "volume": medium(SSS_COLOR, 0.3, SSS_ALBEDO)},
    },
    # Rough glass is NOT the same model: Cycles 3.4's Glass BSDF (GGX) splits
    # reflection and refraction by the Fresnel term of the shading normal,
    # ours (Walter et al. 2007) by that of each microfacet. Shown for scale.
    "glass_rough": {
        "ours": {"type": "refractive", "color": [1, 1, 1], "roughness": 0.2,
                 "ior": 1.5},
        "cycles": {"node": "glass", "color": [1, 1, 1], "ior": 1.5,
                   "roughness": 0.2},
    },
    # Cycles' multiple-scattering GGX glass (Heitz et al. 2016) applies the
    # Fresnel term per microfacet like ours; it adds the light that bounces
    # more than once on the microsurface, which at alpha = 0.04 is a small
    # fraction of a percent. The closest Cycles 3.4 has to our rough glass.
    "glass_rough_ms": {
        "ours": {"type": "refractive", "color": [1, 1, 1], "roughness": 0.2,
                 "ior": 1.5},
        "cycles": {"node": "glass", "color": [1, 1, 1], "ior": 1.5,
                   "roughness": 0.2, "distribution": "MULTI_GGX"},
    },
})

# glTF PBR metal: Yocto's gltfpbr uses Schlick's Fresnel at the half vector,
# Cycles' Principled the interpolated dielectric Fresnel of "metal". Both
# are 0.8 at normal incidence and 1 at grazing, so this is nearly the same
# model; the table shows how near.
CASES.update({
    "gltfpbr_metal": {
        "ours": {"type": "gltfpbr", "color": [METAL_GRAY] * 3, "metallic": 1,
                 "roughness": 0.5},
        "cycles": {"node": "principled_metal", "color": [METAL_GRAY] * 3,
                   "specular": METAL_GRAY / 0.08, "roughness": 0.5},
    },
})

# Lat-long environment cases: the constant sky is replaced by an HDR image
# (a sky brighter at the horizon and a sun lobe), which exercises our
# environment importance sampling; the quad light stays.
ENV_METAL_ROUGHNESS = 0.3
CASES.update({
    "env_matte": {
        "environment": "latlong",
        "ours": {"type": "matte", "color": MATTE_COLOR},
        "cycles": {"node": "diffuse", "color": MATTE_COLOR},
    },
    "env_metal": {
        "environment": "latlong",
        "ours": {"type": "reflective", "color": [METAL_GRAY] * 3,
                 "roughness": ENV_METAL_ROUGHNESS},
        "cycles": {"node": "principled_metal", "color": [METAL_GRAY] * 3,
                   "specular": METAL_GRAY / 0.08,
                   "roughness": ENV_METAL_ROUGHNESS},
    },
})

REGIONS = ["sphere", "shadow", "floor_near", "floor_far", "background"]

# -----------------------------------------------------------------------------
# VECTOR MATH
# -----------------------------------------------------------------------------


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def mul(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


def normalize(a):
    return mul(a, 1 / math.sqrt(dot(a, a)))


def lookat_frame(eye, center, up=(0.0, 1.0, 0.0)):
    # Yocto/GL lookat_frame: the camera looks down -z.
    w = normalize(sub(eye, center))
    u = normalize(cross(up, w))
    v = normalize(cross(w, u))
    return u, v, w, eye


# -----------------------------------------------------------------------------
# RAY CASTING FOR THE REGION MASK
# -----------------------------------------------------------------------------


def camera_ray(frame, u, v):
    # eval_camera of src/scene/scene.cpp with aperture 0 (v down).
    aspect = WIDTH / HEIGHT
    film = (FILM, FILM / aspect)
    q = (film[0] * (0.5 - u), film[1] * (v - 0.5), LENS)
    d = normalize(mul(q, -1))
    x, y, z, o = frame
    world = add(add(mul(x, d[0]), mul(y, d[1])), mul(z, d[2]))
    return o, normalize(world)


def hit_sphere(o, d, center=SPHERE_CENTER, radius=SPHERE_RADIUS, tmax=math.inf):
    oc = sub(o, center)
    b = dot(oc, d)
    c = dot(oc, oc) - radius * radius
    disc = b * b - c
    if disc < 0:
        return math.inf
    s = math.sqrt(disc)
    for t in (-b - s, -b + s):
        if 1e-6 < t < tmax:
            return t
    return math.inf


def hit_box(o, d, bmin, bmax):
    # Slab test; returns the entry distance or inf.
    t0, t1 = 1e-6, math.inf
    for k in range(3):
        if abs(d[k]) < 1e-12:
            if o[k] < bmin[k] or o[k] > bmax[k]:
                return math.inf
            continue
        a = (bmin[k] - o[k]) / d[k]
        b = (bmax[k] - o[k]) / d[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return t0 if t0 <= t1 else math.inf


def light_points():
    x0, y0, z0 = LIGHT_MIN
    sx, sz = LIGHT_SIZE
    return [(x0 + a * sx, y0, z0 + b * sz)
            for a, b in ((0.5, 0.5), (0, 0), (1, 0), (0, 1), (1, 1))]


def classify(frame, u, v):
    # Region index (1-based) of the first hit along the camera ray, or 0.
    o, d = camera_ray(frame, u, v)
    floor_min = (-FLOOR_HALF, -FLOOR_THICKNESS, -FLOOR_HALF)
    floor_max = (FLOOR_HALF, 0.0, FLOOR_HALF)
    light_max = (LIGHT_MIN[0] + LIGHT_SIZE[0], LIGHT_MIN[1] + 1e-5,
                 LIGHT_MIN[2] + LIGHT_SIZE[1])
    ts = hit_sphere(o, d)
    tf = hit_box(o, d, floor_min, floor_max)
    tl = hit_box(o, d, LIGHT_MIN, light_max)
    t = min(ts, tf, tl)
    if t == math.inf:
        return REGIONS.index("background") + 1
    if t == tl:
        return 0
    if t == ts:
        return REGIONS.index("sphere") + 1
    p = add(o, mul(d, t))
    if p[1] < -1e-6:  # a side of the floor box
        return 0
    distance = math.hypot(p[0], p[2])
    blocked = 0
    for q in light_points():
        to_light = sub(q, p)
        length = math.sqrt(dot(to_light, to_light))
        if hit_sphere(p, mul(to_light, 1 / length), tmax=length) < math.inf:
            blocked += 1
    if blocked == len(light_points()):
        return REGIONS.index("shadow") + 1
    if blocked == 0 and distance < 1.5:
        return REGIONS.index("floor_near") + 1
    if blocked == 0 and distance > 3.0:
        return REGIONS.index("floor_far") + 1
    return 0


def make_mask(frame):
    mask = bytearray(WIDTH * HEIGHT)
    for j in range(HEIGHT):
        for i in range(WIDTH):
            points = [(0.5, 0.5), (0.02, 0.02), (0.98, 0.02), (0.02, 0.98),
                      (0.98, 0.98)]
            ids = {classify(frame, (i + a) / WIDTH, (j + b) / HEIGHT)
                   for a, b in points}
            mask[j * WIDTH + i] = ids.pop() if len(ids) == 1 else 0
    return mask


# -----------------------------------------------------------------------------
# LAT-LONG ENVIRONMENT
# -----------------------------------------------------------------------------

# The environment is a smooth function of the direction, sampled into one
# float EXR per renderer at that renderer's texel centres, so that both
# interpolate the same function (a shared file would be half a texel off):
#   ours (eval_environment, eval_image): u = atan2(z, x) / 2 pi, v = acos(y) / pi,
#     texel (i, j) centred at (i / W, j / H), row 0 at the top;
#   Cycles (direction_to_equirectangular) in its z-up frame (x, -z, y):
#     u = 1/2 + atan2(z, x) / 2 pi, v = 1 - acos(y) / pi, texel centres at
#     ((i + 1/2) / W, (j + 1/2) / H) with v = 1 at the top row.
# The sky depends on the polar angle only through sin^2, so it has the same
# value at both poles and the renderers' different wrapping there (ours
# repeats rows, Cycles may clamp) does not matter. EXR rather than HDR:
# stb_image and Blender decode RGBE mantissas half a unit apart.
ENV_WIDTH, ENV_HEIGHT = 1024, 512
SKY_ZENITH = (0.25, 0.32, 0.45)
SUN_DIRECTION = normalize((1.0, 1.1, 0.9))
SUN_RADIANCE = (150.0, 140.0, 120.0)
SUN_SHARPNESS = 400.0  # exp(k (cos - 1)): about 2 pi / k = 0.016 sr


def environment_radiance(d):
    sin2 = 1 - d[1] * d[1]
    sky = (1 + 1.5 * sin2) * (1 + 0.3 * d[0])
    sun = math.exp(SUN_SHARPNESS * (dot(d, SUN_DIRECTION) - 1))
    return [z * sky + s * sun for z, s in zip(SKY_ZENITH, SUN_RADIANCE)]


def latlong_direction(u, v):
    # Our convention: u = atan2(z, x) / 2 pi, v = acos(y) / pi.
    phi, theta = 2 * math.pi * u, math.pi * v
    return (math.sin(theta) * math.cos(phi), math.cos(theta),
            math.sin(theta) * math.sin(phi))


def save_exr(filename, width, height, pixel):
    # Uncompressed scanline OpenEXR, channels B, G, R as 32-bit float.
    def attribute(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + \
            struct.pack("<i", len(data)) + data
    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1)
                        for c in (b"B", b"G", b"R")) + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = struct.pack("<ii", 20000630, 2) + \
        attribute("channels", "chlist", channels) + \
        attribute("compression", "compression", b"\0") + \
        attribute("dataWindow", "box2i", window) + \
        attribute("displayWindow", "box2i", window) + \
        attribute("lineOrder", "lineOrder", b"\0") + \
        attribute("pixelAspectRatio", "float", struct.pack("<f", 1)) + \
        attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) + \
        attribute("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0"
    line_size = 3 * 4 * width
    first = len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", first + j * (8 + line_size))
                       for j in range(height))
    with open(filename, "wb") as f:
        f.write(header + offsets)
        for j in range(height):
            row = [pixel(i, j) for i in range(width)]
            f.write(struct.pack("<ii", j, line_size))
            for c in (2, 1, 0):
                f.write(struct.pack("<%df" % width, *(p[c] for p in row)))


def save_environments(out):
    w, h = ENV_WIDTH, ENV_HEIGHT
    save_exr(os.path.join(out, "sky_ours.exr"), w, h,
             lambda i, j: environment_radiance(latlong_direction(i / w, j / h)))
    save_exr(os.path.join(out, "sky_cycles.exr"), w, h,
             lambda i, j: environment_radiance(
                 latlong_direction((i + 0.5) / w - 0.5, (j + 0.5) / h)))


# -----------------------------------------------------------------------------
# SCENE FILES
# -----------------------------------------------------------------------------


def flat_frame(frame):
    return [c for axis in frame for c in axis]


def translation(p):
    return [1, 0, 0, 0, 1, 0, 0, 0, 1, p[0], p[1], p[2]]


def ours_scene(frame, case):
    material = dict(case["ours"], name="sphere")
    latlong = case.get("environment") == "latlong"
    scene = {
        "asset": {"copyright": "implicit crosscheck scene (tools/crosscheck)",
                  "generator": "tools/crosscheck/make_scenes.py", "version": "4.2"},
        "cameras": [{"name": "default", "frame": flat_frame(frame),
                     "lens": LENS, "film": FILM, "aspect": WIDTH / HEIGHT,
                     "focus": 10000}],
        "environments": [{"name": "sky", "emission": ENVIRONMENT}],
        "materials": [
            {"name": "floor", "type": "matte", "color": FLOOR_COLOR},
            {"name": "light", "type": "matte", "color": [0, 0, 0],
             "emission": LIGHT_EMISSION},
            material,
        ],
        "sdfunctions": [
            {"name": "floor", "type": "box",
             "whd": [2 * FLOOR_HALF, FLOOR_THICKNESS, 2 * FLOOR_HALF],
             "material": 0,
             "world_from_local": translation(
                 (-FLOOR_HALF, -FLOOR_THICKNESS, -FLOOR_HALF))},
            {"name": "light", "type": "box",
             "whd": [LIGHT_SIZE[0], 1e-5, LIGHT_SIZE[1]], "material": 1,
             "world_from_local": translation(LIGHT_MIN)},
            {"name": "sphere", "type": "sphere", "radius": SPHERE_RADIUS,
             "material": 2, "world_from_local": translation(SPHERE_CENTER)},
        ],
    }
    if latlong:
        scene["textures"] = [{"name": "sky", "uri": "sky_ours.exr"}]
        scene["environments"] = [{"name": "sky", "emission": [1, 1, 1],
                                  "emission_tex": 0}]
    return scene


def cycles_scene(frame, case):
    return {
        "width": WIDTH, "height": HEIGHT,
        "camera_frame": flat_frame(frame), "lens_mm": LENS * 1000,
        "sensor_mm": FILM * 1000,
        "environment": ENVIRONMENT,
        "environment_map": "sky_cycles.exr"
        if case.get("environment") == "latlong" else None,
        "floor": {"min": [-FLOOR_HALF, -FLOOR_THICKNESS, -FLOOR_HALF],
                  "max": [FLOOR_HALF, 0.0, FLOOR_HALF], "color": FLOOR_COLOR},
        "light": {"min": list(LIGHT_MIN), "size": list(LIGHT_SIZE),
                  "emission": LIGHT_EMISSION},
        "sphere": {"center": list(SPHERE_CENTER), "radius": SPHERE_RADIUS,
                   "material": case["cycles"]},
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "out"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    frame = lookat_frame(CAMERA_FROM, CAMERA_TO)
    save_environments(args.out)
    for name, case in CASES.items():
        with open(os.path.join(args.out, name + ".json"), "w") as f:
            json.dump(ours_scene(frame, case), f, indent=1)
        with open(os.path.join(args.out, name + ".cycles.json"), "w") as f:
            json.dump(cycles_scene(frame, case), f, indent=1)
    mask = make_mask(frame)
    with open(os.path.join(args.out, "regions.pgm"), "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (WIDTH, HEIGHT))
        f.write(bytes(mask))
    with open(os.path.join(args.out, "regions.txt"), "w") as f:
        f.write("\n".join(REGIONS) + "\n")
    counts = [sum(1 for m in mask if m == k + 1) for k in range(len(REGIONS))]
    print("cases:", " ".join(CASES))
    print("region pixels:", ", ".join(
        f"{n} {c}" for n, c in zip(REGIONS, counts)))


if __name__ == "__main__":
    main()
