"""The examples in examples/python run (tiny settings) and write their
files; the saved scene renders in ypathtrace to the example's own image."""

import os
import subprocess
import sys

import implicit as im
from conftest import run_cli


def run_example(source_dir, name, *args):
    script = os.path.join(source_dir, "examples", "python", name)
    result = subprocess.run([sys.executable, script, *args],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def test_model_example(source_dir, tmp_path):
    out = run_example(source_dir, "model.py", "--output", str(tmp_path),
                      "--voxel", "0.05")
    assert "mesh:" in out
    for name in ("model.stl", "model.obj", "model.vdb"):
        assert os.path.getsize(tmp_path / name) > 1000


def test_render_scene_example(source_dir, tmp_path, ypathtrace):
    out = run_example(source_dir, "render_scene.py", "--output",
                      str(tmp_path), "--resolution", "32", "--samples", "2")
    assert "progressive: " in out
    for name in ("scene.json", "scene.exr", "scene.png"):
        assert os.path.getsize(tmp_path / name) > 100
    result = run_cli(ypathtrace, tmp_path / "scene.json", tmp_path / "cli.exr",
                     resolution=32, samples=2)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "cli.exr").read_bytes() == \
        (tmp_path / "scene.exr").read_bytes()
    image = im.load_image(tmp_path / "scene.exr")
    assert image.shape == (18, 32, 4)
