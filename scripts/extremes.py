#!/usr/bin/env python3
"""Float against double at the extremes (issue 17): renders seeded extreme scenes in exact float
and in auto with a lancer binary, and in double with the double reference of a lancer binary
(`--precision double --width 1`) or with lancer_oracle (--truth oracle), and prints, per scene,
the fraction of pixels off by more than 2/255 as displayed, and what auto chose.

    scripts/extremes.py BUILD/lancer [--truth LANCER_OR_ORACLE] [--out DIR] [--only NAME]

The oracle takes the textbook quadratic: with a tiny sphere 1e6 of its radius away its hit
points carry errors of the order of epsilon (1e-4 of the radius here), and it shows shadow acne
that the engine's double does not; so the default truth is the engine's double reference.

Scenes: tiny spheres far away (axis-aligned, and in general position: random camera position,
direction and distance, log-uniform magnitudes), a ground sphere of radius 1e6, scenes moved
1e5 and 1e6 from the origin, grazing rays, and a course scene scaled by 1e-6 and 1e6 (camera
bounds at tiny and huge scales). The same seeds give the same scenes on any machine.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "..", "scenes")


def unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def add(a, b, s=1.0):
    return [x + s * y for x, y in zip(a, b)]


def random_unit(rng):
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        n = math.sqrt(sum(c * c for c in v))
        if 0.1 < n <= 1:
            return [c / n for c in v]


def log_uniform(rng, lo, hi):
    return 10 ** rng.uniform(math.log10(lo), math.log10(hi))


def frame(direction):
    """Two unit vectors across a view direction (any pair will do for placing objects)."""
    w = unit(direction)
    a = [1, 0, 0] if abs(w[0]) < 0.9 else [0, 1, 0]
    u = unit(cross(a, w))
    return u, cross(w, u)


SHINY = {"color": [0.9, 0.8, 0.7], "ka": 0.1, "kd": 0.7, "ks": 0.6, "shininess": 30,
         "reflect": 0.3}
MATTE = {"color": [0.4, 0.7, 0.9], "ka": 0.1, "kd": 0.9}


def tiny_far(ratio, rng=None, n=96):
    """A sphere of radius ratio * distance filling the frame, a smaller one beside it casting a
    shadow on it and seen in it. Axis-aligned (camera at the origin looking down -z) without rng,
    else from a random position in a random direction at a random distance."""
    if rng is None:
        eye, direction, dist = [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 100.0
    else:
        eye = [c * log_uniform(rng, 1, 1e3) for c in random_unit(rng)]
        direction = random_unit(rng)
        dist = log_uniform(rng, 1, 1e4)
    r = ratio * dist
    u, v = frame(direction)
    centre = add(add(eye, direction, dist), u, 0.3 * r)
    small = add(add(centre, u, -1.6 * r), direction, -0.8 * r)
    light = add(add(centre, v, 30 * r), direction, -20 * r)
    return {
        "camera": {"type": "pinhole", "position": eye, "direction": direction, "distance": 1,
                   "resolution": [n, n], "bounds": [-2.5 * ratio, 2.5 * ratio] * 2},
        "epsilon": 1e-4 * r, "max_depth": 2, "background": [0.1, 0.1, 0.2],
        "environment": [0.3, 0.3, 0.3],
        "lights": [{"position": light, "intensity": 1, "ambient": 0.2},
                   {"position": add(eye, u, 10 * r), "intensity": 0.5}],
        "objects": [{"type": "sphere", "center": centre, "radius": r, "material": SHINY},
                    {"type": "sphere", "center": small, "radius": 0.4 * r, "material": MATTE}]}


def ground(rng=None, n=96):
    """A ground sphere of radius 1e6 seen from a few units above it, a small sphere on it.
    Without rng, the extremes test's scene (tests/test_extremes.cpp)."""
    if rng is None:
        return {"camera": {"type": "pinhole", "position": [0, 1, 5], "direction": [0, -0.3, -1],
                           "distance": 1, "resolution": [n, n], "bounds": [-1, 1, -1, 1]},
                "lights": [{"position": [10, 20, 30], "intensity": 1, "ambient": 0.2}],
                "max_depth": 2,
                "objects": [{"type": "sphere", "center": [0, -1e6, 0], "radius": 1e6,
                             "material": {"color": [0.8, 0.6, 0.5]}},
                            {"type": "sphere", "center": [0, 0.5, -3], "radius": 0.5,
                             "material": {"ks": 1, "reflect": 0.3}}]}
    R = 1e6
    top = [rng.uniform(-1e3, 1e3), rng.uniform(-10, 10), rng.uniform(-1e3, 1e3)]
    centre = [top[0], top[1] - R, top[2]]
    h = rng.uniform(0.5, 4)
    yaw = rng.uniform(0, 2 * math.pi)
    eye = [top[0], top[1] + h, top[2]]
    look = [math.cos(yaw), -rng.uniform(0.15, 0.5), math.sin(yaw)]
    ahead = add(eye, unit([look[0], 0, look[2]]), 4 * h)
    ball = [ahead[0], top[1] + 0.5, ahead[2]]
    return {"camera": {"type": "pinhole", "position": eye, "direction": look, "distance": 1,
                       "resolution": [n, n], "bounds": [-0.8, 0.8, -0.8, 0.8]},
            "lights": [{"position": add(eye, [30, 40, 20]), "intensity": 1, "ambient": 0.2}],
            "max_depth": 2, "environment": [0.5, 0.6, 0.8],
            "objects": [{"type": "sphere", "center": centre, "radius": R,
                         "material": {"color": [0.8, 0.6, 0.5], "kd": 0.9, "ks": 0.3}},
                        {"type": "sphere", "center": ball, "radius": 0.5, "material": SHINY}]}


def load(name):
    with open(os.path.join(SCENES, name)) as f:
        return json.load(f)


def moved(name, offset, rng=None, n=96):
    """A course scene moved by offset along x, or along a random direction with rng."""
    j = load(name)
    shift = [offset, 0, 0] if rng is None else [offset * c for c in random_unit(rng)]
    j["camera"]["position"] = add(j["camera"]["position"], shift)
    for light in j.get("lights", []):
        light["position"] = add(light["position"], shift)
    for o in j["objects"]:
        key = "center" if "center" in o else "point"
        o[key] = add(o[key], shift)
    j["camera"]["resolution"] = [n, n * 2 // 3]
    return j


def scaled(name, s, n=96):
    """A course scene scaled by s about the origin: camera bounds at tiny or huge scales."""
    j = load(name)
    cam = j["camera"]
    cam["position"] = [c * s for c in cam["position"]]
    cam["distance"] = cam.get("distance", 1) * s
    cam["bounds"] = [b * s for b in cam["bounds"]]
    cam["resolution"] = [n, n * 2 // 3]
    j["epsilon"] = j.get("epsilon", 1e-4) * s
    for light in j.get("lights", []):
        light["position"] = [c * s for c in light["position"]]
    for o in j["objects"]:
        key = "center" if "center" in o else "point"
        o[key] = [c * s for c in o[key]]
        if "radius" in o:
            o["radius"] *= s
    return j


def grazing(n=96):
    return {"camera": {"type": "orthographic", "position": [0, 0, 10], "direction": [0, 0, -1],
                       "resolution": [n, 4], "bounds": [1 - 1e-3, 1 + 1e-3, -1e-4, 1e-4]},
            "lights": [{"position": [10, 20, 30], "intensity": 1, "ambient": 0.2}],
            "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                         "material": {"ks": 0.5}}]}


def scenes():
    out = []
    for ratio in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
        out.append((f"tiny-axis {ratio:g}", tiny_far(ratio)))
    for ratio in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
        for seed in (1, 2, 3):
            out.append((f"tiny-general {ratio:g} s{seed}",
                        tiny_far(ratio, random.Random(seed * 1000 + round(-math.log10(ratio))))))
    out.append(("ground 1e6 (test)", ground()))
    for seed in (1, 2, 3):
        out.append((f"ground 1e6 s{seed}", ground(random.Random(seed))))
    for offset in (1e5, 1e6):
        out.append((f"shadows moved {offset:g} x", moved("lorenzi-shadows.json", offset)))
        out.append((f"reflections moved {offset:g} s1",
                    moved("lorenzi-reflections.json", offset, random.Random(7))))
        out.append((f"glass moved {offset:g} s2",
                    moved("lorenzi-glass.json", offset, random.Random(8))))
    out.append(("grazing", grazing()))
    for s in (1e-6, 1e6):
        out.append((f"reflections scaled {s:g}", scaled("lorenzi-reflections.json", s)))
    return out


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 1):
        sys.exit(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()}")
    return p.stdout


def off2(lancer, a, b):
    j = json.loads(run([lancer, "compare", a, b, "--as-displayed", "--json",
                        "--threshold", "2/255"]))
    return j["off"][0]["fraction"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("lancer")
    ap.add_argument("--truth", default="", help="a lancer binary (default: LANCER) or lancer_oracle")
    ap.add_argument("--out", default="/tmp/lancer-extremes")
    ap.add_argument("--only", default="")
    ap.add_argument("--threads", default="2")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    print(f"| {'scene':32} | exact off >2/255 | auto off >2/255 | auto picks |")
    print(f"|{'-' * 34}|------------------|-----------------|------------|")
    for name, j in scenes():
        if args.only and args.only not in name:
            continue
        stem = os.path.join(args.out, name.replace(" ", "_"))
        with open(stem + ".json", "w") as f:
            json.dump(j, f)
        truth = stem + "-double.pfm"
        if not os.path.exists(truth):
            ref = args.truth or args.lancer
            if "oracle" in os.path.basename(ref):
                run([ref, stem + ".json", truth])
            else:
                run([ref, "render", stem + ".json", "-o", truth, "--precision", "double",
                     "--width", "1", "--threads", args.threads])
        run([args.lancer, "render", stem + ".json", "-o", stem + "-exact.pfm", "--precision",
             "exact", "--threads", args.threads])
        info = json.loads(run([args.lancer, "render", stem + ".json", "-o", stem + "-auto.pfm",
                               "--threads", args.threads, "--json"]))
        print(f"| {name:32} | {100 * off2(args.lancer, stem + '-exact.pfm', truth):15.3f}% |"
              f" {100 * off2(args.lancer, stem + '-auto.pfm', truth):14.3f}% |"
              f" {info['precision']:10} |", flush=True)


if __name__ == "__main__":
    main()
