"""Rendering, images and image files.

`render()` takes ypathtrace's options under the same names and defaults
(`default_options()` lists them) and returns the linear RGBA image as a
float32 array of shape (height, width, 4): the pixels the CLI writes to an
.exr for the same scene and options.
"""

import os
import tempfile

import numpy as np

from . import _implicit
from .scene import Scene

LoadedScene = _implicit.LoadedScene


def default_options():
    """The render options and their defaults (those of ypathtrace)."""
    return dict(_implicit.default_render_options())


def option_help():
    """The render options, from the library's option table (the one behind
    ypathtrace --help and the viewer): name -> (type, default, range or
    choices, help)."""
    return dict(_implicit.render_option_help())


def _options_doc():
    """The options section of render()'s and Renderer's docstrings."""
    lines = ["", "    Options (ypathtrace's, from the library's table):"]
    for name, (kind, default, domain, text) in option_help().items():
        where = f", {domain}" if domain and kind != "flag" else ""
        lines.append(f"      {name} ({kind}{where}; default {default!r}): "
                     f"{text}")
    return "\n".join(lines) + "\n"


def load_scene(path):
    """Load a scene file (JSON) with its grids and textures. Problems raise
    implicit.Error naming the file, the element and the key."""
    return _implicit.load_scene(os.fspath(path))


def _loaded(scene):
    """A LoadedScene from a LoadedScene, a Scene or a path."""
    if isinstance(scene, LoadedScene):
        return scene
    if isinstance(scene, Scene):
        return scene.load()
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise TypeError(f"scene: expected a Scene, a loaded scene or a path, "
                    f"found {type(scene).__name__}")


def render(scene, *, progress=None, **options):
    """Render `scene` (a Scene, a loaded scene or a path) and return linear
    RGBA as a float32 array (height, width, 4). With `aov` (names, as a
    list or "albedo,normal"), return a dict of arrays by name instead:
    "image" and each layer, (height, width, 3) or (height, width) for
    depth, the values ypathtrace writes to the .exr's layers.

    Options are ypathtrace's, under the same names (listed below and by
    default_options() and option_help()). `progress`, when
    given, is called as progress(samples_done, samples_total) on the calling
    thread. The GIL is released while tracing; Ctrl-C (or an exception from
    `progress`) stops the render before its next tile and is raised.
    """
    return _implicit.render(_loaded(scene), progress, **options)


render.__doc__ += _options_doc()


class Image:
    """A linear RGBA image that displays itself in Jupyter (tonemapped as
    ypathtrace writes .png: exposure in stops, optional filmic curve)."""

    def __init__(self, array, exposure=0.0, filmic=False):
        self.array = np.asarray(array, dtype=np.float32)
        self.exposure = float(exposure)
        self.filmic = bool(filmic)

    @property
    def shape(self):
        return self.array.shape

    def __array__(self, dtype=None):
        return self.array if dtype is None else self.array.astype(dtype)

    def save(self, path):
        save_image(path, self.array, self.exposure, self.filmic)

    def _repr_png_(self):
        with tempfile.TemporaryDirectory() as directory:
            path = os.path.join(directory, "image.png")
            self.save(path)
            with open(path, "rb") as data:
                return data.read()

    def __repr__(self):
        height, width = self.array.shape[:2]
        return f"<implicit.Image {width}x{height}>"


class Renderer:
    """A progressive render: `step(n)` adds n samples per pixel, `image`
    is the average so far. Scene, accelerator and lights are built once.
    Options as render()'s."""

    def __init__(self, scene, **options):
        self._renderer = _implicit.Renderer(_loaded(scene), **options)

    def step(self, samples=1, *, progress=None):
        """Add `samples` samples per pixel. Interrupted (Ctrl-C, or an
        exception from `progress`), it leaves the image as before."""
        self._renderer.step(samples, progress)
        return self

    @property
    def samples(self):
        return self._renderer.samples

    @property
    def shader(self):
        """The shader in use (eyelight when the scene has no lights)."""
        return self._renderer.shader

    @property
    def array(self):
        """The current image: float32 (height, width, 4), linear RGBA."""
        return self._renderer.image()

    @property
    def image(self):
        return Image(self.array)

    def _repr_png_(self):
        return self.image._repr_png_()


def save_image(path, image, exposure=0.0, filmic=False):
    """Save linear RGBA (or RGB) as ypathtrace does: .exr/.hdr linear,
    .png/.jpg tonemapped sRGB. The file is written whole or not at all."""
    array = image.array if isinstance(image, Image) else image
    _implicit.save_image(os.fspath(path), np.asarray(array), float(exposure),
                         bool(filmic))


def load_image(path):
    """An image file as linear RGBA float32 (height, width, 4)."""
    return _implicit.load_image(os.fspath(path))
