"""Bad input: ValueError with the CLI's one-line message; arrays of the wrong shape or dtype
refused before anything is read."""

import json

import numpy as np
import pytest

import lancer
from conftest import SCENES, run_cli

UNIT = np.array([[0, 0, -1]], np.float32)
ORIGIN = np.array([[0, 0, 5]], np.float32)


def test_missing_file_message_is_the_clis(cli, tmp_path):
    path = tmp_path / "missing.json"
    status, message = run_cli(cli, "render", path, "-o", tmp_path / "x.pfm")
    assert status == 2
    with pytest.raises(ValueError) as e:
        lancer.Scene.load(str(path))
    assert str(e.value) == message


@pytest.mark.parametrize("edit,expected", [
    (lambda d: d["objects"][1].update(radius=-1), "objects[1].radius: must be > 0"),
    (lambda d: d.pop("camera"), "camera: missing required field"),
    (lambda d: d["objects"][0].update(type="cube"), None),
    (lambda d: d.update(max_depth=100), None),
])
def test_bad_description_message_is_the_clis(cli, tmp_path, edit, expected):
    d = json.loads((SCENES / "lorenzi-reflections.json").read_text())
    edit(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    status, message = run_cli(cli, "render", path, "-o", tmp_path / "x.pfm")
    assert status == 2
    with pytest.raises(ValueError) as from_file:
        lancer.Scene.load(str(path))
    assert str(from_file.value) == message
    with pytest.raises(ValueError) as from_dict:
        lancer.Scene(d)
    # The same message, the scene named "dict" instead of the file.
    assert str(from_dict.value) == "dict" + message[len(str(path)):]
    if expected is not None:
        assert str(from_dict.value) == "dict: " + expected


def test_not_a_dict_and_not_json():
    with pytest.raises(TypeError, match="Scene.load"):
        lancer.Scene("scenes/lorenzi-diffuse.json")
    d = json.loads((SCENES / "lorenzi-diffuse.json").read_text())
    d["objects"][0]["radius"] = float("nan")
    with pytest.raises(ValueError):
        lancer.Scene(d)
    d["objects"][0]["radius"] = object()
    with pytest.raises(TypeError, match="is not a JSON value"):
        lancer.Scene(d)


@pytest.mark.parametrize("kwargs,message", [
    ({"precision": "quad"}, "precision: must be exact, double, fast or auto, not 'quad'"),
    ({"threads": 5000}, "threads"),
    ({"width": 3}, "width"),
])
def test_bad_options(kwargs, message):
    with pytest.raises(ValueError, match="^" + message.replace("(", r"\(")):
        lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"), **kwargs)
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    with pytest.raises(ValueError, match="^" + message):
        scene.render(**kwargs)


@pytest.fixture(scope="module")
def scene():
    return lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))


@pytest.mark.parametrize("org,dirs,message", [
    (np.zeros((4, 2), np.float32), np.zeros((4, 3), np.float32),
     r"^origins: must have shape \(n, 3\), not \(4, 2\)$"),
    (np.zeros((4, 3, 1), np.float32), np.zeros((4, 3), np.float32),
     r"^origins: must have shape \(n, 3\), not \(4, 3, 1\)$"),
    (np.zeros(3, np.float32), np.zeros((1, 3), np.float32),
     r"^origins: must have shape \(n, 3\), not \(3,\)$"),
    (np.zeros((4, 3), np.float32), np.zeros((3, 4), np.float32),
     r"^directions: must have shape \(n, 3\), not \(3, 4\)$"),
    (np.zeros((4, 3), np.int32), np.zeros((4, 3), np.float32),
     r"^origins: must be float32 or float64, not int32$"),
    (np.zeros((4, 3), np.float32), np.zeros((4, 3), np.float16),
     r"^directions: must be float32 or float64, not float16$"),
    (np.zeros((4, 3), ">f4"), np.zeros((4, 3), np.float32),
     r"^origins: must be float32 or float64, not >f4$"),
    (np.zeros((4, 3), np.float32), np.zeros((5, 3), np.float32),
     r"^directions: 5 rays, origins 4$"),
])
def test_wrong_arrays_refused(scene, org, dirs, message):
    with pytest.raises(ValueError, match=message):
        scene.intersect(org, dirs)
    with pytest.raises(ValueError, match=message):
        scene.occluded(org, dirs)


def test_wrong_tfar_refused(scene):
    with pytest.raises(ValueError, match=r"^tfar: must have shape \(1,\), not \(2,\)$"):
        scene.intersect(ORIGIN, UNIT, np.ones(2, np.float32))
    with pytest.raises(ValueError, match=r"^tnear: must be float32 or float64, not int64$"):
        scene.intersect(ORIGIN, UNIT, tnear=np.ones(1, np.int64))
    with pytest.raises(ValueError, match=r"^tfar: must be None, a number or an array"):
        scene.intersect(ORIGIN, UNIT, "far")


def test_bad_ray_named_by_its_index(scene):
    org = np.repeat(ORIGIN, 40, axis=0)
    dirs = np.repeat(UNIT, 40, axis=0)
    dirs[37] = [0, 0, -2]
    with pytest.raises(ValueError, match=r"^intersect: ray 37: dir must be unit length"):
        scene.intersect(org, dirs)
    with pytest.raises(ValueError, match=r"^occluded: ray 37: dir must be unit length"):
        scene.occluded(org, dirs)
    dirs[37] = UNIT
    org[21, 1] = np.inf
    with pytest.raises(ValueError, match=r"^intersect: ray 21: org must be finite$"):
        scene.intersect(org, dirs)
    org[21, 1] = 0
    with pytest.raises(ValueError, match=r"^intersect: ray 3: tfar is NaN$"):
        scene.intersect(org, dirs, np.where(np.arange(40) == 3, np.nan, 1.0))


def test_bad_image_for_png():
    with pytest.raises(ValueError, match=r"^image: must have shape \(ny, nx, 3\), not \(4, 4\)$"):
        lancer.png(np.zeros((4, 4), np.float32))
    with pytest.raises(ValueError, match=r"^image: must be float32 or float64, not uint8$"):
        lancer.png(np.zeros((4, 4, 3), np.uint8))
