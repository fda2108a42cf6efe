"""Rendering from Python: the same pixels as ypathtrace, errors, options,
progress, the GIL and cancellation."""

import json
import os
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

import implicit as im
from conftest import run_cli

TINY = {"resolution": 40, "samples": 3}


def example(source_dir, name):
    return os.path.join(source_dir, "examples", name, name + ".json")


def render_both(ypathtrace, tmp_path, scene, path, **options):
    """EXR bytes from Python (render + save_image) and from the CLI."""
    python_exr = tmp_path / "python.exr"
    cli_exr = tmp_path / "cli.exr"
    image = im.render(scene, **options)
    assert image.dtype == np.float32 and image.ndim == 3
    assert image.shape[2] == 4
    im.save_image(python_exr, image)
    result = run_cli(ypathtrace, path, cli_exr, **options)
    assert result.returncode == 0, result.stderr
    return python_exr.read_bytes(), cli_exr.read_bytes(), image


@pytest.mark.parametrize("name,options", [
    ("sdfunction", {}),
    ("sdfunction", {"shader": "eyelight", "seed": 7, "tentfilter": True}),
    ("sdfunction", {"mis": "one", "sampler": "random", "bounces": 2,
                    "clamp": 2.5}),
    ("csg", {"noimplicitmis": True, "envhidden": True, "accel": "none"}),
    ("materials", {"stmaxiter": 200, "threads": 1}),
    ("materials", {"shader": "normal", "camera": "default"}),
])
def test_python_and_cli_exr_are_byte_equal(ypathtrace, source_dir, tmp_path,
                                           name, options):
    path = example(source_dir, name)
    options = {**TINY, **options}
    if options.get("camera") == "default":
        cameras = [c["name"] for c in json.load(open(path))["cameras"]]
        options["camera"] = cameras[-1]
    python, cli, image = render_both(ypathtrace, tmp_path,
                                     im.load_scene(path), path, **options)
    assert python == cli
    assert max(image.shape[:2]) == TINY["resolution"]
    assert np.isfinite(image).all() and image[..., :3].max() > 0


def test_loaded_scene_and_path_give_the_same_image(source_dir):
    path = example(source_dir, "csg")
    scene = im.load_scene(path)
    assert scene.filename == path and len(scene.cameras) >= 1
    assert scene.num_sdfunctions > 0
    a = im.render(scene, **TINY)
    b = im.render(path, **TINY)
    assert np.array_equal(a, b)


def make_scene(grid_path=None, textures=None):
    """A scene with every kind of element, built in Python; `textures` is
    the folder of the example textures."""
    scene = im.Scene()
    f = (im.sphere(0.5) & im.box(0.8)) - im.cylinder(0.2, 2).orient(im.X)
    scene.add(f.translate((0, 0.4, 0)),
              {"type": "glossy", "color": (0.8, 0.3, 0.2), "roughness": 0.2},
              name="shape")
    floor = scene.add_material(
        "matte", color=(0.7, 0.7, 0.7), name="floor",
        color_tex=None if textures is None else
        os.path.join(textures, "checker.tga"))
    scene.add(im.plane(), floor, name="floor")
    scene.add(im.torus(0.3, 0.08).translate((-0.8, 0.1, 0)),
              {"type": "refractive", "color": (1, 1, 1), "ior": 1.5})
    scene.add_light(im.sphere(0.3, center=(1, 2, 1)), (20, 20, 20),
                    name="light")
    scene.add_environment(
        (0.2, 0.25, 0.3), rotate=0.5,
        texture=None if textures is None else
        os.path.join(textures, "sky.hdr"))
    if grid_path is not None:
        im.sphere(0.25).save_grid(grid_path, 0.05)
        scene.add_grid(grid_path, {"type": "reflective",
                                   "color": (0.9, 0.9, 0.9)},
                       transform=im.translation((0.8, 0.3, -0.3)))
    scene.add_camera(eye=(0.5, 1.2, 3), target=(0, 0.3, 0), aspect=1.5,
                     name="main")
    return scene


def test_python_scene_saved_renders_the_same_in_the_cli(ypathtrace, tmp_path,
                                                       source_dir):
    os.makedirs(tmp_path / "grids")
    textures = os.path.join(source_dir, "examples", "materials", "textures")
    scene = make_scene(tmp_path / "grids" / "ball.vdb", textures)
    path = tmp_path / "scene.json"
    scene.save(path)
    saved = json.loads(path.read_text())
    # The JSON round trip: paths relative to the file, the rest as built.
    assert saved["volumes"][0]["uri"] == "grids/ball.vdb"
    assert saved["textures"][1]["uri"] == os.path.relpath(
        os.path.join(textures, "sky.hdr"), tmp_path)
    assert saved == scene.to_dict(str(tmp_path))
    assert len(saved["sdfunctions"]) == 4 and len(saved["materials"]) == 5
    loaded = im.load_scene(path)
    assert loaded.cameras == ["main"] and loaded.num_vol_instances == 1
    python, cli, _ = render_both(ypathtrace, tmp_path, scene, path, **TINY)
    assert python == cli
    # From the loaded file too.
    assert np.array_equal(im.render(loaded, **TINY), im.render(scene, **TINY))


def test_renderer_steps_add_up_to_render(source_dir):
    path = example(source_dir, "sdfunction")
    full = im.render(path, resolution=32, samples=4)
    renderer = im.Renderer(path, resolution=32, samples=4)
    assert renderer.samples == 0
    renderer.step().step(3)
    assert renderer.samples == 4
    assert np.array_equal(renderer.array, full)
    image = renderer.image
    assert isinstance(image, im.Image) and image.shape == full.shape
    png = image._repr_png_()
    assert png.startswith(b"\x89PNG") and len(png) > 100
    assert im.Image(full)._repr_png_() == png


def test_no_lights_fall_back_to_eyelight():
    scene = im.Scene()
    scene.add(im.sphere(1), {"color": (0.5, 0.5, 0.5)})
    with pytest.warns(UserWarning, match="no lights"):
        image = im.render(scene, resolution=16, samples=1)
    assert image[..., :3].max() > 0
    with pytest.warns(UserWarning, match="no lights"):
        assert im.Renderer(scene, resolution=16).shader == "eyelight"


def test_missing_camera_is_added():
    scene = im.Scene()
    scene.add(im.box(1), {"color": (0.5, 0.5, 0.5)})
    scene.add_environment((1, 1, 1))
    image = im.render(scene, resolution=24, samples=1)
    assert image.shape == (14, 24, 4)
    assert image[..., 3].max() == 1


# -----------------------------------------------------------------------------
# ERRORS
# -----------------------------------------------------------------------------


def test_library_errors_carry_the_cli_message(ypathtrace, tmp_path):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({
        "asset": {"version": "4.2"}, "materials": [{}],
        "sdfunctions": [{"name": "t", "type": "torus", "r1": 1,
                         "material": 0}]}))
    with pytest.raises(im.Error) as error:
        im.load_scene(path)
    message = str(error.value)
    assert message.startswith(str(path))
    assert 'sdfunctions[0] ("t").r2: missing required parameter' in message
    assert issubclass(im.Error, Exception)
    result = run_cli(ypathtrace, path, tmp_path / "out.exr")
    assert result.returncode == 1
    assert result.stderr.strip() == f"ypathtrace: error: {message}"


def test_file_errors(tmp_path, source_dir):
    with pytest.raises(im.Error, match="nothing.json"):
        im.load_scene(tmp_path / "nothing.json")
    with pytest.raises(im.Error, match="not found"):
        im.render(example(source_dir, "csg"), camera="nobody", **TINY)
    with pytest.raises(im.Error, match="missing.vdb"):
        scene = im.Scene()
        scene.add_grid(tmp_path / "missing.vdb", {})
        im.render(scene, **TINY)
    with pytest.raises(im.Error, match="out.xyz"):
        im.save_image(tmp_path / "out.xyz", np.zeros((2, 2, 4)))


def test_bad_render_options(source_dir):
    scene = im.load_scene(example(source_dir, "sdfunction"))
    # Values out of range: the library's checks (implicit.Error) or the
    # module's (ValueError); types and names: the module's.
    out_of_range = (ValueError, im.Error)
    for options, error, pattern in [
            ({"samples": -1}, out_of_range, "samples"),
            ({"samples": 0}, out_of_range, "samples"),
            ({"samples": 2**40}, out_of_range, "samples"),
            ({"samples": 2**70}, out_of_range, "samples"),
            ({"samples": 1.5}, TypeError, "samples: expected an integer"),
            ({"resolution": 100000}, out_of_range, "resolution"),
            ({"clamp": float("nan")}, out_of_range, "clamp"),
            ({"clamp": -1}, out_of_range, "clamp"),
            ({"seed": -3}, ValueError, "seed"),
            ({"seed": 2**64}, ValueError,
             r"seed: 18446744073709551616 is out of range \[0, "),
            ({"clamp": 2**200}, ValueError, "clamp: .* is out of range"),
            ({"exposure": 1}, TypeError, "unknown render option 'exposure'"),
            ({"clamp": "big"}, TypeError, "clamp: expected a number"),
            ({"shader": "fancy"}, ValueError, "valid: implicit, "),
            ({"mis": "three"}, ValueError, "valid: one, two"),
            ({"envhidden": 1}, TypeError, "envhidden"),
            ({"threads": -1}, ValueError, "threads"),
            ({"spp": 4}, TypeError, "unknown render option 'spp'"),
            ({"aov": "albedo,bogus"}, ValueError, "unknown value \"bogus\""),
            ({"aov": 3}, TypeError, "aov: expected a list of names"),
            ({"noise_threshold": -1}, ValueError, "noise-threshold"),
            ({"min_samples": -1}, ValueError, "min-samples")]:
        with pytest.raises(error, match=pattern):
            im.render(scene, **options)
    with pytest.raises(TypeError, match="scene"):
        im.render(42)
    with pytest.raises(TypeError, match="progress"):
        im.render(scene, progress=3, **TINY)
    with pytest.raises(ValueError, match="sample count"):
        im.Renderer(scene, **TINY).step(0)


def test_options_are_the_cli_table(ypathtrace):
    # One table behind both: the same names, defaults, ranges and help.
    cli_help = subprocess.run([ypathtrace, "--help"], capture_output=True,
                              text=True).stdout
    defaults = im.default_options()
    help = im.option_help()
    assert list(defaults) == list(help)
    assert defaults["samples"] == 512 and defaults["camera"] is None
    assert defaults["clamp"] == 10.0 and defaults["noimplicitmis"] is False
    assert defaults["shader"] == "implicit" and "exposure" not in defaults
    for name, (kind, default, domain, text) in help.items():
        assert f"--{name.replace('_', '-')}" in cli_help, name
        assert text in cli_help, name
        if kind != "flag" and domain:
            assert f"[{domain}]" in cli_help, name
    assert help["mis"] == ("choice", "two", "one|two", help["mis"][3])
    assert "samples (integer, 1..1048576; default 512)" in im.render.__doc__


def test_files_are_written_whole(tmp_path):
    # Scenes and STL meshes go through the library's atomic writer: a
    # failure names the file and leaves nothing behind.
    scene = im.Scene()
    scene.add(im.sphere(1), {"color": (0.5, 0.5, 0.5)})
    with pytest.raises(im.Error, match=r"nowhere/scene.json: cannot write"):
        scene.save(tmp_path / "nowhere" / "scene.json")
    scene.save(tmp_path / "scene.json")
    im.sphere(1).save(tmp_path / "ball.stl", voxel=0.25)
    assert sorted(os.listdir(tmp_path)) == ["ball.stl", "scene.json"]
    assert im.load_scene(tmp_path / "scene.json").num_sdfunctions == 1


def test_bad_images(tmp_path):
    for bad in (np.zeros((4, 4)), np.zeros((4, 4, 2)), np.zeros((0, 4, 4))):
        with pytest.raises(ValueError, match=r"\(height, width, 4\)"):
            im.save_image(tmp_path / "x.exr", bad)
    with pytest.raises(ValueError, match="exposure"):
        im.save_image(tmp_path / "x.png", np.zeros((2, 2, 3)),
                      exposure=float("nan"))
    rgb = np.full((3, 5, 3), 0.25, np.float32)
    im.save_image(tmp_path / "x.exr", rgb)
    back = im.load_image(tmp_path / "x.exr")
    assert back.shape == (3, 5, 4)
    assert np.array_equal(back[..., :3], rgb) and (back[..., 3] == 1).all()


def test_bad_scene_values():
    scene = im.Scene()
    with pytest.raises(ValueError, match="material type"):
        scene.add_material("plastic")
    with pytest.raises(TypeError, match="unknown material key"):
        scene.add_material(colour=(1, 1, 1))
    with pytest.raises(ValueError, match="material: 3 does not exist"):
        scene.add(im.sphere(1), 3)
    with pytest.raises(ValueError, match="eye and target"):
        scene.add_camera(eye=(1, 1, 1), target=(1, 1, 1))
    with pytest.raises(ValueError, match="finite"):
        scene.add_environment((1, float("inf"), 1))
    # Values only the loader checks still fail, with its message.
    scene.add_material(roughness=2)
    scene.add(im.sphere(1), 0)
    with pytest.raises(im.Error, match=r"python scene: materials\[0\]"
                                       r"\.roughness: must be in \[0, 1\]"):
        im.render(scene, **TINY)


# -----------------------------------------------------------------------------
# PROGRESS, GIL, CANCELLATION
# -----------------------------------------------------------------------------


def check_progress(calls):
    """Progress went up to its total, never backwards, total fixed."""
    assert calls and calls[-1][0] == calls[-1][1] > 0
    assert len({total for _, total in calls}) == 1
    done = [d for d, _ in calls]
    assert done == sorted(done)


def test_progress_is_called(source_dir):
    calls = []
    im.render(example(source_dir, "sdfunction"), resolution=24, samples=5,
              progress=lambda done, total: calls.append((done, total)))
    check_progress(calls)
    steps = []
    renderer = im.Renderer(example(source_dir, "sdfunction"), resolution=24)
    renderer.step(2).step(3, progress=lambda d, t: steps.append((d, t)))
    check_progress(steps)
    assert renderer.samples == 5


def slow_scene(source_dir):
    return im.load_scene(example(source_dir, "materials"))


def test_render_releases_the_gil(source_dir):
    scene = slow_scene(source_dir)
    counts = []
    stop = threading.Event()

    def count():
        n = 0
        while not stop.is_set():
            n += 1
        counts.append(n)

    thread = threading.Thread(target=count)
    thread.start()
    start = time.perf_counter()
    im.render(scene, resolution=64, samples=8, threads=1)
    elapsed = time.perf_counter() - start
    stop.set()
    thread.join()
    # A thread blocked on the GIL would count a few times per switch
    # interval (5 ms); a free one counts millions of times a second.
    assert counts[0] > 20000 * elapsed, (counts[0], elapsed)


def test_exception_in_progress_cancels(source_dir):
    scene = slow_scene(source_dir)

    def progress(done, total):
        raise RuntimeError("stop here")

    start = time.perf_counter()
    with pytest.raises(RuntimeError, match="stop here"):
        im.render(scene, resolution=96, samples=100000, progress=progress)
    assert time.perf_counter() - start < 10
    renderer = im.Renderer(scene, resolution=32)
    renderer.step(2)
    before = renderer.array
    with pytest.raises(RuntimeError):
        renderer.step(100000, progress=progress)
    assert renderer.samples == 2 and np.array_equal(renderer.array, before)


def test_ctrl_c_stops_the_render(source_dir):
    scene = slow_scene(source_dir)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            im.render(scene, resolution=96, samples=100000)
    finally:
        timer.cancel()
    assert time.perf_counter() - start < 10


def test_renderer_refuses_a_second_thread(source_dir):
    renderer = im.Renderer(slow_scene(source_dir), resolution=64)
    errors = []

    def other():
        for call in (renderer.step, lambda: renderer.array):
            try:
                call()
            except RuntimeError as error:
                errors.append(str(error))

    thread = threading.Thread(target=other)

    def progress(done, total):
        if not thread.is_alive():
            thread.start()
            thread.join()
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        renderer.step(100000, progress=progress)
    assert len(errors) == 2 and "another thread" in errors[0]
    assert renderer.samples == 0
    renderer.step()
    assert renderer.samples == 1


def test_aovs_by_name(source_dir):
    # The layers by name beside the image, which they do not change.
    path = example(source_dir, "sdfunction")
    plain = im.render(path, **TINY)
    layers = im.render(path, aov=["albedo", "depth", "variance"], **TINY)
    assert sorted(layers) == ["albedo", "depth", "image", "variance"]
    assert np.array_equal(layers["image"], plain)
    height, width = plain.shape[:2]
    assert layers["albedo"].shape == (height, width, 3)
    assert layers["depth"].shape == (height, width)
    assert layers["depth"].max() > 0 and layers["variance"].min() >= 0
    assert im.render(path, aov="normal", **TINY)["normal"].shape[2] == 3


def test_denoise_option(source_dir):
    path = example(source_dir, "sdfunction")
    plain = im.render(path, **TINY)
    denoised = im.render(path, denoise=True, **TINY)
    assert denoised.shape == plain.shape and np.isfinite(denoised).all()
    assert not np.array_equal(denoised[..., :3], plain[..., :3])
    assert np.array_equal(denoised[..., 3], plain[..., 3])
    nfor = im.render(path, denoise=True, denoiser="nfor", **TINY)
    assert not np.array_equal(nfor[..., :3], denoised[..., :3])
    with pytest.raises(ValueError, match="denoiser"):
        im.render(path, denoise=True, denoiser="oidn", **TINY)
