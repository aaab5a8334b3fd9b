"""Scene.intersect and Scene.occluded on numpy rays: the same answers as intersect<16> and
occluded<16> of the C++ API (bench/api_rays.cpp), and any layout read in place."""

import json
import subprocess

import numpy as np
import pytest

import lancer
from conftest import SCENES


def random_rays(n, seed=1):
    rng = np.random.default_rng(seed)
    org = rng.uniform(-4, 4, (n, 3)).astype(np.float32)
    org[:, 2] += 6
    dirs = rng.normal(size=(n, 3))
    dirs[:, 2] -= 1.5
    dirs = (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)
    tfar = rng.uniform(1, 20, n).astype(np.float32)
    tfar[::7] = np.inf
    return org, dirs, tfar


def cpp_hits(api_rays, tmp_path, scene, org, dirs, tfar, *extra):
    rays = tmp_path / "rays.bin"
    out = tmp_path / "hits.bin"
    with open(rays, "wb") as f:
        for a in (org, dirs, tfar):
            np.ascontiguousarray(a, dtype=np.float32).tofile(f)
    r = subprocess.run([str(api_rays), str(scene), str(rays), str(out), *extra],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["rays"] == len(org)
    n = len(org)
    raw = np.fromfile(out, dtype=np.uint8)
    t = raw[: 4 * n].view(np.float32)
    ids = raw[4 * n: 8 * n].view(np.int32)
    normal = raw[8 * n: 20 * n].view(np.float32).reshape(n, 3)
    occ = raw[20 * n: 24 * n].view(np.int32)
    return t, ids, normal, occ != 0


@pytest.mark.parametrize("scene", ["lorenzi-reflections", "lorenzi-glass", "many-spheres"])
@pytest.mark.parametrize("n", [1, 15, 16, 17, 1000])
def test_intersect_equals_cpp_intersect16(api_rays, tmp_path, scene, n):
    path = SCENES / (scene + ".json")
    s = lancer.Scene.load(str(path))
    org, dirs, tfar = random_rays(n)
    if n == 1000:
        # Half of them the scene's camera rays, spread over the image: hits in any scene.
        corg, cdirs = s.camera_rays()
        step = corg.shape[0] * corg.shape[1] // 500
        org[500:] = corg.reshape(-1, 3)[::step][:500]
        dirs[500:] = cdirs.reshape(-1, 3)[::step][:500]
        tfar[500:] = np.inf
    t, ids, normal, occ = cpp_hits(api_rays, tmp_path, path, org, dirs, tfar)
    pt, pid, pn = s.intersect(org, dirs, tfar)
    assert pt.shape == (n,) and pid.shape == (n,) and pn.shape == (n, 3)
    assert pt.dtype == np.float32 and pid.dtype == np.int32 and pn.dtype == np.float32
    assert pt.tobytes() == t.tobytes()
    assert np.array_equal(pid, ids)
    assert pn.tobytes() == normal.tobytes()
    assert np.array_equal(s.occluded(org, dirs, tfar), occ)
    if n == 1000:
        assert (pid >= 0).sum() > 10 and (pid == -1).sum() > 10  # both kinds of answer


def test_intersect_equals_cpp_at_every_precision(api_rays, tmp_path):
    path = SCENES / "lorenzi-reflections.json"
    org, dirs, tfar = random_rays(333, seed=4)
    s = lancer.Scene.load(str(path))
    for precision in ("exact", "double", "fast"):
        t, ids, normal, occ = cpp_hits(api_rays, tmp_path, path, org, dirs, tfar,
                                       "--precision", precision)
        pt, pid, pn = s.intersect(org, dirs, tfar, precision=precision)
        assert pt.tobytes() == t.tobytes(), precision
        assert np.array_equal(pid, ids)
        assert np.array_equal(s.occluded(org, dirs, tfar, precision=precision), occ)


def test_empty_arrays():
    s = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    t, ids, normal = s.intersect(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    assert t.shape == (0,) and ids.shape == (0,) and normal.shape == (0, 3)
    assert s.occluded(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)


def test_any_layout_reads_the_same_rays():
    s = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    org, dirs, tfar = random_rays(501, seed=2)
    expected = s.intersect(org, dirs, tfar)
    # Every other row of a larger buffer, Fortran order, float64, and a transposed view.
    big = np.full((1002, 3), np.nan, np.float32)
    big[::2] = org
    layouts = [
        (big[::2], dirs, tfar),
        (np.asfortranarray(org), np.asfortranarray(dirs), tfar),
        (org.astype(np.float64), dirs.astype(np.float64), tfar.astype(np.float64)),
        (np.ascontiguousarray(org.T).T, dirs, np.repeat(tfar, 2)[::2]),
    ]
    for o, d, f in layouts:
        got = s.intersect(o, d, f)
        for a, b in zip(got, expected):
            assert a.tobytes() == b.tobytes()
    # Negative strides: the same rays backwards.
    got = s.intersect(org[::-1], dirs[::-1], tfar[::-1])
    for a, b in zip(got, expected):
        assert a[::-1].tobytes() == b.tobytes()


def test_tfar_scalar_and_tnear():
    s = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    org = np.array([[0, 0, 5]], np.float32)
    dirs = np.array([[0, 0, -1]], np.float32)
    t, ids, normal = s.intersect(org, dirs)
    assert ids[0] == 2 and t[0] == pytest.approx(8.0)  # the radius-2 sphere at z = -5
    assert np.allclose(normal[0], [0, 0, 1])
    assert s.intersect(org, dirs, 7.5)[1][0] == -1
    assert not s.occluded(org, dirs, 7.5)[0] and s.occluded(org, dirs, 8.5)[0]
    # From beyond the near side: the far side of the same sphere.
    t2, ids2, _ = s.intersect(org, dirs, tnear=np.array([9.0]))
    assert ids2[0] == 2 and t2[0] == pytest.approx(12.0)


def test_out_arrays_are_written_and_returned():
    s = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    org, dirs, tfar = random_rays(100, seed=3)
    expected = s.intersect(org, dirs, tfar)
    out = (np.empty(100, np.float32), np.empty(100, np.int32), np.empty((100, 3), np.float32))
    got = s.intersect(org, dirs, tfar, out=out)
    for a, b, c in zip(got, out, expected):
        assert a is b and a.tobytes() == c.tobytes()
    blocked = np.empty(100, bool)
    assert s.occluded(org, dirs, tfar, out=blocked) is blocked
    assert np.array_equal(blocked, s.occluded(org, dirs, tfar))


@pytest.mark.parametrize("out,message", [
    ((np.empty(9, np.float32), np.empty(10, np.int32), np.empty((10, 3), np.float32)),
     r"^out\[0\] \(t\): must be a writable C-contiguous float32 array of shape \(10,\), "
     r"not float32 \(9,\)$"),
    ((np.empty(10, np.float32), np.empty(10, np.int64), np.empty((10, 3), np.float32)),
     r"^out\[1\] \(id\): .* not int64 \(10,\)$"),
    ((np.empty(10, np.float32), np.empty(10, np.int32), np.empty((10, 3), np.float32).T.copy().T),
     r"^out\[2\] \(normal\): .* shape \(10, 3\), not float32 \(10, 3\)$"),
    ((np.empty(10, np.float32), np.empty(10, np.int32)),
     r"^out: must be None or a tuple \(t, id, normal\)$"),
])
def test_wrong_out_arrays_refused(out, message):
    s = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    org, dirs, _ = random_rays(10)
    before = [a.copy() for a in out]
    with pytest.raises(ValueError, match=message):
        s.intersect(org, dirs, out=out)
    for a, b in zip(out, before):
        assert a.tobytes() == b.tobytes()  # nothing written


def test_read_only_out_refused():
    s = lancer.Scene.load(str(SCENES / "lorenzi-reflections.json"))
    org, dirs, _ = random_rays(10)
    blocked = np.zeros(10, bool)
    blocked.flags.writeable = False
    with pytest.raises(ValueError, match=r"^out: must be a writable C-contiguous bool array"):
        s.occluded(org, dirs, out=blocked)
