"""lancer.validate, bench, trade and flux: the CLI's commands, as dicts and arrays."""

import json
import subprocess

import numpy as np
import pytest

import lancer
from conftest import SCENES, run_cli


def cli_json(cli, *args):
    r = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    assert r.returncode in (0, 1), r.stderr
    return json.loads(r.stdout)


def test_validate_is_the_clis(cli):
    path = SCENES / "lorenzi-glass.json"
    ours = lancer.validate(lancer.Scene.load(str(path)), threads=2)
    theirs = cli_json(cli, "validate", path, "--json", "--threads", 2)
    assert ours["identical"] is True and theirs["identical"] is True
    assert [w["width"] for w in ours["widths"]] == [w["width"] for w in theirs["widths"]]
    for a, b in zip(ours["widths"], theirs["widths"]):
        assert a["isa"] == b["isa"] and a["differing_pixels"] == 0
    assert ours["structure"] == theirs["structure"]
    assert ours["resolution"] == tuple(theirs["resolution"])


def test_validate_takes_triangles_meshes_and_cylinders(cli):
    path = SCENES / "prims" / "cylinders.json"
    ours = lancer.validate(lancer.Scene.load(str(path)), threads=2)
    theirs = cli_json(cli, "validate", path, "--json", "--threads", 2)
    assert ours["identical"] is True and theirs["identical"] is True
    assert [w["width"] for w in ours["widths"]] == [w["width"] for w in theirs["widths"]]


def test_validate_refuses_what_the_cli_refuses(cli):
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    with pytest.raises(ValueError, match="^precision: validate compares exact or double"):
        lancer.validate(scene, precision="fast")
    with pytest.raises(ValueError, match=r"^widths: validate compares packet widths"):
        lancer.validate(scene, widths=[1])


def test_bench_rows():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    r = lancer.bench(scene, widths=[1, 4], modes=["primary"], repeat=2)
    assert [(row["width"], row["mode"]) for row in r["results"]] == [(1, "primary"),
                                                                     (4, "primary")]
    for row in r["results"]:
        assert row["rays"] == 300 * 200 and row["mrays_per_s"] > 0  # camera rays
        assert row["samples"].shape == (2,)
    one = lancer.bench(scene, widths=4, threads=1, modes="primary", repeat=1)
    assert [(row["width"], row["threads"]) for row in one["results"]] == [(4, 1)]
    with pytest.raises(ValueError,
                       match="^mode: must be primary, full, kernel, ao or diffuse, not 'x'$"):
        lancer.bench(scene, modes=["x"])
    # The incoherent kinds: through the library API, and the kernels alone beside it.
    inc = lancer.bench(scene, widths=4, modes=["ao", "diffuse"], repeat=1)
    kinds = {(row["mode"], row["config"]) for row in inc["results"]}
    assert kinds == {("ao", ""), ("ao", "kernels, prepared frame"), ("diffuse", ""),
                     ("diffuse", "kernels, prepared frame")}
    for row in inc["results"]:
        assert row["rays"] > 0 and row["rays"] % 4 == 0  # four rays from each camera hit
    with pytest.raises(ValueError, match="^repeat: must be from 1 to 1000, not 0"):
        lancer.bench(scene, repeat=0)


def test_trade_rows():
    scene = lancer.Scene.load(str(SCENES / "lorenzi-diffuse.json"))
    r = lancer.trade(scene, repeat=1)
    by = {(row["precision"], row["width"]): row for row in r["results"]}
    assert by[("double", 1)]["max_abs_diff"] == 0 and by[("double", 1)]["psnr_db"] is None
    assert ("exact", 1) in by and ("fast", 4) in by


def test_flux_is_the_clis(cli):
    path = SCENES / "flux2d.json"
    r = subprocess.run([str(cli), "flux", str(path), "--csv", "-"], capture_output=True,
                       text=True, check=True)
    rows = [line.split(",") for line in r.stdout.strip().splitlines()[1:]]
    x = np.array([float(a) for a, _ in rows])
    flux = np.array([float(b) for _, b in rows])
    ours = lancer.flux(lancer.Scene.load(str(path)))
    assert np.array_equal(ours["x"], x) and np.array_equal(ours["flux"], flux)
    camera = ours["rays"]["camera"]
    assert camera["points"].shape == (len(x), 2, 2) and camera["hit"].shape == (len(x),)
    assert len(ours["scene"]["spheres"]) > 0
    from_dict = lancer.flux(lancer.Scene(json.loads(path.read_text())))
    assert np.array_equal(from_dict["flux"], flux)


def test_flux_refuses_a_pinhole_scene(cli, tmp_path):
    path = SCENES / "lorenzi-diffuse.json"
    status, message = run_cli(cli, "flux", path, "--csv", tmp_path / "f.csv")
    assert status == 2
    with pytest.raises(ValueError) as e:
        lancer.flux(lancer.Scene.load(str(path)))
    assert str(e.value) == message
