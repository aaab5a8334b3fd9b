#!/usr/bin/env python3
"""What the Python module adds to a ray query: one million rays through Scene.intersect from
numpy against the same rays through intersect<16> of the C++ API (bench/api_rays.cpp, rays laid
into Ray16 packets beforehand, untimed), one pass of each in turn per round, and the median of
the rounds' ratios. A benchmark, not a test (docs/python.md, "Overhead").

    PYTHONPATH=build/python /usr/bin/python3 scripts/python-overhead.py [--rays N] [--rounds R]
        [--scene scenes/lorenzi-reflections.json] [--build build]
"""

import argparse
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
    p.add_argument("--rounds", type=int, default=31, help="alternating passes of each side")
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
        # The C++ side stays resident and runs one timed pass per line it reads: the two sides
        # alternate pass by pass, so that whatever else loads the machine falls on both alike.
        cpp = subprocess.Popen([str(program), a.scene, rays, os.path.join(tmp, "hits.bin"),
                                "--repeat", "1", "--precision", a.precision, "--serve"],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert cpp.stdout.readline().strip() == "ready"
        hits = scene.intersect(org, dirs)  # prepared and warm; the arrays reused by out=

        def cpp_pass():
            cpp.stdin.write("\n")
            cpp.stdin.flush()
            return tuple(map(float, cpp.stdout.readline().split()))

        def py_pass(**kw):
            c0, t0 = time.thread_time(), time.perf_counter()
            scene.intersect(org, dirs, **kw)  # in this thread: its CPU time counts it all
            return time.perf_counter() - t0, time.thread_time() - c0

        cpp_s, py_s, reuse_s = [], [], []
        for _ in range(a.rounds):
            cpp_s.append(cpp_pass())
            py_s.append(py_pass())
            reuse_s.append(py_pass(out=hits))
        cpp.stdin.close()
        cpp.wait()
    info = scene.info()
    print("python-overhead: %s, %d rays, %s precision, width %d (%s), %d rounds"
          % (a.scene, a.rays, info["precision"], info["width"], info["isa"], a.rounds))
    for k, clock in enumerate(("wall", "thread CPU")):
        cpp_k = [c[k] for c in cpp_s]
        print("  %s seconds:" % clock)
        print("    C++ intersect<16>:      median %.4f s  (%.1f ns/ray)"
              % (statistics.median(cpp_k), 1e9 * statistics.median(cpp_k) / a.rays))
        for name, side in (("numpy Scene.intersect", py_s), ("numpy, out= reused", reuse_s)):
            side_k = [p[k] for p in side]
            ratios = [p / c for p, c in zip(side_k, cpp_k)]
            print("    %-22s  median %.4f s  (%.1f ns/ray); ratio per round: median %.3f "
                  "(quartiles %.3f, %.3f)"
                  % (name + ":", statistics.median(side_k), 1e9 * statistics.median(side_k) / a.rays,
                     statistics.median(ratios), *statistics.quantiles(ratios, n=4)[::2]))

if __name__ == "__main__":
    main()
