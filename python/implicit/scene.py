"""Scenes assembled in Python, written in the project's JSON format.

A `Scene` holds plain JSON elements (cameras, textures, materials,
environments, sdfunctions, volumes, vol_instances); `save(path)` writes the
file that `ypathtrace --scene` reads, and rendering from Python parses the
same text, so both give the same image. Only the keys you give are written:
the defaults are the loader's. File paths (textures, grids) are kept
absolute in memory and written relative to the saved scene.
"""

import json
import math
import os

import numpy as np

from . import _implicit
from .sdf import (SDF, UP, _frame12, _matrix, _non_negative, _number,
                  _positive, _vec3)

MATERIAL_TYPES = tuple(_implicit.material_type_names)

# Material keys and their kinds, from the scene format's table
# (src/scene/scene.h): a "color" is 3 numbers, a "number" one, a "texture"
# a path or an index from add_texture.
_MATERIAL_KEYS = dict(_implicit.material_keys)


def _relative_expression_uris(sdfunctions, directory):
    """Make the `.vm` uris of expression objects, however deeply nested,
    relative to `directory` (in place; an explicit stack, no recursion)."""
    stack = list(sdfunctions)
    while stack:
        value = stack.pop()
        if isinstance(value, list):
            stack.extend(value)
        elif isinstance(value, dict):
            if value.get("type") == "expression" and "uri" in value:
                value["uri"] = os.path.relpath(
                    value["uri"], directory).replace(os.sep, "/")
            stack.extend(value.values())


def lookat(eye, target, up=UP):
    """The camera frame at `eye` looking at `target` (12 numbers: x, y, z
    axes then origin; the camera looks down its -z, as Yocto/GL's)."""
    eye, target, up = _vec3("eye", eye), _vec3("target", target), \
        _vec3("up", up)
    w = eye - target
    if not np.linalg.norm(w) > 0:
        raise ValueError("lookat: eye and target must differ")
    w /= np.linalg.norm(w)
    u = np.cross(up, w)
    if not np.linalg.norm(u) > 1e-12:
        raise ValueError("lookat: up is parallel to the view direction")
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    v /= np.linalg.norm(v)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, w, eye
    return _frame12(m)


class Scene:
    """A scene under construction. Every `add_*` returns the element's
    index (the handle other elements refer to)."""

    def __init__(self, name="python scene"):
        # `name` stands for the file name in error messages.
        self.name = str(name)
        self.cameras = []
        self.textures = []
        self.materials = []
        self.environments = []
        self.sdfunctions = []
        self.volumes = []
        self.vol_instances = []

    # ---- elements ----

    def add_camera(self, eye=(0, 0, 3), target=(0, 0, 0), up=UP, *,
                   name=None, lens=None, film=None, aspect=None, focus=None,
                   aperture=None, orthographic=None):
        """A camera at `eye` looking at `target`. lens and film in metres
        (defaults 0.05 and 0.036), aspect width/height (default 1.5), focus
        distance (default: |eye - target| when aperture > 0)."""
        camera = {"name": name or f"camera{len(self.cameras)}",
                  "frame": lookat(eye, target, up)}
        for key, value in (("lens", lens), ("film", film),
                           ("aspect", aspect)):
            if value is not None:
                camera[key] = _positive(key, value)
        if aperture is not None:
            camera["aperture"] = _non_negative("aperture", aperture)
            if focus is None and aperture > 0:
                focus = float(np.linalg.norm(_vec3("eye", eye) -
                                             _vec3("target", target)))
        if focus is not None:
            camera["focus"] = _positive("focus", focus)
        if orthographic is not None:
            camera["orthographic"] = bool(orthographic)
        self.cameras.append(camera)
        return len(self.cameras) - 1

    def add_texture(self, path, *, name=None):
        """An image file (.png, .jpg, .hdr, .exr, ...) for materials and
        environments."""
        texture = {"uri": os.path.abspath(os.fspath(path))}
        if name is not None:
            texture["name"] = str(name)
        self.textures.append(texture)
        return len(self.textures) - 1

    def _texture(self, key, value):
        if isinstance(value, bool):
            raise TypeError(f"{key}: expected a path or a texture index")
        if isinstance(value, int):
            if not 0 <= value < len(self.textures):
                raise ValueError(f"{key}: texture {value} does not exist "
                                 f"(the scene has {len(self.textures)})")
            return value
        return self.add_texture(value)

    def add_material(self, type="matte", *, name=None, **keys):
        """A material (Yocto/GL 4.2): type one of MATERIAL_TYPES; keys
        emission, color, scattering (3 numbers), metallic, roughness, ior,
        trdepth, scanisotropy, opacity, and *_tex textures (a path or an
        index)."""
        if type not in MATERIAL_TYPES:
            raise ValueError(f"type: unknown material type {type!r} (valid: "
                             f"{', '.join(MATERIAL_TYPES)})")
        material = {"type": type}
        if name is not None:
            material["name"] = str(name)
        for key, value in keys.items():
            kind = _MATERIAL_KEYS.get(key)
            if kind == "color":
                material[key] = [float(v) for v in _vec3(key, value)]
            elif kind == "number":
                material[key] = _number(key, value)
            elif kind == "texture":
                material[key] = self._texture(key, value)
            else:
                raise TypeError(f"unknown material key {key!r} (keys: " +
                                ", ".join(_MATERIAL_KEYS) + ")")
        self.materials.append(material)
        return len(self.materials) - 1

    def _material(self, material):
        if isinstance(material, dict):
            return self.add_material(**material)
        if isinstance(material, bool) or not isinstance(material, int):
            raise TypeError("material: expected an index from add_material "
                            "or a dict of material keys")
        if not 0 <= material < len(self.materials):
            raise ValueError(f"material: {material} does not exist (the "
                             f"scene has {len(self.materials)})")
        return material

    def add(self, sdf, material, *, name=None):
        """An object: an SDF expression with a material (an index or a dict
        of add_material's keys)."""
        if not isinstance(sdf, SDF):
            raise TypeError(f"expected an SDF, found {type(sdf).__name__}")
        node = sdf.to_json()
        node["material"] = self._material(material)
        if name is not None:
            node = {"name": str(name), **node}
        self.sdfunctions.append(node)
        return len(self.sdfunctions) - 1

    def add_light(self, sdf, emission, *, name=None):
        """An emitting object (black matte with `emission`)."""
        material = self.add_material(
            "matte", emission=emission, color=(0, 0, 0),
            name=None if name is None else f"{name}_material")
        return self.add(sdf, material, name=name)

    def add_environment(self, emission=(1, 1, 1), texture=None, *,
                        rotate=0.0, name=None):
        """Light from infinitely far: `emission` times an optional lat-long
        texture (a path or an index), turned by `rotate` radians about UP."""
        environment = {"emission": [float(v) for v in
                                    _vec3("emission", emission)]}
        if name is not None:
            environment["name"] = str(name)
        if texture is not None:
            environment["emission_tex"] = self._texture("texture", texture)
        angle = _number("rotate", rotate)
        if angle != 0:
            c, s = math.cos(angle), math.sin(angle)
            environment["frame"] = [c, 0, -s, 0, 1, 0, s, 0, c, 0, 0, 0]
        self.environments.append(environment)
        return len(self.environments) - 1

    def add_grid(self, path, material, *, scale=None, binary=None,
                 transform=None, name=None):
        """A grid file (.sdf, .vdb, .vol) placed in the scene: `scale`
        multiplies its extent and values, `transform` (4x4 world_from_local)
        places it: an .sdf or .vol with its first sample at the local
        origin, a .vdb where its own transform puts it. An .sdf is SDFGen
        text unless binary=True (skanti)."""
        path = os.path.abspath(os.fspath(path))
        volume = {"uri": path}
        if name is not None:
            volume["name"] = str(name)
        if binary is not None:
            volume["binary"] = bool(binary)
        elif path.lower().endswith(".sdf"):
            volume["binary"] = False
        self.volumes.append(volume)
        instance = {"volume": len(self.volumes) - 1,
                    "material": self._material(material)}
        if name is not None:
            instance["name"] = str(name)
        if scale is not None:
            instance["scale"] = _positive("scale", scale)
        if transform is not None:
            instance["world_from_local"] = _frame12(_matrix(transform))
        self.vol_instances.append(instance)
        return len(self.vol_instances) - 1

    # ---- files ----

    def to_dict(self, directory=None):
        """The scene as JSON data; with `directory`, file paths are made
        relative to it."""
        def relative(element):
            element = dict(element)
            if directory is not None:
                element["uri"] = os.path.relpath(
                    element["uri"], directory).replace(os.sep, "/")
            return element
        scene = {"asset": {"version": "4.2", "generator": "implicit python"}}
        for key, elements in (
                ("cameras", self.cameras),
                ("textures", [relative(t) for t in self.textures]),
                ("materials", self.materials),
                ("environments", self.environments),
                ("volumes", [relative(v) for v in self.volumes]),
                ("vol_instances", self.vol_instances),
                ("sdfunctions", self.sdfunctions)):
            if elements:
                scene[key] = json.loads(json.dumps(elements))
        if directory is not None:
            _relative_expression_uris(scene.get("sdfunctions", []),
                                      directory)
        return scene

    def to_json(self, directory=None):
        return json.dumps(self.to_dict(directory), indent=2)

    def save(self, path):
        """Write the scene file (ypathtrace --scene renders it)."""
        path = os.fspath(path)
        directory = os.path.dirname(os.path.abspath(path))
        text = self.to_json(directory) + "\n"
        _implicit.write_file(path, text.encode())  # whole or not at all

    def load(self):
        """The scene parsed (and its files loaded) by the renderer."""
        return _implicit.parse_scene(self.to_json(), self.name)
