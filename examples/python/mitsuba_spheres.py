"""Render the seed's three-layer paint with the km Mitsuba 3 plugin, next to
Mitsuba's own `roughplastic` for scale (docs/python.md, "Mitsuba 3").

    python examples/python/mitsuba_spheres.py [OUT.png] [--spp N] [--width W]
        [--variant scalar_rgb|llvm_ad_rgb|...]

Left: a sphere of the km stack of examples/seed-three-layers.toml (a smooth
interface of index 1.3 over an isotropic scattering layer over a Lambertian
reflector of albedo 0.8): its whole BSDF from one km solve, with the mirror
reflection of the interface as a delta lobe. Right: `roughplastic`
(int_ior 1.3, alpha 0.05, diffuse reflectance 0.6). Both on a grey floor,
under a constant sky and a directional light. Needs `pip install mitsuba`.
"""

from __future__ import annotations

import argparse
import pathlib
import time
from typing import Any

import drjit as dr
import mitsuba as mi

import km.mitsuba

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]


def scene_dict(width: int, height: int, spp: int) -> dict[str, Any]:
    paint = (REPO / "examples" / "seed-three-layers.toml").read_text()
    T = mi.ScalarTransform4f
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 8},
        "sensor": {
            "type": "perspective", "fov": 34,
            "to_world": T().look_at(origin=[0, 2.2, 8.5], target=[0, 0.8, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "gaussian"}},
            "sampler": {"type": "independent", "sample_count": spp, "seed": 1},
        },
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.35}},
        "sun": {"type": "directional", "direction": [0.6, -1.0, -0.5],
                "irradiance": {"type": "rgb", "value": 2.2}},
        "km_sphere": {
            "type": "sphere", "center": [-1.15, 0.9, 0], "radius": 0.9,
            "bsdf": {"type": "km", "scene": paint},
        },
        "plastic_sphere": {
            "type": "sphere", "center": [1.15, 0.9, 0], "radius": 0.9,
            "bsdf": {"type": "roughplastic", "int_ior": 1.3, "alpha": 0.05,
                     "diffuse_reflectance": {"type": "rgb", "value": 0.6}},
        },
        "floor": {
            "type": "rectangle",
            "to_world": T().rotate([1, 0, 0], -90).scale([8, 8, 1]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}},
        },
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", default=str(REPO / "docs" / "python-mitsuba-spheres.png"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--variant", default="scalar_rgb")
    args = ap.parse_args()
    mi.set_variant(args.variant)
    km.mitsuba.register()
    start = time.perf_counter()
    scene = mi.load_dict(scene_dict(args.width, args.width // 2, args.spp))
    loaded = time.perf_counter()
    img = mi.render(scene)
    dr.eval(img)  # a vectorised variant renders lazily
    dr.sync_thread()
    done = time.perf_counter()
    out = pathlib.Path(args.out)
    tmp = out.with_name(f".{out.stem}.tmp{out.suffix}")
    write_bitmap: Any = mi.util.write_bitmap  # untyped in mitsuba's stubs
    write_bitmap(str(tmp), img, write_async=False)  # sRGB, 8 bit
    tmp.replace(out)
    print(f"wrote {out}: {args.width}x{args.width // 2}, {args.spp} spp; "
          f"load (km table) {loaded - start:.2f} s, render {done - loaded:.1f} s")


if __name__ == "__main__":
    main()
