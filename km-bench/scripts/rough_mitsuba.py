#!/usr/bin/env python3
"""Rough faces and metals: km against Mitsuba 3's volumetric path tracer.

Each stack is one scattering slab (homogeneous medium, Henyey-Greenstein
phase) between two very wide parallel rectangles: the top face is Mitsuba's
`roughdielectric` (or `dielectric`) into the slab, the bottom face a
`roughconductor` (named metal), `diffuse`, or a `roughdielectric` back into
air. A `directional` emitter lights it at `theta_i`; one 1-pixel
`orthographic` sensor per exit direction looks at the middle of the slab
(scalar variant, `volpath`). The pixel's radiance per unit irradiance on the
surface is the BRDF (above) or BTDF (below): `f = L / (E cos theta_i)`.
Several seeds give Mitsuba's standard error: 16 by default, since the
spread of 4 seeds' means underestimated it by up to 4x at some directions
(docs/rough.md §8). km's multi-flux and Monte Carlo answers of the same
scene files come from the `km` binary.

The totals R and T come by reciprocity: the directional-hemispherical
reflectance at `theta_i` is the radiance leaving the top along `theta_i`
under a uniform sky of unit radiance above the slab, and the transmittance
the radiance leaving the top along it under a uniform sky below (not the
radiance leaving the bottom under the sky above: that is the transmittance
of light arriving from below, which differs where the faces differ). Each
is one 1-pixel sensor just above the top under a `constant` emitter, with
a black plane that shades the sky on the other side: below the slab for R,
above the sensor for T.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

# The stacks (docs/rough.md table R3): alpha of the top face, slab index n,
# g, tau, albedo, bottom, light angle; exit directions [theta, phi].
STACKS = [
    dict(name="clear-coat-ggx-0.05", alpha=0.05, n=1.5, g=0.0, tau=1.0, albedo=0.9,
         bottom=dict(kind="diffuse", albedo=0.5), theta_i=30.0),
    dict(name="rough-top-smooth-bottom", alpha=0.3, n=1.33, g=0.5, tau=0.5, albedo=0.95,
         bottom=dict(kind="air"), theta_i=40.0),
    dict(name="rough-both", alpha=0.2, n=1.5, g=0.7, tau=2.0, albedo=0.99,
         bottom=dict(kind="air", alpha=0.2), theta_i=20.0),
    dict(name="lacquer-over-gold", alpha=0.1, n=1.5, g=0.9, tau=0.5, albedo=0.9,
         bottom=dict(kind="metal", metal="Au", alpha=0.2), theta_i=45.0),
    dict(name="aluminium-base", alpha=0.5, n=1.7, g=0.3, tau=10.0, albedo=0.8,
         bottom=dict(kind="metal", metal="Al", alpha=0.05), theta_i=60.0),
    # (A smooth top cannot be rendered by Mitsuba's volpath under a
    # directional emitter: no path reaches a delta light through a delta
    # interface, so its answer is 0; this stack's top is therefore rough.)
    dict(name="coat-over-rough-al", alpha=0.1, n=1.4, g=0.0, tau=1.0, albedo=0.5,
         bottom=dict(kind="metal", metal="Al", alpha=0.3), theta_i=10.0),
]
DIRS = [[0.0, 0.0], [20.0, 180.0], [35.0, 90.0], [45.0, 180.0], [60.0, 0.0], [75.0, 180.0]]
WAVELENGTH_NM = 550.0


def km_scene(s):
    """The km scene file (TOML) of a stack."""
    lines = [
        "[light]", f"theta_deg = {s['theta_i']}",
        "[spectrum]", f"wavelengths_nm = {WAVELENGTH_NM}",
        "[[layer]]", f"tau = {s['tau']}", f"albedo = {s['albedo']}", f"g = {s['g']}",
        f"n = {s['n']}",
    ]
    if s["alpha"] > 0:
        lines.append(f"roughness = {s['alpha']}")
    b = s["bottom"]
    lines.append("[substrate]")
    if b["kind"] == "diffuse":
        lines += ['kind = "lambertian"', f"albedo = {b['albedo']}"]
    elif b["kind"] == "metal":
        lines += ['kind = "conductor"', f'metal = "{b["metal"]}"']
        if b.get("alpha", 0) > 0:
            lines.append(f"roughness = {b['alpha']}")
    else:
        lines += ['kind = "transparent"', "n = 1.0"]
        if b.get("alpha", 0) > 0:
            lines.append(f"roughness = {b['alpha']}")
    lines += ["[output]", f"directions_deg = {json.dumps(DIRS)}"]
    return "\n".join(lines) + "\n"


def metal_nk(metal, wavelength_nm):
    """n, k of a named metal at a wavelength, interpolated linearly in the
    table km reads (km-core/data/metals_nk.csv), as km does."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "km-core",
                        "data", "metals_nk.csv")
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or line.startswith("metal,"):
                continue
            m, wl, n, k = line.strip().split(",")
            if m == metal:
                rows.append((float(wl), float(n), float(k)))
    rows.sort()
    for (w0, n0, k0), (w1, n1, k1) in zip(rows, rows[1:]):
        if w0 <= wavelength_nm <= w1:
            t = (wavelength_nm - w0) / (w1 - w0)
            return n0 + t * (n1 - n0), k0 + t * (k1 - k0)
    raise ValueError(f"{metal} has no constants at {wavelength_nm} nm")


def mitsuba_scene(mi, s, sensor_dir, below, seed, spp):
    """The Mitsuba scene of a stack with one sensor along `sensor_dir`."""
    d = 1.0  # slab thickness; sigma_t = tau / d
    half = 1.0e4  # lateral half-width: the slab is 2e4 wide, 1 thick
    sigma_t = s["tau"] / d
    medium = {
        "type": "homogeneous",
        "sigma_t": sigma_t,
        "albedo": s["albedo"],
        "phase": {"type": "hg", "g": s["g"]},
    }
    if s["alpha"] > 0:
        top_bsdf = {"type": "roughdielectric", "distribution": "ggx", "alpha": s["alpha"],
                    "int_ior": s["n"], "ext_ior": 1.0, "sample_visible": True}
    else:
        top_bsdf = {"type": "dielectric", "int_ior": s["n"], "ext_ior": 1.0}
    to_world = mi.ScalarTransform4f
    top = {"type": "rectangle", "bsdf": top_bsdf, "interior": medium,
           "to_world": to_world().scale([half, half, 1.0])}
    b = s["bottom"]
    if b["kind"] == "diffuse":
        bot_bsdf = {"type": "diffuse", "reflectance": b["albedo"]}
    elif b["kind"] == "metal":
        # The metal's n, k at the km scene's wavelength, relative to the slab
        # above it (Mitsuba's conductors take the index relative to the
        # medium they face; a named `material` would be relative to vacuum
        # and, in an RGB variant, averaged over a colour channel).
        n, k = metal_nk(b["metal"], WAVELENGTH_NM)
        eta, kk = n / s["n"], k / s["n"]
        bot_bsdf = {"type": "roughconductor", "eta": eta, "k": kk, "distribution": "ggx",
                    "alpha": max(b.get("alpha", 0.0), 1e-4)}
        if b.get("alpha", 0) == 0:
            bot_bsdf = {"type": "conductor", "eta": eta, "k": kk}
    elif b.get("alpha", 0) > 0:
        # Normal up (into the slab): the slab is outside, air inside (below).
        bot_bsdf = {"type": "roughdielectric", "distribution": "ggx", "alpha": b["alpha"],
                    "int_ior": 1.0, "ext_ior": s["n"], "sample_visible": True}
    else:
        bot_bsdf = {"type": "dielectric", "int_ior": 1.0, "ext_ior": s["n"]}
    bottom = {"type": "rectangle", "bsdf": bot_bsdf, "exterior": medium,
              "to_world": to_world().translate([0, 0, -d]).scale([half, half, 1.0])}
    th, ph = math.radians(sensor_dir[0]), math.radians(sensor_dir[1])
    # The exit direction (pointing away from the surface) in Mitsuba's frame:
    # z up, the light arrives from azimuth 0 (it travels towards azimuth 180).
    v = [math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)]
    z0 = 0.0
    if below:
        v[2] = -v[2]
        z0 = -d
    origin = [5.0 * v[0], 5.0 * v[1], z0 + 5.0 * v[2]]
    target = [0.0, 0.0, z0]
    up = [0, 0, 1] if abs(v[2]) < 0.999 else [1, 0, 0]
    ti = math.radians(s["theta_i"])
    light_dir = [-math.sin(ti), 0.0, -math.cos(ti)]
    return {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 50},
        "sensor": {
            "type": "orthographic",
            "to_world": to_world().look_at(origin=origin, target=target, up=up)
            @ to_world().scale([0.5, 0.5, 1.0]),
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
        },
        "emitter": {"type": "directional", "direction": light_dir, "irradiance": 1.0},
        "top": top,
        "bottom": bottom,
    }


def mean_stderr(vals):
    """The mean of the seeds' values and its standard error (from their spread)."""
    m = sum(vals) / len(vals)
    var = sum((x - m) ** 2 for x in vals) / max(len(vals) - 1, 1)
    return m, math.sqrt(var / len(vals))


def finite_render(mi, scene_of, seed, spp, label):
    """The pixel of the scene `scene_of(seed)`; a render whose pixel is not
    finite (one sample's NaN spoils the whole pixel: seen once in 800
    renders, a GGX 0.05 face seen at the normal) is reported and replaced
    by the render of seed `seed + 1000`, and so on."""
    for k in range(seed, seed + 10_000, 1000):
        v = float(mi.render(mi.load_dict(scene_of(k)), spp=spp, seed=k).array[0])
        if math.isfinite(v):
            return v
        print(f"  ({label}, seed {k}: not finite, replaced)", file=sys.stderr)
    raise RuntimeError("no finite render in ten seeds")


def mitsuba_values(mi, s, spp, seeds):
    """BRDF (and BTDF when light leaves below) at DIRS: means and standard errors."""
    out = {}
    cos_i = math.cos(math.radians(s["theta_i"]))
    sides = [("brdf", False)]
    if s["bottom"]["kind"] == "air":
        sides.append(("btdf", True))
    for key, below in sides:
        means, errs = [], []
        for dvec in DIRS:
            vals = []
            for seed in range(seeds):
                vals.append(finite_render(
                    mi, lambda k: mitsuba_scene(mi, s, dvec, below, k, spp), seed, spp,
                    f"{s['name']} {key} {dvec}") / cos_i)
            m, e = mean_stderr(vals)
            means.append(m)
            errs.append(e)
        out[key] = means
        out[key + "_stderr"] = errs
    return out


def totals_scene(mi, s, transmitted, seed, spp):
    """The scene whose one pixel is R (or T, `transmitted`) of the stack at
    `theta_i`, by reciprocity: the radiance leaving the top along `theta_i`
    under a unit uniform sky, shaded by a black plane below the slab (R) or
    above the sensor (T)."""
    tf = mi.ScalarTransform4f
    d = mitsuba_scene(mi, s, [s["theta_i"], 0.0], False, seed, spp)
    del d["emitter"]
    d["sky"] = {"type": "constant", "radiance": 1.0}
    z = 0.5 if transmitted else -1.5
    d["shade"] = {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": 0.0},
                  "to_world": tf().translate([0, 0, z]) @ tf().scale([4.0e4, 4.0e4, 1.0])}
    if transmitted:
        # The sensor between the top (z = 0) and the shade, with a footprint
        # small enough that no ray starts beyond either.
        th = math.radians(s["theta_i"])
        origin = [0.02 * math.sin(th), 0.0, 0.02 * math.cos(th)]
        d["sensor"]["to_world"] = (tf().look_at(origin=origin, target=[0, 0, 0], up=[0, 0, 1])
                                   @ tf().scale([0.002, 0.002, 1.0]))
        d["sensor"]["near_clip"] = 1e-4
    return d


def mitsuba_totals(mi, s, spp, seeds):
    """R (and T when light leaves below) at `theta_i`: means and standard errors."""
    out = {}
    sides = [("reflectance", False)]
    if s["bottom"]["kind"] == "air":
        sides.append(("transmittance", True))
    for key, transmitted in sides:
        vals = []
        for seed in range(seeds):
            vals.append(finite_render(
                mi, lambda k: totals_scene(mi, s, transmitted, k, spp), seed, spp,
                f"{s['name']} {key}"))
        out[key], out[key + "_stderr"] = mean_stderr(vals)
    return out


def report_totals(mt, mf, mc):
    """Print km's totals against Mitsuba's (within max(3 sigma, 1e-3))."""
    for key in ("reflectance", "transmittance"):
        if key not in mt:
            continue
        m, e = mt[key], mt[key + "_stderr"]
        for name, res in (("multiflux", mf), ("mc", mc)):
            if "refused" in res:
                continue
            x = first(res[key])
            ex = first(res["stderr"][key]) if name == "mc" else 0.0
            sig = math.hypot(e, ex)
            ok = abs(x - m) <= max(3 * sig, 1e-3)
            print(f"  {key}: km {name} {x:.5f} +- {ex:.1g} mitsuba {m:.5f} +- {e:.1g} "
                  f"(diff {x - m:+.1e}) {'ok' if ok else 'OFF'}", file=sys.stderr)


def first(v):
    """A number, or the first channel's of a list."""
    return v if isinstance(v, float) else v[0]


def km_values(km, s, method, extra):
    """km's answer for the stack by `method`."""
    with tempfile.NamedTemporaryFile("w", suffix=".toml", delete=False) as f:
        f.write(km_scene(s))
        path = f.name
    try:
        cmd = [km, "solve", path, "--method", method, "--json"] + extra
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            # A refusal (a method that cannot give the stack's answer):
            # recorded, not compared.
            return {"refused": r.stderr.strip()}
        return json.loads(r.stdout)
    finally:
        os.unlink(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--km", required=True, help="the km binary")
    ap.add_argument("--spp", type=int, default=65536)
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--mc-samples", type=int, default=20_000_000)
    ap.add_argument("--mc-cone", type=float, default=1.0,
                    help="half-angle (degrees) of km's Monte Carlo cone bins; Mitsuba's "
                    "values are points, so a lobe needs a narrow cone")
    ap.add_argument("--mf-streams", type=int, default=24,
                    help="streams of km's multi-flux answer (its change from 16 is in "
                    "docs/rough.md §7)")
    ap.add_argument("--stacks", default="",
                    help="comma-separated names of the stacks to run (default: all)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default="rough-mitsuba.json")
    a = ap.parse_args()
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    stacks = STACKS[:2] if a.quick else STACKS
    if a.stacks:
        names = a.stacks.split(",")
        unknown = set(names) - {s["name"] for s in STACKS}
        if unknown:
            ap.error(f"unknown stacks {sorted(unknown)}; known: {[s['name'] for s in STACKS]}")
        stacks = [s for s in STACKS if s["name"] in names]
    spp = 4096 if a.quick else a.spp
    results = []
    for s in stacks:
        mf = km_values(a.km, s, "multiflux", ["--streams", str(a.mf_streams)])
        mc = km_values(a.km, s, "mc", ["--samples", str(a.mc_samples), "--seed", "1",
                                        "--cone", str(a.mc_cone)])
        ms = mitsuba_values(mi, s, spp, a.seeds)
        mt = mitsuba_totals(mi, s, spp, a.seeds)
        results.append(dict(stack=s, directions_deg=DIRS, multiflux=mf, mc=mc, mitsuba=ms,
                            mitsuba_totals=mt))
        print(f"{s['name']}: done", file=sys.stderr)
        report_totals(mt, mf, mc)
        for key in ("brdf", "btdf"):
            if key not in ms:
                continue
            for k, dv in enumerate(DIRS):
                m, e = ms[key][k], ms[key + "_stderr"][k]
                for name, res in (("multiflux", mf), ("mc", mc)):
                    if "refused" in res:
                        print(f"  {key} {dv}: km {name} refused", file=sys.stderr)
                        continue
                    x = first(res[key][k])
                    # Monte Carlo: its own standard error joins Mitsuba's.
                    ex = first(res["stderr"][key][k]) if name == "mc" else 0.0
                    sig = math.hypot(e, ex)
                    ok = abs(x - m) <= max(3 * sig, 0.01 * abs(m))
                    print(f"  {key} {dv}: km {name} {x:.5g} +- {ex:.2g} mitsuba {m:.5g} +- "
                          f"{e:.2g} (z {(x - m) / sig if sig > 0 else 0:+.1f}) "
                          f"{'ok' if ok else 'OFF'}", file=sys.stderr)
    with open(a.out, "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
