"""A Mitsuba 3 BSDF plugin for km stacks (``km.mitsuba``).

    import mitsuba as mi
    mi.set_variant("scalar_rgb")
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

Properties of the plugin: ``scene`` (the scene file's TOML text, or a path
to it), ``streams`` (int, optional), ``n_theta`` (46), ``n_phi`` (37).
Channels: a one-channel scene is grey in every variant; an RGB variant
takes a three-channel scene as R, G, B; a spectral variant interpolates a
scene with wavelengths (linear, clamped at the ends).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

import km
from ._table import DIRECT, REFL, SPEC, TRANS, BsdfTable

__all__ = ["register", "table_for", "PLUGIN"]

PLUGIN = "km"
_CACHE: dict[tuple[Any, ...], BsdfTable] = {}


def table_for(scene_text: str, streams: int | None = None, n_theta: int = 46,
              n_phi: int = 37) -> BsdfTable:
    """The table of a scene (cached per arguments: loading a scene twice solves once)."""
    key = (scene_text, streams, n_theta, n_phi)
    if key not in _CACHE:
        b = km.bsdf(km.Scene.from_toml(scene_text), streams=streams)
        _CACHE[key] = BsdfTable(b, n_theta=n_theta, n_phi=n_phi)
    return _CACHE[key]


def register(name: str = PLUGIN) -> type:
    """Register the plugin with Mitsuba (a variant must be set) and return its class."""
    import mitsuba as mi

    variant = mi.variant()
    if variant is None or not variant.startswith("scalar"):
        raise km.KmError(f"km.mitsuba needs a scalar variant (scalar_rgb, scalar_spectral), "
                         f"not {variant}")
    spectral = "spectral" in variant
    F = mi.BSDFFlags

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

        # -- helpers --------------------------------------------------------

        def _spectrum(self, si: Any, values: np.ndarray) -> Any:
            tab = self.table
            if tab.channels == 1:
                return mi.Spectrum(float(values[0]))
            if spectral:
                wl = np.array([si.wavelengths[i] for i in range(len(si.wavelengths))])
                v = np.interp(wl, tab.wavelengths_nm, values)
                return mi.Spectrum(*[float(x) for x in v])
            return mi.Spectrum(float(values[0]), float(values[1]), float(values[2]))

        def _enabled(self, ctx: Any) -> tuple[bool, ...]:
            tr = self.table.transmits
            return (ctx.is_enabled(F.DeltaReflection, 0), ctx.is_enabled(F.GlossyReflection, 1),
                    tr and ctx.is_enabled(F.DeltaTransmission, 2),
                    tr and ctx.is_enabled(F.GlossyTransmission, 3))

        def _lobes(self, ctx: Any) -> tuple[bool, ...]:
            e = self._enabled(ctx)  # in the table's order: SPEC, DIRECT, REFL, TRANS
            return (e[0], e[2], e[1], e[3])

        def _incidence(self, si: Any) -> tuple[str, float, float] | None:
            wi = si.wi
            cos_i = float(wi.z)
            if cos_i == 0.0 or (cos_i < 0.0 and not self.table.transmits):
                return None
            side = "above" if cos_i > 0 else "below"
            theta_i = math.degrees(math.acos(min(abs(cos_i), 1.0)))
            return side, theta_i, math.atan2(float(wi.y), float(wi.x))

        def _geometry(self, si: Any, wo: Any) -> tuple[str, float, bool, float, float] | None:
            inc = self._incidence(si)
            if inc is None or float(wo.z) == 0.0:
                return None
            side, theta_i, phi_i = inc
            transmitted = (float(wo.z) > 0) != (side == "above")
            mu_o = min(abs(float(wo.z)), 1.0)
            phi = math.degrees(math.atan2(float(wo.y), float(wo.x)) - phi_i)
            return side, theta_i, transmitted, mu_o, phi

        # -- the BSDF interface ---------------------------------------------

        def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            g = self._geometry(si, wo)
            lobes = self._lobes(ctx)
            if g is None:
                return mi.Spectrum(0.0)
            side, theta_i, transmitted, mu_o, phi = g
            if not lobes[TRANS if transmitted else REFL]:
                return mi.Spectrum(0.0)
            f = self.table.eval(side, transmitted, theta_i, math.degrees(math.acos(mu_o)), phi)
            return self._spectrum(si, f * mu_o)

        def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            g = self._geometry(si, wo)
            if g is None:
                return 0.0
            side, theta_i, transmitted, mu_o, phi = g
            return self.table.pdf(side, transmitted, theta_i, mu_o, phi, self._lobes(ctx))

        def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> tuple[Any, Any]:
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any,
                   active: Any = True) -> tuple[Any, Any]:
            bs: Any = mi.BSDFSample3f()
            inc = self._incidence(si)
            lobes = self._lobes(ctx)
            if inc is None:
                return bs, mi.Spectrum(0.0)
            side, theta_i, phi_i = inc
            tab = self.table
            s = tab.sample(side, theta_i, float(sample1), float(sample2[0]), float(sample2[1]),
                           lobes)
            if s is None:
                return bs, mi.Spectrum(0.0)
            lobe, mu_o, phi = s
            up = 1.0 if side == "above" else -1.0
            n_in, n_out = ((tab.n_above, tab.n_below) if side == "above"
                           else (tab.n_below, tab.n_above))
            wi = si.wi
            if lobe == SPEC:
                bs.wo = mi.Vector3f(-float(wi.x), -float(wi.y), float(wi.z))
                bs.pdf = tab.delta_probability(side, SPEC, theta_i, lobes)
                bs.eta, bs.sampled_type, bs.sampled_component = 1.0, +F.DeltaReflection, 0
                value = tab.delta_value(side, SPEC, theta_i)
            elif lobe == DIRECT:
                # Snell between the outer media (parallel interfaces): the
                # transmitted direction depends on n_in / n_out only.
                ratio = n_in / n_out
                sin_t2 = ratio * ratio * (1.0 - float(wi.z) ** 2)
                if sin_t2 >= 1.0:
                    return bs, mi.Spectrum(0.0)
                cos_t = math.sqrt(1.0 - sin_t2)
                bs.wo = mi.Vector3f(-ratio * float(wi.x), -ratio * float(wi.y), -up * cos_t)
                bs.pdf = tab.delta_probability(side, DIRECT, theta_i, lobes)
                bs.eta, bs.sampled_type, bs.sampled_component = (n_out / n_in,
                                                                 +F.DeltaTransmission, 2)
                value = tab.delta_value(side, DIRECT, theta_i)
            else:
                transmitted = lobe == TRANS
                sin_o = math.sqrt(max(0.0, 1.0 - mu_o * mu_o))
                a = phi_i + math.radians(phi)
                z = up * mu_o * (-1.0 if transmitted else 1.0)
                bs.wo = mi.Vector3f(sin_o * math.cos(a), sin_o * math.sin(a), z)
                bs.pdf = tab.pdf(side, transmitted, theta_i, mu_o, phi, lobes)
                if transmitted:
                    bs.eta, bs.sampled_type, bs.sampled_component = (n_out / n_in,
                                                                     +F.GlossyTransmission, 3)
                else:
                    bs.eta, bs.sampled_type, bs.sampled_component = 1.0, +F.GlossyReflection, 1
                if bs.pdf <= 0.0:
                    return bs, mi.Spectrum(0.0)
                f = tab.eval(side, transmitted, theta_i, math.degrees(math.acos(mu_o)), phi)
                value = f * mu_o
            if bs.pdf <= 0.0:
                return bs, mi.Spectrum(0.0)
            return bs, self._spectrum(si, np.asarray(value) / bs.pdf)

        def eval_diffuse_reflectance(self, si: Any, active: Any = True) -> Any:
            """The stack's total reflectance at ``si.wi`` (the albedo Mitsuba's AOVs show)."""
            inc = self._incidence(si)
            if inc is None:
                return mi.Spectrum(0.0)
            return self._spectrum(si, self.table.albedo(inc[0], inc[1])["reflectance"])

        def albedo(self, si: Any) -> dict[str, Any]:
            """Totals at ``si.wi``: reflectance, transmittance and their delta parts."""
            inc = self._incidence(si)
            if inc is None:
                return {}
            return {k: self._spectrum(si, v) for k, v in self.table.albedo(inc[0], inc[1]).items()}

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
