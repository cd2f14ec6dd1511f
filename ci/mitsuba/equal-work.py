#!/usr/bin/env python3
"""The equal-work render in Mitsuba 3 on the CPU, `scalar_rgb` (Embree's BVH, one ray at a
time) or `llvm_ad_rgb` (Embree's packets, the integrator JIT-compiled across the lanes:
needs LLVM 16 or newer, `DRJIT_LIBLLVM_PATH` pointing at its libLLVM), one timed frame per
process so that the whole process can be timed too (ci/peers/
mitsuba_equal_work.py times several frames of one process, for the GPU variants).

The scene of ci/peers/equal-work.toml: the Stanford bunny on a 4x4 diffuse floor at
y = 0.0335, one point light at (-0.6, 1.2, 0.9), camera eye (-0.2, 0.17, 0.36) looking at
(-0.015, 0.1, 0), vertical fov 32, 1 sample per pixel; the `direct` integrator with
`emitter_samples = 1`, `bsdf_samples = 0`: a primary ray and one shadow ray per hit, the
work of fragtrace's `max_depth = 0`.

Prints one line: load_build_s (mi.load_dict: OBJ load and Embree build), render_s (mi.render
of the frame, after a warm-up render that pays the one-time costs), rays.

Usage: equal-work.py [--size N] [--threads T] [--variant V] [--models DIR] [--out FILE.exr]
"""
import argparse
import os
import sys
import time

ap = argparse.ArgumentParser()
ap.add_argument("--size", type=int, default=1024)
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--models", default=os.environ.get("FRAGTRACE_MODEL_PATH", "../shared/models"))
ap.add_argument("--variant", default="scalar_rgb", choices=["scalar_rgb", "llvm_ad_rgb"])
ap.add_argument("--out", default="")
args = ap.parse_args()

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant(args.variant)
dr.set_thread_count(args.threads)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "peers"))
from equal_work_scene import scene  # noqa: E402

scene_dict = scene(mi, args.size, os.path.join(args.models, "bunny/stanford-bunny.obj"))



def render():
    """One frame to the image in memory: the LLVM variant's result is lazy until evaluated."""
    img = mi.render(scene, spp=1)
    dr.eval(img)
    dr.sync_thread()
    return img


t0 = time.perf_counter()
scene = mi.load_dict(scene_dict)
t1 = time.perf_counter()
render()  # warm-up: the first render pays one-time set-up (the LLVM variant's compilation)
t2 = time.perf_counter()
img = render()
t3 = time.perf_counter()
if args.out:
    mi.Bitmap(img).write(args.out)
print(f"load_build_s {t1 - t0:.4f} render_s {t3 - t2:.4f} warmup_s {t2 - t1:.4f} "
      f"size {args.size} threads {args.threads} variant {args.variant}")
