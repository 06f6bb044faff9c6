#!/usr/bin/env python3
"""The speed anchor's Mitsuba side as a user's whole script: import, load, render, EXR written.

usage: anchor_mitsuba.py DIR [--ground rough|smooth] [--variant llvm_ad_mono_polarized]
                         [--spp 16] [--depth 6] [--size 500] [--repeats 2] [--exr FILE]
DIR holds the meshes written by anchor_landing.py. Prints one JSON line:
  exr_written  wall-clock time [s since the epoch] at which the EXR was on disk (the caller, which
               noted the time before starting this process, gets the whole script's time);
  import_s, load_s, first_render_s (kernels from Dr.Jit's cache on disk, or compiled), exr_s;
  render_s     the renders after that one, each of the same spp (kernels in memory): Mitsuba's
               render-only time, as anchor_landing.py times it.
Mitsuba's LLVM variants need libLLVM: Debian's libllvm19 with
DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so (Mitsuba 3.9, Dr.Jit 1.2 and later).
Imports neither pmmw nor trimesh, so that the script's time is Mitsuba's own.
"""

import argparse
import json
import os
import time


def scene_dict(mi, d, ground="rough", size=500, spp=16, depth=6):
    """Mitsuba's description of the anchor (meshes in ``d``); ``ground``: rough (GGX alpha 0.2,
    ``roughdielectric``) or smooth (``dielectric``)."""
    ground_bsdf = (
        {"type": "roughdielectric", "int_ior": 1.9, "alpha": 0.2}
        if ground == "rough"
        else {"type": "dielectric", "int_ior": 1.9}
    )
    return {
        "type": "scene",
        "integrator": {"type": "stokes", "integrator": {"type": "path", "max_depth": depth}},
        "sensor": {
            "type": "perspective",
            "fov": 10,
            "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, -1000, 70], target=[0, 300, 0], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "sky": {"type": "constant", "radiance": {"type": "spectrum", "value": 0.1}},
        "ground": {"type": "ply", "filename": os.path.join(d, "ground.ply"), "bsdf": ground_bsdf},
        "runway": {
            "type": "ply",
            "filename": os.path.join(d, "runway.ply"),
            "bsdf": {"type": "dielectric", "int_ior": 1.6},
        },
        "plates": {
            "type": "ply",
            "filename": os.path.join(d, "plates.ply"),
            "bsdf": {"type": "conductor", "material": "Al"},
        },
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--ground", choices=("rough", "smooth"), default="rough")
    ap.add_argument("--variant", default="llvm_ad_mono_polarized")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--depth", type=int, default=6)
    ap.add_argument("--size", type=int, default=500)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--exr", default=None)
    a = ap.parse_args()
    t = time.perf_counter()
    import mitsuba as mi

    mi.set_variant(a.variant)
    out = {"import_s": time.perf_counter() - t}
    t = time.perf_counter()
    scene = mi.load_dict(scene_dict(mi, a.dir, a.ground, a.size, a.spp, a.depth))
    out["load_s"] = time.perf_counter() - t
    t = time.perf_counter()
    img = mi.render(scene, spp=a.spp)
    mi.Bitmap(img).write(a.exr or os.path.join(a.dir, f"mitsuba_{a.ground}.exr"))  # evaluates the image
    out["exr_written"] = time.time()
    out["first_render_s"] = time.perf_counter() - t  # render and EXR
    out["render_s"] = []
    for _ in range(a.repeats):
        t = time.perf_counter()
        img = mi.render(scene, spp=a.spp)
        img.numpy()  # (the render is lazy until evaluated)
        out["render_s"].append(time.perf_counter() - t)
    out["paths"] = a.size * a.size * a.spp
    out["mitsuba"] = mi.__version__
    import drjit

    out["drjit"] = drjit.__version__
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
