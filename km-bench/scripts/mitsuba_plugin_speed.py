"""Speed of the km Mitsuba 3 plugin against Mitsuba's own `roughplastic`, and
a render of clear-coated spheres (docs/python.md §11, "Speed").

    python km-bench/scripts/mitsuba_plugin_speed.py OUTDIR [--variant llvm_ad_rgb]
        [--spp 16] [--width 384] [--reps 5] [--bsdf-samples 1000000]
        [--coat-roughness A0,A1,A2]

Three spheres of km stacks (a clear coat of index 1.5 over a pigment layer
over a white ground, three pigments and thicknesses) in a row, and the same
row with `roughplastic` (int_ior 1.5, GGX, diffuse reflectances near the km
stacks' albedos), each on a grey floor under a constant sky and a spherical
lamp, path tracer of depth 8. By default the km coats are smooth (their
mirror image of the lamp is a delta lobe) and roughplastic's alpha is 0.05,
0.2, 0.5. With --coat-roughness A0,A1,A2 the km coat of sphere i has a rough
top face, GGX alpha Ai (the layer's `roughness`; km gives the BSDF table
through rough faces from alpha 0.1, docs/rough.md §3, §7), and
roughplastic's alpha is Ai too, so each column compares like with like.
Writes OUTDIR/km-spheres.exr and .png (and the roughplastic row,
roughplastic-spheres.exr/.png; both rows, spheres.exr/.png) and prints:

* tables: the build time of each km table (one km.bsdf solve tabulated on
  the plugin's grid) and its count of negative values (the truncated
  series' ringing; the plugin clamps them to 0 in eval and in its sampling
  weights);
* render: wall time per render (median of --reps interleaved runs, after one
  warm-up render that includes the JIT compilation), camera samples/s
  (pixels * spp / time), and the ratio km / roughplastic;
* bsdf: BSDF.sample followed by BSDF.eval_pdf on --bsdf-samples random
  incidences at once (vectorised variants; one call per sample in scalar
  ones, --bsdf-samples // 100 of them), median of --reps, samples/s; the
  first km sphere against roughplastic at the first sphere's alpha (0.2
  without --coat-roughness).

Set DRJIT_LIBLLVM_PATH to a libLLVM >= 16 where Dr.Jit's default one cannot
compile its kernels (LLVM 15 on x86: "Cannot select ... fminimum").
"""

from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import time
from typing import Any

import numpy as np

COAT = """
[[layer]]            # clear coat
{roughness}sigma_a = 0.0005
sigma_s = 0.0005
thickness = 20.0
g = 0.0
n = 1.5

[[layer]]            # pigment
sigma_a = {sigma_a}
sigma_s = {sigma_s}
thickness = {thickness}
g = 0.4
n = 1.5

[substrate]
kind = "lambertian"
albedo = 0.8
"""
# Red, green and blue-ish pigments of different thicknesses (in the units of 1/sigma).
PIGMENTS = [
    ([0.01, 0.6, 0.8], [1.5, 1.2, 1.0], 4.0),
    ([0.5, 0.05, 0.6], [1.0, 1.2, 1.0], 1.5),
    ([0.9, 0.5, 0.02], [0.6, 0.8, 1.2], 0.6),
]
ALPHAS = [0.05, 0.2, 0.5]
PLASTIC_RGB = [[0.6, 0.15, 0.1], [0.15, 0.5, 0.12], [0.1, 0.2, 0.6]]


def km_scenes(rough: list[float] | None = None) -> list[str]:
    """The three km stacks; with ``rough``, coat i's top face GGX of alpha rough[i]."""
    return [COAT.format(sigma_a=a, sigma_s=s, thickness=t,
                        roughness=f"roughness = {rough[i]}\n" if rough else "")
            for i, (a, s, t) in enumerate(PIGMENTS)]


def scene_dict(mi: Any, kind: str, width: int, height: int, spp: int,
               rough: list[float] | None = None) -> dict[str, Any]:
    T = mi.ScalarTransform4f
    d: dict[str, Any] = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 8},
        "sensor": {
            "type": "perspective", "fov": 40,
            "to_world": T().look_at(origin=[0, 2.0, 8.0], target=[0, 0.7, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp, "seed": 1},
        },
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.4}},
        "lamp": {"type": "sphere", "center": [-4.0, 6.0, 5.0], "radius": 0.6,
                 "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 60.0}}},
        "floor": {
            "type": "rectangle",
            "to_world": T().rotate([1, 0, 0], -90).scale([10, 10, 1]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
        },
    }
    texts = km_scenes(rough)
    alphas = rough or ALPHAS
    for i in range(3):
        bsdf: dict[str, Any]
        if kind == "km":
            bsdf = {"type": "km", "scene": texts[i]}
        else:
            bsdf = {"type": "roughplastic", "int_ior": 1.5, "alpha": alphas[i],
                    "distribution": "ggx",
                    "diffuse_reflectance": {"type": "rgb", "value": PLASTIC_RGB[i]}}
        d[f"sphere{i}"] = {"type": "sphere", "center": [2.3 * (i - 1), 0.9, 0], "radius": 0.9,
                           "bsdf": bsdf}
    return d


def write_image(mi: Any, img: Any, path: pathlib.Path) -> None:
    """EXR and sRGB PNG, each via a temporary file renamed into place."""
    for suffix in (".exr", ".png"):
        out = path.with_suffix(suffix)
        tmp = out.with_name(f".{out.stem}.tmp{suffix}")
        mi.util.write_bitmap(str(tmp), img, write_async=False)
        tmp.replace(out)


def time_render(mi: Any, dr: Any, scene: Any) -> float:
    start = time.perf_counter()
    img = mi.render(scene)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - start


def time_bsdf(mi: Any, dr: Any, bsdf: Any, n: int, jit: bool, seed: int) -> float:
    """Seconds for n BSDF.sample + BSDF.eval_pdf at random incidences (upper hemisphere)."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(3, n))
    w[2] = np.abs(w[2])
    w = (w / np.linalg.norm(w, axis=0)).astype(np.float32)
    u = rng.random((3, n)).astype(np.float32)
    ctx = mi.BSDFContext()
    if jit:
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(w)
        s1, s2 = mi.Float(u[0]), mi.Point2f(u[1:])
        dr.eval(si, s1, s2)
        dr.sync_thread()
        start = time.perf_counter()
        bs, weight = bsdf.sample(ctx, si, s1, s2)
        val, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
        dr.eval(bs, weight, val, pdf)
        dr.sync_thread()
        return time.perf_counter() - start
    sis = []
    for i in range(n):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*w[:, i].tolist())
        sis.append(si)
    start = time.perf_counter()
    for i in range(n):
        bs, weight = bsdf.sample(ctx, sis[i], float(u[0, i]),
                                 mi.Point2f(float(u[1, i]), float(u[2, i])))
        bsdf.eval_pdf(ctx, sis[i], bs.wo)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=pathlib.Path)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--width", type=int, default=384)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--bsdf-samples", type=int, default=1_000_000)
    ap.add_argument("--coat-roughness", default=None, metavar="A0,A1,A2",
                    help="GGX alpha of the km coats' top faces, one per sphere (km from "
                         "0.1), and roughplastic's alpha; default: smooth km coats, "
                         "roughplastic alpha 0.05, 0.2, 0.5")
    args = ap.parse_args()
    if not args.outdir.is_dir():
        ap.error(f"{args.outdir} is not a directory")
    if args.reps < 1 or args.spp < 1 or args.width < 2 or args.bsdf_samples < 100:
        ap.error("needs --reps >= 1, --spp >= 1, --width >= 2, --bsdf-samples >= 100")
    rough: list[float] | None = None
    if args.coat_roughness is not None:
        try:
            rough = [float(x) for x in args.coat_roughness.split(",")]
        except ValueError:
            ap.error(f"--coat-roughness: not numbers: {args.coat_roughness!r}")
        if len(rough) != 3 or not all(0.0 < a <= 1.0 for a in rough):
            ap.error("--coat-roughness needs three values in (0, 1], one per sphere")

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    import km.mitsuba

    km.mitsuba.register()
    jit = not args.variant.startswith("scalar")
    width, height = args.width, args.width // 2
    coats = ("smooth km coats" if rough is None else
             "km coats GGX alpha " + ", ".join(f"{a:g}" for a in rough))
    alphas = rough or ALPHAS
    print(f"variant {args.variant}, {width} x {height} pixels, {args.spp} spp, path depth 8; "
          f"{coats}; roughplastic alpha {', '.join(f'{a:g}' for a in alphas)}; "
          f"load average {os.getloadavg()[0]:.1f}")
    # The km tables first, each timed (the plugin finds them in its cache).
    for i, text in enumerate(km_scenes(rough)):
        t0 = time.perf_counter()
        tab = km.mitsuba.table_for(text)
        dt = time.perf_counter() - t0
        f = np.concatenate([v.ravel() for (_, tr), v in tab.f.items()
                            if tab.transmits or not tr])
        print(f"table of sphere {i}: built in {dt:.2f} s; {int((f < 0).sum())} of {f.size} "
              f"values negative (smallest {f.min():.3g}, largest {f.max():.3g}; "
              f"clamped to 0 by the plugin)")
    t0 = time.perf_counter()
    scenes = {k: mi.load_dict(scene_dict(mi, k, width, height, args.spp, rough))
              for k in ("km", "roughplastic")}
    print(f"scenes loaded in {time.perf_counter() - t0:.2f} s")
    times: dict[str, list[float]] = {"km": [], "roughplastic": []}
    rows = []
    for k, sc in scenes.items():  # warm-up (JIT compilation) and the images
        start = time.perf_counter()
        img = mi.render(sc)
        dr.eval(img)
        dr.sync_thread()
        print(f"first render ({k}, with compilation): {time.perf_counter() - start:.2f} s")
        write_image(mi, img, args.outdir / f"{k}-spheres")
        rows.append(np.array(img))
    # Both rows in one image: km above, roughplastic below.
    write_image(mi, mi.TensorXf(np.concatenate(rows, axis=0)), args.outdir / "spheres")
    for _ in range(args.reps):
        for k, sc in scenes.items():
            times[k].append(time_render(mi, dr, sc))
    samples = width * height * args.spp
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"\n{'render':<14} {'median s':>9} {'min s':>8} {'samples/s':>12}")
    for k in times:
        print(f"{k:<14} {med[k]:9.3f} {min(times[k]):8.3f} {samples / med[k]:12.3e}")
    ratios = sorted(a / b for a, b in zip(times["km"], times["roughplastic"]))
    print(f"km / roughplastic render time: {med['km'] / med['roughplastic']:.2f} "
          f"(per interleaved pair {ratios[0]:.2f}-{ratios[-1]:.2f}); "
          f"load average {os.getloadavg()[0]:.1f}")

    n = args.bsdf_samples if jit else args.bsdf_samples // 100
    alpha0 = 0.2 if rough is None else rough[0]
    bsdfs = {"km": mi.load_dict({"type": "km", "scene": km_scenes(rough)[0]}),
             "roughplastic": mi.load_dict({"type": "roughplastic", "int_ior": 1.5,
                                           "alpha": alpha0})}
    for b in bsdfs.values():  # warm-up
        time_bsdf(mi, dr, b, min(n, 1000), jit, 0)
    bt: dict[str, list[float]] = {"km": [], "roughplastic": []}
    for rep in range(args.reps):
        for k, b in bsdfs.items():
            bt[k].append(time_bsdf(mi, dr, b, n, jit, rep + 1))
    print(f"\nbsdf: km sphere 0 ({'smooth' if rough is None else f'alpha {rough[0]:g}'}) "
          f"against roughplastic alpha {alpha0:g}; load average {os.getloadavg()[0]:.1f}")
    print(f"{'bsdf sample+eval_pdf':<22} {'n':>9} {'median s':>9} {'samples/s':>12} "
          f"{'us/sample':>10}")
    for k in bt:
        m = statistics.median(bt[k])
        print(f"{k:<22} {n:9d} {m:9.4f} {n / m:12.3e} {1e6 * m / n:10.3f}")
    ratio = statistics.median(bt["km"]) / statistics.median(bt["roughplastic"])
    print(f"km / roughplastic bsdf time: {ratio:.2f}")


if __name__ == "__main__":
    main()
