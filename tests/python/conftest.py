"""Shared fixtures of the Python module's tests: the build directory (LANCER_BUILD, default
build/), its CLI and the C++ rays program, and the repository's scenes."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("LANCER_BUILD", ROOT / "build")).resolve()
SCENES = ROOT / "scenes"


def built(name):
    path = BUILD / name
    if not path.exists():
        pytest.fail("%s is not built: cmake --build %s --target %s" % (path, BUILD, path.name))
    return path


@pytest.fixture(scope="session")
def cli():
    return built("lancer")


@pytest.fixture(scope="session")
def api_rays():
    return built("bench/lancer_api_rays")


def run_cli(cli, *args):
    """The CLI's exit status and its stderr's last line without the "lancer: " prefix."""
    r = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    last = lines[-1] if lines else ""
    return r.returncode, last[len("lancer: "):] if last.startswith("lancer: ") else last
