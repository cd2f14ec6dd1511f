"""Mitsuba 3 on the equal-work view of ci/peers/equal-work.toml: the Stanford bunny on a 4x4
diffuse floor at y = 0.0335, one point light, primary rays plus one shadow ray per hit
(`direct`, emitter_samples = 1, bsdf_samples = 0), 1 sample per pixel.

    python3 mitsuba_equal_work.py BUNNY.obj VARIANT SIZE[,SIZE...] [RUNS]

Prints one line per size: load/build seconds, then each timed render from `mi.render` to
the image in host memory (a NumPy array), after one warm-up render, and on the CUDA variants
the sum of the render's kernel times (Dr.Jit's kernel history)."""
import os
import sys
import time

import mitsuba as mi

obj, variant, sizes = sys.argv[1], sys.argv[2], [int(s) for s in sys.argv[3].split(",")]
runs = int(sys.argv[4]) if len(sys.argv) > 4 else 5
mi.set_variant(variant)
import numpy as np  # noqa: E402  (after the variant, as Mitsuba's examples do)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from equal_work_scene import scene as equal_work  # noqa: E402


def history(start):
    """Dr.Jit's kernel history: on `start`, cleared and switched on; after a render, the sum
    of its kernels' execution times in ms as the device timed them (the figure beside
    fragtrace's GPU timer queries), or None where the variant records none (LLVM)."""
    import drjit as dr

    try:
        if start:
            dr.kernel_history()  # clears it
            dr.set_flag(dr.JitFlag.KernelHistory, True)
            return None
        h = dr.kernel_history()
        dr.set_flag(dr.JitFlag.KernelHistory, False)
        ms = [e["execution_time"] for e in h if "execution_time" in e]
        return sum(ms) if ms and variant.startswith("cuda") else None
    except (AttributeError, KeyError, TypeError):
        return None


def scene(size):
    return equal_work(mi, size, obj)


for size in sizes:
    t0 = time.perf_counter()
    s = mi.load_dict(scene(size))
    load = time.perf_counter() - t0
    np.asarray(mi.render(s, spp=1))  # warm-up: kernel compilation, caches
    times, kernels = [], []
    for _ in range(runs):
        history(True)
        t = time.perf_counter()
        img = np.asarray(mi.render(s, spp=1))
        times.append((time.perf_counter() - t) * 1e3)
        kernels.append(history(False))
    times.sort()
    k = sorted(x for x in kernels if x is not None)
    print(
        f"mitsuba {variant} {size}x{size}: load+build {load:.3f} s, render ms "
        f"{' '.join(f'{x:.1f}' for x in times)} (median {times[len(times) // 2]:.1f}), "
        + (f"kernel ms {' '.join(f'{x:.2f}' for x in k)} (median {k[len(k) // 2]:.2f}), " if k else "")
        + f"mean {float(img.mean()):.4f}",
        flush=True,
    )
