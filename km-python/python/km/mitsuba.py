"""A Mitsuba 3 BSDF plugin for km stacks (``km.mitsuba``).

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")         # or scalar_rgb, scalar_spectral, llvm_ad_spectral, ...
    import km.mitsuba
    km.mitsuba.register()                 # the plugin "km"
    bsdf = mi.load_dict({"type": "km", "scene": open("paint.toml").read()})

The plugin evaluates, samples (with its pdf) and reports the albedo of the
whole BSDF of a km stack: one :func:`km.bsdf` solve when the plugin is
loaded, tabulated on a ``(theta_i, theta_o, phi)`` grid
(:class:`km._table.BsdfTable`; trilinear interpolation, sampling by
inverting the table's cell distribution, eq. M1 of docs/python.md). The
delta parts are delta lobes: mirror reflection (``DeltaReflection``) and,
when the stack transmits, the unscattered beam (``DeltaTransmission``,
refracted by Snell's law between the ambient and the substrate). A stack
over an opaque substrate is one-sided (black from below, as Mitsuba's own
one-sided BSDFs); a transmitting stack is two-sided, its lower face lit
through the substrate (``side="below"`` of :meth:`km.Bsdf.eval`).

One code path serves every variant but the polarised ones: the table is
flattened into arrays of the variant (Dr.Jit arrays in the ``llvm_*`` and
``cuda_*`` variants, float64 ``array.array`` in the scalar ones) and eval,
pdf and sample are written as array operations over them (gathers of the
table's corners, interpolation weights as arrays, a binary search in the
cumulative cell distribution of the chosen row), so a vectorised variant
traces them once for a whole wavefront of rays.

Properties of the plugin: ``scene`` (the scene file's TOML text, or a path
to it), ``streams`` (int, optional), ``n_theta`` (46), ``n_phi`` (37).
Channels: a one-channel scene is grey in every variant; an RGB variant
takes a three-channel scene as R, G, B; a spectral variant interpolates a
scene with wavelengths (linear, clamped at the ends).
"""

from __future__ import annotations

import array
import math
import os
from typing import Any, Callable

import numpy as np

import km
from ._table import DIRECT, REFL, SIDES, SPEC, TRANS, BsdfTable

__all__ = ["register", "table_for", "PLUGIN"]

PLUGIN = "km"
_CACHE: dict[tuple[Any, ...], BsdfTable] = {}
# Guards denominators that a select discards (scalar variants evaluate both
# branches of a select eagerly, in Python).
_TINY = 1e-30


def table_for(scene_text: str, streams: int | None = None, n_theta: int = 46,
              n_phi: int = 37) -> BsdfTable:
    """The table of a scene (cached per arguments: loading a scene twice solves once)."""
    key = (scene_text, streams, n_theta, n_phi)
    if key not in _CACHE:
        b = km.bsdf(km.Scene.from_toml(scene_text), streams=streams)
        _CACHE[key] = BsdfTable(b, n_theta=n_theta, n_phi=n_phi)
    return _CACHE[key]


_TOTALS = ("reflectance", "transmittance", "reflectance_specular", "transmittance_direct")
# The flattened arrays of a table per variant, built once (the tables live
# in _CACHE for the process, so their ids are not reused).
_ARRAYS: dict[tuple[int, str], tuple[BsdfTable, dict[str, Any]]] = {}


def _flatten(tab: BsdfTable) -> dict[str, np.ndarray]:
    """A :class:`BsdfTable` as flat arrays, channel innermost (float64).

    ``f``: ``[block, j, k, l, c]`` with ``block = 2 side + transmitted``
    (zeros where the stack has no such side or lobe); ``delta``:
    ``[side, lobe (SPEC, DIRECT), j, c]``; ``totals``: ``[side, key, j, c]``;
    ``wn``: the cell weights of eq. M1 divided by ``2 A dmu dphi``,
    ``[block, j, k, l]``; ``cdf``: each row's cumulative cell weights
    normalised to 1, ``[block, j, k * (n_phi - 1) + l]``; ``mu_top``,
    ``d_mu``: the sampling cells' upper edge and extent in ``cos theta_o``;
    ``wl``: the scene's wavelengths (nm; ``[0]`` without)."""
    n, m, c = len(tab.theta), len(tab.phi), tab.channels
    f = np.zeros((4, n, n, m, c))
    wn = np.zeros((4, n, n, m - 1))
    cdf = np.zeros((4, n, n * (m - 1)))
    delta = np.zeros((2, 2, n, c))
    totals = np.zeros((2, 4, n, c))
    for si, side in enumerate(SIDES):
        if side not in tab.lobes:
            continue
        for di, lobe in enumerate((SPEC, DIRECT)):
            delta[si, di] = tab.delta[(side, lobe)].T
        for ki, key in enumerate(_TOTALS):
            totals[si, ki] = tab.totals[side][key].T
        for tr in (False, True):
            b = 2 * si + int(tr)
            f[b] = np.moveaxis(tab.f[(side, tr)], 0, -1)
            w = tab.weights[(side, tr)]
            a = w.reshape(n, -1).sum(axis=1)  # A_j,s
            ok = a > 0
            den = 2.0 * np.where(ok, a, 1.0)[:, None, None] * tab.d_mu[None, :, None] * tab.d_phi
            wn[b] = np.where(ok[:, None, None], w / den, 0.0)
            c_ = tab.cdf[(side, tr)]
            cdf[b] = np.where(ok[:, None], c_ / np.where(ok, c_[:, -1], 1.0)[:, None], 0.0)
    return {"f": f, "wn": wn, "cdf": cdf, "delta": delta, "totals": totals,
            "mu_top": tab.mu_edges[:-1], "d_mu": tab.d_mu,
            "wl": np.asarray(tab.wavelengths_nm or [0.0], dtype=float)}


def _lobe_tables(tab: BsdfTable, enabled: tuple[bool, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Lobe probabilities ``P[side, j, lobe]`` renormalised over the enabled
    lobes, and the thresholds ``[side, j, 0..2]`` that pick a lobe from one
    uniform number (the lobe is the count of thresholds at or below it; the
    thresholds at and after the last lobe of nonzero probability are 2,
    above any number drawn), with ``[side, j, 3]`` = 1 where some enabled
    lobe has a nonzero probability, else 0."""
    n = len(tab.theta)
    p = np.zeros((2, n, 4))
    thr = np.zeros((2, n, 4))
    mask = np.asarray(enabled, dtype=float)
    for si, side in enumerate(SIDES):
        if side not in tab.lobes:
            thr[si, :, :3] = 2.0
            continue
        q = tab.lobes[side] * mask[None, :]
        s = q.sum(axis=1)
        q = np.where(s[:, None] > 0, q / np.where(s > 0, s, 1.0)[:, None], 0.0)
        p[si] = q
        cum = np.cumsum(q, axis=1)
        for j in range(n):
            nz = np.nonzero(q[j] > 0)[0]
            if nz.size == 0:
                thr[si, j, :3] = 2.0
                continue
            last = int(nz[-1])
            thr[si, j, :3] = [cum[j, k] if k < last else 2.0 for k in range(3)]
            thr[si, j, 3] = 1.0
    return p, thr


def register(name: str = PLUGIN) -> type:
    """Register the plugin with Mitsuba (a variant must be set) and return its class."""
    import drjit as dr
    import mitsuba as mi

    variant = mi.variant()
    if variant is None:
        raise km.KmError("km.mitsuba needs a Mitsuba variant (mi.set_variant(...)) first")
    if "polarized" in variant:
        raise km.KmError(f"km.mitsuba has no polarised BSDF, so not {variant}")
    spectral = "spectral" in variant
    jit = not variant.startswith("scalar")
    F = mi.BSDFFlags
    Float, UInt = mi.Float, mi.UInt32
    binary_search: Any = dr.binary_search  # untyped in drjit's stubs

    gather: Callable[..., Any]
    if jit:
        def to_array(x: np.ndarray) -> Any:
            return Float(np.ascontiguousarray(x, dtype=np.float32).ravel())

        def gather(buf: Any, idx: Any, active: Any = True) -> Any:
            return dr.gather(Float, buf, idx, active)
    else:
        def to_array(x: np.ndarray) -> Any:
            # Indexing an array.array gives a Python float (fast; 8 bytes an entry).
            return array.array("d", np.asarray(x, dtype=float).ravel())

        def gather(buf: Any, idx: Any, active: Any = True) -> Any:
            return buf[idx] if active else 0.0

    def as_uint(b: Any) -> Any:
        return dr.select(b, UInt(1), UInt(0))

    def neg(b: Any) -> Any:  # `~` of a mask; `not` of a scalar variant's bool
        return ~b if jit else not b

    # Without mitsuba's stubs mi.BSDF is Any (misc); with them the ignore is unused.
    class KmBSDF(mi.BSDF):  # type: ignore[misc, unused-ignore]
        """A km stack's whole BSDF (see the module ``km.mitsuba``)."""

        def __init__(self, props: Any) -> None:
            mi.BSDF.__init__(self, props)
            text = props["scene"] if "scene" in props else None
            if text is None:
                raise km.KmError("the km plugin needs the property `scene` (TOML text or path)")
            if "\n" not in text and os.path.isfile(text):
                with open(text, encoding="utf-8") as fh:
                    text = fh.read()
            streams = props["streams"] if "streams" in props else None
            n_theta = props["n_theta"] if "n_theta" in props else 46
            n_phi = props["n_phi"] if "n_phi" in props else 37
            self.table = table_for(text, streams, int(n_theta), int(n_phi))
            tab = self.table
            if tab.channels != 1:
                if spectral and not tab.wavelengths_nm:
                    raise km.KmError("a spectral variant needs a scene with wavelengths "
                                     f"(this one has {tab.channels} channels without)")
                if not spectral and tab.channels != 3:
                    raise km.KmError(f"an RGB variant needs a scene of 1 or 3 channels "
                                     f"(R, G, B), not {tab.channels}")
            side_flags = F.FrontSide | (F.BackSide if tab.transmits else F.Empty)
            comps = [F.DeltaReflection | side_flags, F.GlossyReflection | side_flags]
            if tab.transmits:
                comps += [F.DeltaTransmission | side_flags, F.GlossyTransmission | side_flags]
            self.m_components = comps
            flags: Any = F.Empty
            for c in comps:
                flags = flags | c
            self.m_flags = flags
            self._build(tab)

        def _build(self, tab: BsdfTable) -> None:
            n, m = len(tab.theta), len(tab.phi)
            self._n, self._m, self._c, self._ncell = n, m, tab.channels, n * (m - 1)
            self._dt = math.radians(tab.d_theta)
            self._theta_max = math.radians(float(tab.theta[-1]))
            self._dp = tab.d_phi
            # n_in / n_out of the unscattered beam from above, from below (an
            # opaque substrate has no index below: no beam, the ratio unused).
            n_a, n_b = tab.n_above, tab.n_below if tab.transmits else tab.n_above
            self._n_in_out = (n_a / n_b, n_b / n_a)
            key = (id(tab), str(variant))
            if key not in _ARRAYS:
                _ARRAYS[key] = (tab, {k: to_array(v) for k, v in _flatten(tab).items()})
            a = _ARRAYS[key][1]
            self._f, self._wn, self._cdf = a["f"], a["wn"], a["cdf"]
            self._delta, self._totals = a["delta"], a["totals"]
            self._mu_top, self._d_mu, self._wl = a["mu_top"], a["d_mu"], a["wl"]
            self._wl_list = [float(x) for x in tab.wavelengths_nm or [0.0]]
            self._lobe_cache: dict[tuple[bool, ...], tuple[Any, Any]] = {}

        # -- helpers --------------------------------------------------------

        def _lobe_arrays(self, enabled: tuple[bool, ...]) -> tuple[Any, Any]:
            if enabled not in self._lobe_cache:
                p, thr = _lobe_tables(self.table, enabled)
                self._lobe_cache[enabled] = (to_array(p), to_array(thr))
            return self._lobe_cache[enabled]

        def _channel_map(self, si: Any) -> list[tuple[Any, Any]]:
            """Per output channel: the table channel below it and the weight of the next.

            Grey and RGB: the channels themselves (weight 0); spectral: the
            path's wavelengths between the scene's (linear, clamped)."""
            c = self._c
            if c == 1:
                return [(UInt(0), Float(0.0))]
            if not spectral:
                return [(UInt(i), Float(0.0)) for i in range(c)]
            out = []
            wl = self._wl_list
            for i in range(len(si.wavelengths)):
                lam = si.wavelengths[i]
                c0 = UInt(0)
                for node in wl[1:-1]:
                    c0 = c0 + as_uint(lam >= node)
                w0 = gather(self._wl, c0)
                w1 = gather(self._wl, c0 + 1)
                out.append((c0, dr.clip((lam - w0) / (w1 - w0), 0.0, 1.0)))
            return out

        def _fetch(self, buf: Any, bases: list[Any], weights: list[Any],
                   cmap: list[tuple[Any, Any]], active: Any) -> Any:
            """sum_corners weight * buf[base, channel] as a Spectrum (bases index
            ``[..., c]`` rows of ``self._c`` channels)."""
            c = self._c
            if not jit and not active:  # a scalar variant skips what it would discard
                return [0.0] * len(cmap)
            vals = []
            for c0, tw in cmap:
                acc: Any = Float(0.0)
                for b, w in zip(bases, weights):
                    v = gather(buf, b * c + c0, active)
                    if c > 1 and spectral:
                        v = v + tw * (gather(buf, b * c + c0 + 1, active) - v)
                    acc = dr.fma(w, v, acc)
                vals.append(acc)
            return vals

        def _spectrum(self, vals: list[Any]) -> Any:
            if len(vals) == 1:
                return mi.Spectrum(vals[0])
            return mi.Spectrum(*vals)

        def _enabled(self, ctx: Any) -> tuple[bool, ...]:
            """Enabled lobes in the table's order: SPEC, DIRECT, REFL, TRANS."""
            tr = self.table.transmits
            return (bool(ctx.is_enabled(F.DeltaReflection, 0)),
                    bool(tr and ctx.is_enabled(F.DeltaTransmission, 2)),
                    bool(ctx.is_enabled(F.GlossyReflection, 1)),
                    bool(tr and ctx.is_enabled(F.GlossyTransmission, 3)))

        def _incidence(self, si: Any, active: Any) -> tuple[Any, Any, Any, Any, Any]:
            """(valid, side index, lower node j, weight t, phi_i) of ``si.wi``."""
            cos_i = si.wi.z
            valid = active & (cos_i != 0.0)
            if not self.table.transmits:
                valid = valid & (cos_i > 0.0)
            side = as_uint(cos_i < 0.0)
            theta_i = dr.acos(dr.minimum(dr.abs(cos_i), 1.0))
            j, t = self._node(theta_i)
            return valid, side, j, t, dr.atan2(si.wi.y, si.wi.x)

        def _node(self, theta: Any) -> tuple[Any, Any]:
            """Lower node and interpolation weight of a polar angle (radians)."""
            x = dr.clip(theta, 0.0, self._theta_max) / self._dt
            jf = dr.minimum(dr.floor(x), self._n - 2)
            return UInt(jf), x - jf

        def _relative_phi(self, wo: Any, phi_i: Any) -> Any:
            """Azimuth of ``wo`` relative to the incidence, folded into [0, pi]."""
            d = dr.atan2(wo.y, wo.x) - phi_i
            d = d - 2.0 * math.pi * dr.floor((d + math.pi) / (2.0 * math.pi))
            return dr.minimum(dr.abs(d), math.pi)

        def _eval_f(self, block: Any, j: Any, t: Any, theta_o: Any, phi: Any, cmap: Any,
                    active: Any) -> list[Any]:
            """Trilinear interpolation of the smooth BSDF (per channel, >= 0)."""
            if not jit and not active:
                return [0.0] * len(cmap)
            n, m = self._n, self._m
            k, u = self._node(theta_o)
            xp = dr.clip(phi, 0.0, math.pi) / self._dp
            lf = dr.minimum(dr.floor(xp), m - 2)
            v = xp - lf
            l_ = UInt(lf)
            base = ((block * n + j) * n + k) * m + l_
            bases, weights = [], []
            for dj, wj in ((0, 1.0 - t), (1, t)):
                for dk, wk in ((0, 1.0 - u), (1, u)):
                    wjk = wj * wk
                    for dl, wl in ((0, 1.0 - v), (1, v)):
                        bases.append(base + (dj * n + dk) * m + dl)
                        weights.append(wjk * wl)
            vals = self._fetch(self._f, bases, weights, cmap, active)
            return [dr.maximum(x, 0.0) for x in vals]

        def _pdf_cell(self, side: Any, transmitted: Any, j: Any, t: Any, k: Any, l_: Any,
                      p: Any, active: Any) -> Any:
            """Eq. M1 for an exit in cell (k, l) of the smooth lobe ``transmitted``."""
            n, m = self._n, self._m
            block = 2 * side + as_uint(transmitted)
            lobe = REFL + as_uint(transmitted)
            total: Any = Float(0.0)
            for dj, wj in ((0, 1.0 - t), (1, t)):
                jj = j + dj
                pj = gather(p, (side * n + jj) * 4 + lobe, active)
                w = gather(self._wn, ((block * n + jj) * n + k) * (m - 1) + l_, active)
                total = dr.fma(wj * pj, w, total)
            return total

        def _exit(self, si: Any, wo: Any, active: Any, smooth_on: tuple[bool, bool]
                  ) -> tuple[Any, ...]:
            """Geometry of a smooth exit: (valid, side, transmitted, j, t, mu_o,
            theta_o, phi) with the lobe enabled and the stack's sides respected."""
            valid, side, j, t, phi_i = self._incidence(si, active)
            valid = valid & (wo.z != 0.0)
            transmitted = (wo.z > 0.0) != (si.wi.z > 0.0)
            if not smooth_on[1]:
                valid = valid & neg(transmitted)
            if not smooth_on[0]:
                valid = valid & transmitted
            mu_o = dr.minimum(dr.abs(wo.z), 1.0)
            theta_o = dr.acos(mu_o)
            phi = self._relative_phi(wo, phi_i)
            return valid, side, transmitted, j, t, mu_o, theta_o, phi

        # -- the BSDF interface ---------------------------------------------

        def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            e = self._enabled(ctx)
            valid, side, tr, j, t, mu_o, theta_o, phi = self._exit(si, wo, active, (e[2], e[3]))
            if not jit and not valid:
                return mi.Spectrum(0.0)
            block = 2 * side + as_uint(tr)
            vals = self._eval_f(block, j, t, theta_o, phi, self._channel_map(si), valid)
            return self._spectrum([dr.select(valid, x * mu_o, 0.0) for x in vals])

        def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            e = self._enabled(ctx)
            valid, side, tr, j, t, mu_o, theta_o, phi = self._exit(si, wo, active, (e[2], e[3]))
            if not jit and not valid:
                return 0.0
            p, _ = self._lobe_arrays(e)
            k = UInt(dr.minimum(dr.floor(theta_o / self._dt), self._n - 1))
            l_ = UInt(dr.minimum(dr.floor(phi / self._dp), self._m - 2))
            return dr.select(valid, self._pdf_cell(side, tr, j, t, k, l_, p, valid), 0.0)

        def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> tuple[Any, Any]:
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any,
                   active: Any = True) -> tuple[Any, Any]:
            n, m = self._n, self._m
            e = self._enabled(ctx)
            p, thr = self._lobe_arrays(e)
            valid, side, j0, t, phi_i = self._incidence(si, active)
            # The node (j0 or j0 + 1, probabilities 1 - t and t), then the
            # lobe from the same number rescaled.
            up_node = sample1 < t
            j = j0 + as_uint(up_node)
            u1 = dr.select(up_node, sample1 / dr.maximum(t, _TINY),
                           (sample1 - t) / dr.maximum(1.0 - t, _TINY))
            row = (side * n + j) * 4
            lobe = UInt(0)
            for i in range(3):
                lobe = lobe + as_uint(u1 >= gather(thr, row + i, valid))
            valid = valid & (gather(thr, row + 3, valid) > 0.0)
            is_spec = lobe == SPEC
            is_direct = lobe == DIRECT
            smooth = valid & (lobe >= REFL)
            transmitted = lobe == TRANS
            # Smooth lobes: the cell from the row's cumulative distribution.
            block = 2 * side + as_uint(transmitted)
            crow = (block * n + j) * self._ncell
            x = sample2[0]
            cdf = self._cdf
            if jit or smooth:
                idx = UInt(binary_search(0, self._ncell - 1,
                                         lambda i: gather(cdf, crow + i, smooth) <= x))
            else:
                idx = UInt(0)
            below = dr.select(idx > 0, gather(cdf, crow + idx - 1, smooth & (idx > 0)), 0.0)
            width = gather(cdf, crow + idx, smooth) - below
            frac = dr.select(width > 0.0, (x - below) / dr.maximum(width, _TINY), 0.5)
            k = idx // (m - 1)
            l_ = idx - k * (m - 1)
            mu = gather(self._mu_top, k, smooth) \
                - dr.clip(frac, 0.0, 1.0) * gather(self._d_mu, k, smooth)
            mu = dr.clip(mu, 0.0, 1.0)
            u3 = sample2[1]
            left = u3 < 0.5
            v = dr.select(left, 2.0 * u3, 2.0 * u3 - 1.0)
            phi = (Float(l_) + v) * self._dp
            a = phi_i + dr.select(left, phi, -phi)
            up = dr.select(side == 0, 1.0, -1.0)
            sin_o = dr.safe_sqrt(1.0 - mu * mu)
            z_smooth = dr.select(transmitted, -up * mu, up * mu)
            # The unscattered beam: Snell between the outer media.
            wi = si.wi
            ratio = dr.select(side == 0, self._n_in_out[0], self._n_in_out[1])
            sin_t2 = ratio * ratio * (1.0 - wi.z * wi.z)
            cos_t = dr.safe_sqrt(1.0 - sin_t2)
            valid = valid & neg(is_direct & (sin_t2 >= 1.0))
            wx = dr.select(is_spec, -wi.x, dr.select(is_direct, -ratio * wi.x, sin_o * dr.cos(a)))
            wy = dr.select(is_spec, -wi.y, dr.select(is_direct, -ratio * wi.y, sin_o * dr.sin(a)))
            wz = dr.select(is_spec, wi.z, dr.select(is_direct, -up * cos_t, z_smooth))
            # Densities: the delta lobes' discrete probabilities, eq. M1 for smooth ones.
            prow0, prow1 = (side * n + j0) * 4, (side * n + j0 + 1) * 4
            p_delta = (1.0 - t) * gather(p, prow0 + lobe, valid) \
                + t * gather(p, prow1 + lobe, valid)
            p_smooth = self._pdf_cell(side, transmitted, j0, t, k, l_, p, smooth)
            pdf = dr.select(smooth, p_smooth, p_delta)
            valid = valid & (pdf > 0.0)
            cmap = self._channel_map(si)
            f = self._eval_f(block, j0, t, dr.acos(mu), phi, cmap, smooth)
            dl = as_uint(is_direct)
            dbase = (side * 2 + dl) * n + j0
            d = self._fetch(self._delta, [dbase, dbase + 1], [1.0 - t, t], cmap,
                            valid & neg(smooth))
            inv = 1.0 / dr.maximum(pdf, _TINY)
            vals = [dr.select(valid, dr.select(smooth, fs * mu, ds) * inv, 0.0)
                    for fs, ds in zip(f, d)]
            bs: Any = dr.zeros(mi.BSDFSample3f) if not jit else \
                dr.zeros(mi.BSDFSample3f, dr.width(sample1))
            bs.wo = mi.Vector3f(wx, wy, wz)
            bs.pdf = dr.select(valid, pdf, 0.0)
            eta_out = dr.select(side == 0, 1.0 / self._n_in_out[0], 1.0 / self._n_in_out[1])
            bs.eta = dr.select(is_direct | transmitted, eta_out, 1.0)
            bs.sampled_type = dr.select(
                is_spec, UInt(+F.DeltaReflection),
                dr.select(is_direct, UInt(+F.DeltaTransmission),
                          dr.select(transmitted, UInt(+F.GlossyTransmission),
                                    UInt(+F.GlossyReflection))))
            bs.sampled_component = dr.select(
                is_spec, UInt(0), dr.select(is_direct, UInt(2),
                                            dr.select(transmitted, UInt(3), UInt(1))))
            return bs, self._spectrum(vals)

        def _total_values(self, si: Any, keys: tuple[int, ...], active: Any) -> list[Any]:
            valid, side, j, t, _ = self._incidence(si, active)
            cmap = self._channel_map(si)
            out = []
            for key in keys:
                base = (side * 4 + key) * self._n + j
                vals = self._fetch(self._totals, [base, base + 1], [1.0 - t, t], cmap, valid)
                out.append(self._spectrum([dr.select(valid, x, 0.0) for x in vals]))
            return out

        def eval_diffuse_reflectance(self, si: Any, active: Any = True) -> Any:
            """The stack's total reflectance at ``si.wi`` (the albedo Mitsuba's AOVs show)."""
            return self._total_values(si, (0,), active)[0]

        def albedo(self, si: Any, active: Any = True) -> dict[str, Any]:
            """Totals at ``si.wi``: reflectance, transmittance and their delta parts
            (zero where ``si.wi`` does not reach the stack)."""
            vals = self._total_values(si, (0, 1, 2, 3), active)
            return dict(zip(_TOTALS, vals))

        def traverse(self, callback: Any) -> None:
            pass

        def parameters_changed(self, keys: Any = None) -> None:
            pass

        def to_string(self) -> str:
            tab = self.table
            return (f"KmBSDF[channels={tab.channels}, transmits={tab.transmits}, "
                    f"grid={len(tab.theta)}x{len(tab.theta)}x{len(tab.phi)}]")

    mi.register_bsdf(name, lambda props: KmBSDF(props))
    return KmBSDF
