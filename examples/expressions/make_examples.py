"""Write the expression examples: scene files and a generated .vm model.

    /usr/bin/python3 examples/expressions/make_examples.py [--shapes N]

Writes, next to this script:
  gyroid_lattice.json   a part filled with a gyroid sheet inside a skin,
                        cut open by its bounds (lattice tools' look)
  twisted_columns.json  twisted and bent columns (IQ's opTwist, opCheapBend)
  iq_repeat.json        displaced, repeated and mirrored shapes (IQ's
                        opDisplace, opLimitedRepetition, opSymXZ, opElongate)
  slab_text.json        slab_text.vm: a generated model of several thousand
                        clauses (Prospero-like: rows of glyphs made of
                        circles and capsules from sqrt/square/min/max,
                        extruded into a slab), seen from above
The model is seeded: the same command writes the same bytes.
"""

import argparse
import json
import math
import os
import random

HERE = os.path.dirname(os.path.abspath(__file__))


# -----------------------------------------------------------------------------
# SCENES
# -----------------------------------------------------------------------------

def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0]]


def lookat(eye, target, up=(0, 1, 0)):
    """A camera frame at `eye` looking at `target` (cameras look down -z)."""
    z = normalize([e - t for e, t in zip(eye, target)])
    x = normalize(cross(up, z))
    y = cross(z, x)
    return [round(c, 6) for c in x + y + z + list(eye)]


def camera(eye, target, aspect=1.5, up=(0, 1, 0)):
    focus = math.sqrt(sum((e - t) ** 2 for e, t in zip(eye, target)))
    return {"name": "default", "frame": lookat(eye, target, up),
            "aspect": aspect, "focus": round(focus, 4)}


def at(x, y, z):
    """The frame of an object whose local origin lies at (x, y, z) in its
    parent's space (sdfunction frames map the parent's points into the
    object's: the translation is the opposite)."""
    return [1, 0, 0, 0, 1, 0, 0, 0, 1, -x, -y, -z]


def scene(copyright, cam, materials, sdfunctions, sky=(0.5, 0.55, 0.65)):
    return {
        "asset": {"version": "4.2", "generator": "make_examples.py",
                  "copyright": copyright},
        "cameras": [cam],
        "environments": [{"name": "sky", "emission": list(sky)}],
        "materials": materials,
        "sdfunctions": sdfunctions,
    }


def floor(material, size=8, y=0):
    return {"name": "floor", "type": "box", "whd": [size, 0.01, size],
            "material": material,
            "frame": at(-size / 2, y - 0.01, -size / 2)}


def lamp(material, position, size=(1.2, 0.01, 1.2)):
    return {"name": "lamp", "type": "box", "whd": list(size),
            "material": material,
            "frame": at(position[0] - size[0] / 2, position[1],
                        position[2] - size[2] / 2)}


LIGHT = {"name": "light", "emission": [12, 11, 10]}
FLOOR = {"name": "floor", "color": [0.6, 0.6, 0.6]}


def gyroid_lattice():
    # The part: a rounded box. Inside, a skin 0.04 thick and a gyroid sheet
    # of period 2 pi / 14 (thickness 0.025); the bounds cut away the front
    # (z > 0.2) so that the lattice shows.
    gyroid = ("sin(14*x)*cos(14*y) + sin(14*y)*cos(14*z) + "
              "sin(14*z)*cos(14*x)")
    formula = ("min(abs(part + 0.02) - 0.02, "
               "max(part, abs(" + gyroid + ")/14 - 0.0125))")
    part = {"type": "round", "radius": 0.1, "operand": {
        "type": "box", "whd": [1.2, 0.8, 0.8],
        "frame": at(-0.6, -0.4, -0.4)}}
    lattice = {"name": "lattice", "type": "expression", "material": 2,
               "expression": formula, "operands": {"part": part},
               "bounds": [[-0.75, -0.55, -0.55], [0.75, 0.55, 0.2]],
               "frame": at(0, 0.55, 0)}
    return scene(
        "implicit example: a part filled with a gyroid sheet inside a skin",
        camera([1.4, 1.1, 2.4], [0, 0.45, 0]),
        [FLOOR, LIGHT, {"name": "metal", "type": "reflective",
                        "color": [0.85, 0.6, 0.35], "roughness": 0.35}],
        [floor(0), lamp(1, (0.5, 3, 1.5)), lattice])


def twisted_columns():
    columns = []
    for i, (twist, bend) in enumerate([(0.0, 0.0), (1.2, 0.0), (2.4, 0.0),
                                       (1.2, 0.35)]):
        shaft = {"type": "round", "radius": 0.03, "operand": {
            "type": "box", "whd": [0.34, 2.0, 0.34],
            "frame": at(-0.17, -1.0, -0.17)}}
        warped = {"type": "twist", "k": twist, "operand": shaft}
        frame = at((i - 1.5) * 0.8, 1.0, 0)
        if bend:
            # opCheapBend bends along x: the column's y is the bend's x
            # (a quarter turn about z on either side of it).
            warped["frame"] = [0, 1, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0]
            warped = {"type": "bend", "k": bend, "operand": warped}
            frame = [0, -1, 0, 1, 0, 0, 0, 0, 1, -1.0, (i - 1.5) * 0.8, 0]
        columns.append({"name": "column%d" % i, "material": 2 + i % 2,
                        **warped, "frame": frame})
    return scene(
        "implicit example: twisted and bent columns",
        camera([0.6, 1.7, 6.8], [0, 1.0, 0]),
        [FLOOR, LIGHT,
         {"name": "stone", "color": [0.75, 0.7, 0.62]},
         {"name": "glaze", "type": "glossy", "color": [0.2, 0.35, 0.6],
          "roughness": 0.2}],
        [floor(0), lamp(1, (1.0, 3.2, 2.0))] + columns)


def iq_repeat():
    # A limited grid of displaced spheres (5 x 5), mirrored pillars
    # (elongated spheres), all on a floor.
    bumps = {"name": "bumps", "material": 2, "type": "repeat",
             "spacing": [0.7, 0, 0.7], "limit": [2, 0, 2],
             "operand": {"type": "displace",
                         "expression": "0.04*sin(18*x)*sin(18*y)*sin(18*z)",
                         "operand": {"type": "sphere", "radius": 0.24}},
             "frame": at(0, 0.28, 0)}
    pillars = {"name": "pillars", "material": 3, "type": "mirror",
               "axes": "xz", "operand": {
                   "type": "elongate", "h": [0, 0.5, 0], "operand": {
                       "type": "sphere", "radius": 0.12},
                   "frame": at(2.1, 0.62, 2.1)}}
    return scene(
        "implicit example: IQ's repetition, displacement, mirror, elongate",
        camera([2.6, 2.2, 3.4], [0, 0.15, 0]),
        [FLOOR, LIGHT,
         {"name": "clay", "color": [0.8, 0.45, 0.3]},
         {"name": "chrome", "type": "reflective", "color": [0.9, 0.9, 0.9],
          "roughness": 0.1}],
        [floor(0), lamp(1, (0.0, 3.0, 1.0)), bumps, pillars])


# -----------------------------------------------------------------------------
# THE GENERATED MODEL
# -----------------------------------------------------------------------------

class vm_writer:
    """Clauses of a .vm file; each method returns the clause's name."""

    def __init__(self):
        self.lines = []
        self.constants = {}

    def clause(self, op, *args):
        name = "_%x" % len(self.lines)
        self.lines.append(" ".join([name, op] + list(args)))
        return name

    def const(self, value):
        text = repr(float(round(value, 5)))
        if text not in self.constants:
            self.constants[text] = self.clause("const", text)
        return self.constants[text]


def circle(vm, x, y, cx, cy, r):
    dx = vm.clause("square", vm.clause("sub", x, vm.const(cx)))
    dy = vm.clause("square", vm.clause("sub", y, vm.const(cy)))
    return vm.clause("sub", vm.clause("sqrt", vm.clause("add", dx, dy)),
                     vm.const(r))


def capsule(vm, x, y, ax, ay, bx, by, r):
    """Distance to the segment a-b minus r: h = clamp(dot(p - a, b - a) /
    |b - a|^2, 0, 1), |p - a - h (b - a)| - r."""
    ex, ey = bx - ax, by - ay
    px = vm.clause("sub", x, vm.const(ax))
    py = vm.clause("sub", y, vm.const(ay))
    inv = 1.0 / (ex * ex + ey * ey)
    dot = vm.clause("add", vm.clause("mul", px, vm.const(ex * inv)),
                    vm.clause("mul", py, vm.const(ey * inv)))
    h = vm.clause("min", vm.clause("max", dot, vm.const(0)), vm.const(1))
    qx = vm.clause("sub", px, vm.clause("mul", h, vm.const(ex)))
    qy = vm.clause("sub", py, vm.clause("mul", h, vm.const(ey)))
    d = vm.clause("add", vm.clause("square", qx), vm.clause("square", qy))
    return vm.clause("sub", vm.clause("sqrt", d), vm.const(r))


def glyph(vm, x, y, rng, cx, cy, w, h):
    """A made-up letter in the cell about (cx, cy): 2-4 strokes and maybe a
    dot, a ring or a hole."""
    strokes = []
    points = [(cx + w * u, cy + h * v) for u, v in
              [(-0.4, -0.45), (0.4, -0.45), (-0.4, 0.45), (0.4, 0.45),
               (0, 0), (-0.4, 0), (0.4, 0), (0, 0.45), (0, -0.45)]]
    r = 0.09 * w
    for _ in range(rng.randint(2, 4)):
        a, b = rng.sample(points, 2)
        strokes.append(capsule(vm, x, y, a[0], a[1], b[0], b[1], r))
    kind = rng.random()
    if kind < 0.3:
        strokes.append(circle(vm, x, y, cx, cy + 0.7 * h, 1.3 * r))
    elif kind < 0.55:
        ring = circle(vm, x, y, cx, cy, 0.32 * w)
        strokes.append(vm.clause("sub", vm.clause("abs", ring),
                                 vm.const(0.6 * r)))
    shape = strokes[0]
    for s in strokes[1:]:
        shape = vm.clause("min", shape, s)
    if kind > 0.85:  # a hole through the glyph
        hole = circle(vm, x, y, cx + 0.15 * w, cy - 0.1 * h, 0.18 * w)
        shape = vm.clause("max", shape, vm.clause("neg", hole))
    return shape


def slab_model(shapes, seed=11):
    """Rows of glyphs filling [-1, 1]^2 until about `shapes` glyphs, their
    union extruded into a slab |z| < 0.05 (z is up in the model)."""
    rng = random.Random(seed)
    vm = vm_writer()
    x, y, z = (vm.clause("var-x"), vm.clause("var-y"), vm.clause("var-z"))
    columns = max(1, int(math.sqrt(shapes * 1.6)))
    rows = max(1, (shapes + columns - 1) // columns)
    w, h = 1.9 / columns, 1.9 / rows
    union = None
    for j in range(rows):
        for i in range(columns):
            if j * columns + i >= shapes:
                break
            g = glyph(vm, x, y, rng, -0.95 + (i + 0.5) * w,
                      0.95 - (j + 0.5) * h, 0.8 * w, 0.8 * h)
            union = g if union is None else vm.clause("min", union, g)
    slab = vm.clause("sub", vm.clause("abs", z), vm.const(0.05))
    vm.clause("max", union, slab)
    return "# generated by make_examples.py: %d glyphs\n" % shapes + \
        "\n".join(vm.lines) + "\n", len(vm.lines)


def slab_text(vm_name):
    model = {"name": "text", "type": "expression", "material": 2,
             "uri": vm_name, "bounds": [[-1, -1, -0.06], [1, 1, 0.06]],
             # model z up -> world y up: local (x, -z, y - 0.06)
             "frame": [1, 0, 0, 0, 0, 1, 0, -1, 0, 0, 0, -0.06]}
    return scene(
        "implicit example: a generated model of several thousand clauses",
        camera([0, 2.6, 0.0001], [0, 0, 0], 1.0, up=(0, 0, -1)),
        [FLOOR, LIGHT, {"name": "ink", "color": [0.15, 0.2, 0.35]}],
        [floor(0, 3), lamp(1, (0.5, 3, 0.5)), model])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", type=int, default=140,
                        help="glyphs of the generated model")
    parser.add_argument("--output", default=HERE)
    parser.add_argument("--vm-name", default="slab_text.vm")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)
    text, clauses = slab_model(args.shapes)
    with open(os.path.join(args.output, args.vm_name), "w") as f:
        f.write(text)
    scenes = {"gyroid_lattice.json": gyroid_lattice(),
              "twisted_columns.json": twisted_columns(),
              "iq_repeat.json": iq_repeat(),
              "slab_text.json": slab_text(args.vm_name)}
    for name, content in scenes.items():
        with open(os.path.join(args.output, name), "w") as f:
            json.dump(content, f, indent=1)
            f.write("\n")
    print("%s: %d clauses" % (args.vm_name, clauses))


if __name__ == "__main__":
    main()
