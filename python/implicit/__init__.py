"""implicit: model implicit surfaces in Python and render them.

    import implicit as im
    f = im.sphere(1) & im.box(1.5)
    f -= im.cylinder(0.5, 3) | im.cylinder(0.5, 3).orient(im.X)
    scene = im.Scene()
    scene.add(f, {"color": (0.8, 0.3, 0.2)})
    scene.add_environment((1, 1, 1))
    scene.add_camera(eye=(3, 2, 4), target=(0, 0, 0))
    image = im.render(scene, resolution=256, samples=16)  # (H, W, 4) float32
    im.save_image("out.png", image)
    f.save("out.stl", voxel=0.02)

Expressions follow fogleman/sdf (with Y up), scenes are the project's JSON
format (what ypathtrace reads), and rendering, evaluation and meshing run the
renderer's own C++ code. Library errors raise implicit.Error.
"""

from . import _implicit
from ._implicit import Error
from .render import (Image, LoadedScene, Renderer, default_options,
                     load_image, load_scene, option_help, render, save_image)
from .functions import (acos, asin, atan, atan2, ceil, clamp, cos, exp,
                        floor, log, max, min, mix, mod, sin, sqrt, square,
                        tan, x, y, z)
from .scene import MATERIAL_TYPES, Scene, lookat
from .sdf import (ORIGIN, SDF, UP, X, Y, Z, box, box_frame, capped_cone,
                  capped_cylinder, capsule, cylinder, difference, ellipsoid,
                  expression, from_json, intersection, load_vm, octahedron,
                  orientation, plane, rotation, rounded_box, scaling, sphere,
                  torus, translation, union, wireframe_box, write_stl)

Error.__module__ = "implicit"
SHADERS = tuple(_implicit.shader_names)

__all__ = [
    "Error", "Image", "LoadedScene", "Renderer", "default_options",
    "load_image", "load_scene", "option_help", "render", "save_image",
    "MATERIAL_TYPES",
    "Scene", "lookat", "ORIGIN", "SDF", "UP", "X", "Y", "Z", "box",
    "box_frame", "capped_cone", "capped_cylinder", "capsule", "cylinder",
    "difference", "ellipsoid", "from_json", "intersection", "octahedron",
    "orientation", "plane", "rotation", "rounded_box", "scaling", "sphere",
    "torus", "translation", "union", "wireframe_box", "write_stl", "SHADERS",
    "expression", "load_vm", "x", "y", "z", "sqrt", "sin", "cos", "tan",
    "asin", "acos", "atan", "atan2", "exp", "log", "floor", "ceil", "square",
    "min", "max", "mod", "clamp", "mix",
]
