"""Shared fixtures: where the sources and the built ypathtrace are.

ctest sets IMPLICIT_SOURCE_DIR, IMPLICIT_YPATHTRACE and PYTHONPATH (the
build's python folder); run by hand, the sources are found from this file and
ypathtrace in build/release.
"""

import os
import subprocess

import pytest

SOURCE_DIR = os.environ.get(
    "IMPLICIT_SOURCE_DIR",
    os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE_DIR


@pytest.fixture(scope="session")
def ypathtrace():
    path = os.environ.get("IMPLICIT_YPATHTRACE",
                          os.path.join(SOURCE_DIR, "build", "release",
                                       "ypathtrace"))
    if not os.path.exists(path):
        pytest.skip(f"no ypathtrace at {path} (set IMPLICIT_YPATHTRACE)")
    return path


def run_cli(ypathtrace, scene, output, **options):
    """Run ypathtrace; options as render()'s (True flags, names, numbers)."""
    command = [ypathtrace, "--scene", str(scene), "--output", str(output),
               "--quiet"]
    for key, value in options.items():
        key = key.replace("_", "-")
        if isinstance(value, (list, tuple)):
            value = ",".join(value)
        if value is True:
            command.append(f"--{key}")
        elif value is not False and value is not None:
            command += [f"--{key}", str(value)]
    return subprocess.run(command, capture_output=True, text=True)
