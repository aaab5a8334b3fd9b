"""lancer.Scene: loading, dicts, renders against the CLI's PFM, camera rays and primary hits."""

import json
import threading
import time

import numpy as np
import pytest

import lancer
from conftest import SCENES, run_cli


def read_pfm(path):
    """A PFM file as float32 (ny, nx, 3), row 0 at the top (PFM stores the bottom row first)."""
    data = path.read_bytes()
    lines = data.split(b"\n", 3)
    assert lines[0] == b"PF"
    nx, ny = map(int, lines[1].split())
    scale = float(lines[2])
    dtype = "<f4" if scale < 0 else ">f4"
    rgb = np.frombuffer(lines[3], dtype=dtype).reshape(ny, nx, 3)
    return rgb[::-1].astype(np.float32)


def test_load_render_shape():
    rgb = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json")).render()
    assert rgb.shape == (400, 600, 3)
    assert lancer.Scene.load(SCENES / "lorenzi-reflections.json").render().shape == rgb.shape
    assert rgb.dtype == np.float32
    assert rgb.flags["C_CONTIGUOUS"]


@pytest.mark.parametrize("scene", ["lorenzi-diffuse", "lorenzi-reflections", "lorenzi-glass",
                                   "coloured-lights", "glass-tir"])
@pytest.mark.parametrize("precision,width", [("auto", None), ("exact", 1), ("exact", None),
                                             ("double", None), ("fast", None)])
def test_render_same_bits_as_cli_pfm(cli, tmp_path, scene, precision, width):
    path = SCENES / (scene + ".json")
    out = tmp_path / "cli.pfm"
    args = ["render", path, "-o", out, "--precision", precision, "--threads", 2]
    if width is not None:
        args += ["--width", width]
    status, message = run_cli(cli, *args)
    assert status == 0, message
    ours = lancer.Scene.load(str(path)).render(precision=precision, width=width or 0, threads=2)
    theirs = read_pfm(out)
    assert ours.shape == theirs.shape
    assert ours.tobytes() == theirs.tobytes()


def test_rows_are_the_whole_images_rows():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"), precision="exact")
    whole = scene.render()
    band = scene.render(rows=(17, 43))
    assert band.shape == (26, 600, 3)
    assert band.tobytes() == whole[17:43].tobytes()
    assert scene.render(rows=(5, 5)).shape == (0, 600, 3)


def test_rows_out_of_range_raise_the_apis_message():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    with pytest.raises(ValueError, match=r"^render_rows: rows \[0, 201\) outside \[0, 200\)$"):
        scene.render(rows=(0, 201))
    with pytest.raises(ValueError, match=r"^render_rows: rows \[-1, 3\)"):
        scene.render(rows=(-1, 3))


def test_dict_scene_renders_as_its_file():
    path = SCENES / "lorenzi-glass.json"
    from_dict = lancer.Scene(json.loads(path.read_text()))
    from_file = lancer.Scene.load(str(path))
    assert from_dict.render().tobytes() == from_file.render().tobytes()
    assert from_dict.name == "dict"


def test_dict_takes_numpy_values():
    d = json.loads((SCENES / "lorenzi-diffuse.json").read_text())
    d["objects"][0]["center"] = np.array(d["objects"][0]["center"], dtype=np.float64)
    d["objects"][0]["radius"] = np.float32(d["objects"][0]["radius"])
    plain = lancer.Scene(json.loads((SCENES / "lorenzi-diffuse.json").read_text()))
    assert lancer.Scene(d).render().tobytes() == plain.render().tobytes()


def test_info_says_what_was_resolved():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    info = scene.info(precision="exact", width=1, threads=1)
    assert (info["precision"], info["width"], info["isa"]) == ("exact", 1, "scalar")
    assert info["one_ray"] == "scalar"  # width 1: every query on the reference
    assert (info["nx"], info["ny"], info["objects"]) == (600, 400, 4)
    assert scene.info()["precision"] in ("exact", "double")


def test_camera_rays_hit_what_primary_hits_says():
    # A pinhole on an axis at float positions, exact: the round trip of camera_ray is exact.
    scene = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"), precision="exact")
    org, dirs = scene.camera_rays()
    assert org.shape == dirs.shape == (400, 600, 3)
    t, ids, _ = scene.intersect(org.reshape(-1, 3), dirs.reshape(-1, 3))
    pt, pid = scene.primary_hits()
    assert pt.shape == pid.shape == (400, 600)
    assert pt.dtype == np.float32 and pid.dtype == np.int32
    assert np.array_equal(ids.reshape(400, 600), pid)
    assert t.reshape(400, 600).tobytes() == pt.tobytes()
    assert (pid >= 0).any() and (pid == -1).any()


def test_camera_rays_sub_sample_outside_raises():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    with pytest.raises(ValueError, match=r"^camera_ray: sub-sample \(1, 0\) outside 0 \.\. 0$"):
        scene.camera_rays(1, 0)


def test_png_is_the_clis_png(cli, tmp_path):
    path = SCENES / "lorenzi-shadows.json"
    out = tmp_path / "cli.png"
    status, message = run_cli(cli, "render", path, "-o", out)
    assert status == 0, message
    scene = lancer.Scene.load(str(path))
    assert scene._repr_png_() == out.read_bytes()
    assert lancer.Image(scene.render())._repr_png_() == out.read_bytes()


def test_render_releases_the_gil():
    # While one thread renders, another runs Python: held, the GIL would stop it for the whole
    # render; released, it waits at most a switch interval now and then.
    scene = lancer.Scene.load(str(SCENES / "lorenzi-glass.json"), precision="double", width=1,
                              threads=1)
    t0 = time.perf_counter()
    scene.render()
    alone = time.perf_counter() - t0
    assert alone > 0.05  # long enough that a held GIL would show
    done = threading.Event()

    def work():
        scene.render()
        done.set()

    thread = threading.Thread(target=work)
    last = time.perf_counter()
    longest = 0.0
    thread.start()
    while not done.is_set():
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    thread.join()
    assert longest < alone / 2


def test_threads_query_one_scene_at_once():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"), precision="exact")
    org, dirs = scene.camera_rays()
    org, dirs = org.reshape(-1, 3), dirs.reshape(-1, 3)
    expected = scene.intersect(org, dirs)
    results = [None] * 4

    def work(k):
        results[k] = scene.intersect(org, dirs)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        for a, b in zip(r, expected):
            assert a.tobytes() == b.tobytes()
