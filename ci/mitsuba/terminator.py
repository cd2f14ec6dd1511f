#!/usr/bin/env python3
"""Shadow-terminator lit/unlit check against Mitsuba 3 `scalar_rgb` (docs/robustness.md,
"The shadow terminator"), on a held-out mesh: the happy Buddha (a mesh and views that no
test renders), 2 views at SIZE x SIZE, one point light.

fragtrace renders each view diffuse-only (kd = 1, no ambient, max_depth = 0) with
`--terminator exact` and with the default `smooth`, with the `primid` AOV; a pixel is lit
where its value is > 0. Mitsuba traces the same pixel centre (perspective sensor, same eye,
target, vertical fov), and from its hit a shadow ray to the light (`spawn_ray_to`: its own
offset, along the geometric normal only); pixels whose two primary rays hit different
triangles are left out. Counted per view, over the pixels both hit:

  false light   lit by fragtrace (smooth) where both Mitsuba's shadow ray and the exact-origin
                shadow ray are blocked: the light the terminator fix must not create;
  false shadow  unlit by fragtrace (smooth) where Mitsuba's shadow ray reaches the light and
                the light is above both the geometric and the shading horizon: the speckles
                the fix is for.

Usage: terminator.py [--size N] [--ft BINARY]... [--models DIR]
Each --ft binary (default target/release/fragtrace) gets its own row, so a before/after is
one run: terminator.py --ft /path/to/old/fragtrace --ft target/release/fragtrace
Needs: python3 -m pip install mitsuba==3.9.1 drjit==1.5.0 numpy
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser()
ap.add_argument("--size", type=int, default=512)
ap.add_argument("--ft", action="append", default=[])
ap.add_argument("--models", default=os.environ.get("FRAGTRACE_MODEL_PATH", os.path.join(HERE, "../../../shared/models")))
args = ap.parse_args()
fts = args.ft or [os.path.join(HERE, "../../target/release/fragtrace")]

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("scalar_rgb")

MESH = os.path.join(args.models, "happy_buddha/buddha.obj")
LIGHT = [3.0, 6.5, 4.0]
# (eye, target, vertical fov): the Buddha is about 1.8 x 4.3 x 1.8, base at y = 0.
VIEWS = [
    ([0.6, 2.8, 4.6], [-0.15, 2.3, -0.1], 38.0),
    ([-4.2, 1.6, 1.2], [-0.1, 1.5, -0.1], 36.0),
]

SCENE_TOML = """background = [0.0, 0.0, 0.0]
ambient = [0.0, 0.0, 0.0]
max_depth = 0
[camera]
eye = {eye}
look_at = {target}
fov = {fov}
[[lights]]
position = {light}
intensity = 1.0
[materials.white]
albedo = [1.0, 1.0, 1.0]
kd = 1.0
[[objects]]
mesh = "{mesh}"
material = "white"
"""


def fragtrace(ft, view, terminator, work):
    """(lit mask, primid) of fragtrace binary `ft` on view `view`."""
    eye, target, fov = view
    toml = os.path.join(work, "buddha.toml")
    with open(toml, "w") as f:
        f.write(SCENE_TOML.format(eye=eye, target=target, fov=fov, light=LIGHT, mesh=MESH))
    out = os.path.join(work, f"ft-{terminator}.exr")
    subprocess.run([ft, "render", toml, "--backend", "cpu", "--precision", "f64", "--width",
                    str(args.size), "--height", str(args.size), "--terminator", terminator,
                    "--aov", "primid", "-q", "-o", out], check=True)
    img = np.array(mi.Bitmap(out), copy=False)
    aov = mi.Bitmap(os.path.join(work, "ft-" + terminator + ".aov.exr"))  # one channel
    prim = np.array(aov, copy=False).reshape(args.size, args.size, -1)[:, :, 0]
    return img[:, :, :3].max(axis=2) > 0.0, prim


def mitsuba(view):
    """Per pixel: (primitive index or -1, shadow ray blocked, light above both horizons)."""
    eye, target, fov = view
    T = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "sensor": {
            "type": "perspective", "fov": fov, "fov_axis": "y",
            "to_world": T().look_at(origin=eye, target=target, up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": args.size, "height": args.size},
        },
        "mesh": {"type": "obj", "filename": MESH, "face_normals": False},
    })
    sensor = scene.sensors()[0]
    n = args.size
    prim = np.full((n, n), -1, dtype=np.int64)
    blocked = np.zeros((n, n), dtype=bool)
    above = np.zeros((n, n), dtype=bool)
    lp = mi.Point3f(LIGHT)
    for j in range(n):
        for i in range(n):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((i + 0.5) / n, (j + 0.5) / n), mi.Point2f(0.5, 0.5))
            si = scene.ray_intersect(ray)
            if not si.is_valid():
                continue
            prim[j, i] = si.prim_index
            to_l = lp - si.p
            ng = si.n if dr.dot(si.n, ray.d) < 0 else -si.n
            ns = si.sh_frame.n if dr.dot(si.sh_frame.n, ng) > 0 else -si.sh_frame.n
            above[j, i] = dr.dot(to_l, ng) > 0 and dr.dot(to_l, ns) > 0
            blocked[j, i] = scene.ray_test(si.spawn_ray_to(lp))
    return prim, blocked, above


with tempfile.TemporaryDirectory() as work:
    print(f"== shadow terminator vs Mitsuba {mi.__version__} scalar_rgb: happy Buddha, "
          f"{args.size}x{args.size}, light at {LIGHT}")
    total = {}
    for v, view in enumerate(VIEWS):
        m_prim, m_blocked, m_above = mitsuba(view)
        for ft in fts:
            lit_e, prim_e = fragtrace(ft, view, "exact", work)
            lit_s, prim_s = fragtrace(ft, view, "smooth", work)
            same = (m_prim >= 0) & (prim_s == m_prim) & (prim_e == m_prim)
            false_light = same & lit_s & ~lit_e & m_blocked
            false_shadow = same & ~lit_s & ~m_blocked & m_above
            false_shadow_e = same & ~lit_e & ~m_blocked & m_above
            disagree = same & (lit_s != (~m_blocked & m_above))
            t = total.setdefault(ft, [0, 0, 0])
            t[0] += false_light.sum()
            t[1] += false_shadow.sum()
            t[2] += false_shadow_e.sum()
            print(f"view {v}: {ft}: {same.sum()} pixels hit alike; false light {false_light.sum()}; "
                  f"false shadow {false_shadow.sum()} (exact origin {false_shadow_e.sum()}); "
                  f"lit/unlit disagreement {100.0 * disagree.sum() / max(same.sum(), 1):.2f}%")
            ys, xs = np.nonzero(false_light)
            if len(xs):
                print("   false light at", ", ".join(f"({x},{y})" for x, y in list(zip(xs, ys))[:8]))
    for ft, (fl, fs, fse) in total.items():
        print(f"total: {ft}: false light {fl}, false shadow {fs} (exact origin {fse})")
sys.stdout.flush()
