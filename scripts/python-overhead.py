#!/usr/bin/env python3
"""What the Python module adds to a ray query: one million rays through Scene.intersect from
numpy against the same rays through intersect<16> of the C++ API (bench/api_rays.cpp, rays laid
into Ray16 packets beforehand, untimed), side by side in rounds, the median of each round's
ratio. A benchmark, not a test (docs/python.md, "Overhead").

    PYTHONPATH=build/python /usr/bin/python3 scripts/python-overhead.py [--rays N] [--rounds R]
        [--scene scenes/lorenzi-reflections.json] [--build build]
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import lancer


def camera_like_rays(scene, n):
    """Camera rays of the scene, repeated up to n: the coherent rays a renderer traces."""
    org, dirs = scene.camera_rays()
    org, dirs = org.reshape(-1, 3), dirs.reshape(-1, 3)
    reps = -(-n // len(org))
    return np.tile(org, (reps, 1))[:n].copy(), np.tile(dirs, (reps, 1))[:n].copy()


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rays", type=int, default=1_000_000)
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--repeat", type=int, default=3, help="timed passes per side per round")
    p.add_argument("--scene", default="scenes/lorenzi-reflections.json")
    p.add_argument("--precision", default="exact")
    p.add_argument("--build", default="build")
    a = p.parse_args()
    program = pathlib.Path(a.build) / "bench" / "lancer_api_rays"
    if not program.exists():
        sys.exit("python-overhead: no %s (cmake --build %s --target lancer_api_rays)"
                 % (program, a.build))
    scene = lancer.Scene.load(a.scene, precision=a.precision)
    org, dirs = camera_like_rays(scene, a.rays)
    tfar = np.full(a.rays, np.inf, np.float32)
    with tempfile.TemporaryDirectory() as tmp:
        rays = os.path.join(tmp, "rays.bin")
        with open(rays, "wb") as f:
            for arr in (org, dirs, tfar):
                arr.tofile(f)
        ratios, py_s, cpp_s = [], [], []
        reuse_ratios, reuse_s = [], []
        hits = scene.intersect(org, dirs)  # prepared and warm; the arrays reused by out=
        for _ in range(a.rounds):
            out = subprocess.run([str(program), a.scene, rays, os.path.join(tmp, "hits.bin"),
                                  "--repeat", str(a.repeat), "--precision", a.precision],
                                 capture_output=True, text=True, check=True)
            cpp = statistics.median(json.loads(out.stdout)["seconds"])
            times = []
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                scene.intersect(org, dirs)
                times.append(time.perf_counter() - t0)
            py = statistics.median(times)
            cpp_s.append(cpp)
            py_s.append(py)
            ratios.append(py / cpp)
            times = []
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                scene.intersect(org, dirs, out=hits)
                times.append(time.perf_counter() - t0)
            reuse_s.append(statistics.median(times))
            reuse_ratios.append(reuse_s[-1] / cpp)
    info = scene.info()
    print("python-overhead: %s, %d rays, %s precision, width %d (%s), %d rounds of %d passes"
          % (a.scene, a.rays, info["precision"], info["width"], info["isa"], a.rounds, a.repeat))
    print("  C++ intersect<16>:      median %.4f s  (%.1f ns/ray)"
          % (statistics.median(cpp_s), 1e9 * statistics.median(cpp_s) / a.rays))
    print("  numpy Scene.intersect:  median %.4f s  (%.1f ns/ray)"
          % (statistics.median(py_s), 1e9 * statistics.median(py_s) / a.rays))
    print("  ratio per round: median %.3f (min %.3f, max %.3f)"
          % (statistics.median(ratios), min(ratios), max(ratios)))
    print("  numpy, out= reused:     median %.4f s  (%.1f ns/ray)"
          % (statistics.median(reuse_s), 1e9 * statistics.median(reuse_s) / a.rays))
    print("  ratio per round: median %.3f (min %.3f, max %.3f)"
          % (statistics.median(reuse_ratios), min(reuse_ratios), max(reuse_ratios)))


if __name__ == "__main__":
    main()
