"""A km BSDF tabulated for a renderer: interpolation, sampling and its pdf.

:class:`BsdfTable` holds one :func:`km.bsdf` solve on a regular
``(theta_i, theta_o, phi)`` grid and answers, per direction pair, what a
renderer asks (``km.mitsuba`` wraps it as a Mitsuba 3 plugin):

* ``eval``: the BRDF/BTDF by trilinear interpolation in ``(theta_i,
  theta_o, phi)`` of the table's values, whose negative values (the series
  of a narrow lobe rings) are set to 0 and the rest scaled per incidence
  and channel so that the hemispherical albedo stays the series' own
  (:func:`clipped`);
* ``sample``/``pdf``: a mixture whose density is known exactly. Between the
  two incidence nodes ``j0, j1`` bracketing ``theta_i`` (weights ``1 - t``,
  ``t``, those of the interpolation) a node is picked; at node ``j`` a lobe
  with probability proportional to its albedo (mirror reflection ``R_s``,
  unscattered transmission ``T_d``, smooth reflection, smooth transmission);
  for a smooth lobe a cell ``(theta_o, phi)`` with probability proportional
  to ``max(f, 0) cos theta_o`` averaged over its corners times its solid
  angle, then a direction uniform in ``(cos theta_o, phi)`` inside the cell,
  on either side of the plane of incidence. So, for a smooth exit in cell
  ``(k, l)`` on lobe ``s``::

      pdf(wo) = sum_j w_j P_j(s) W_j,s(k, l) / (2 A_j,s dmu_k dphi)        (M1)

  with ``A_j,s = sum_kl W_j,s(k, l)``; the delta lobes have the discrete
  probabilities ``sum_j w_j P_j(delta)``.

Angles: ``theta`` from the normal on each side, ``phi`` relative to the
incidence (``phi = 180``: mirror side), as in docs/bsdf.md §2.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

SIDES = ("above", "below")
# Lobes: mirror reflection, unscattered transmission, smooth reflection, smooth transmission.
SPEC, DIRECT, REFL, TRANS = range(4)


def clipped(f: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``f[c, i, o, p]`` without negative values, albedo kept.

    The Fourier series of a narrow lobe (a rough face, docs/rough.md §3)
    rings: negative values next to an overshoot. Clamped alone, the table
    would reflect more than the stack (at alpha 0.1 and 80 degrees, 0.39
    against 0.29). So per channel and incidence the clamped values are
    scaled by ``A(f) / A(max(f, 0))`` with
    ``A(g) = 2 integral g cos(theta_o) sin(theta_o) dtheta_o dphi`` on the
    table's grid (trapezoids; ``phi`` over ``[0, 180]``, doubled). Without
    negative values the factor is exactly 1 and ``f`` is unchanged.
    """
    if not (f < 0).any():
        return f
    t, p = np.radians(theta), np.radians(phi)
    weight = np.cos(t) * np.sin(t)

    def trapezoid(y: np.ndarray, x: np.ndarray) -> np.ndarray:
        # Over the last axis (numpy >= 1.23 has no np.trapezoid).
        return np.asarray((0.5 * (y[..., 1:] + y[..., :-1]) * np.diff(x)).sum(axis=-1))

    def albedo(g: np.ndarray) -> np.ndarray:
        out: np.ndarray = 2.0 * trapezoid(trapezoid(g, p) * weight, t)
        return out

    pos = np.clip(f, 0.0, None)
    a_f, a_pos = albedo(f), albedo(pos)
    scale = np.where(a_pos > 0.0, np.clip(a_f, 0.0, None) / np.where(a_pos > 0, a_pos, 1.0), 0.0)
    out: np.ndarray = pos * np.minimum(scale, 1.0)[..., None, None]
    return out


class BsdfTable:
    """One km BSDF solve tabulated for rendering (see the module's text).

    ``bsdf``: a :class:`km.Bsdf`; ``n_theta`` polar nodes uniform in
    ``[0, theta_max]`` degrees for incidence and exit (beyond ``theta_max``
    the values of ``theta_max`` are used), ``n_phi`` azimuth nodes uniform in
    ``[0, 180]`` (the BSDF of isotropic layers is even in ``phi``).
    """

    def __init__(self, bsdf: Any, *, n_theta: int = 46, n_phi: int = 37,
                 theta_max: float = 89.5) -> None:
        if n_theta < 2 or n_phi < 2 or not 0.0 < theta_max < 90.0:
            raise ValueError("needs n_theta >= 2, n_phi >= 2 and 0 < theta_max < 90")
        self.channels = bsdf.channels
        self.wavelengths_nm = bsdf.wavelengths_nm
        self.transmits = bsdf.transmits
        self.n_above, self.n_below = bsdf.n_above, bsdf.n_below
        self.theta = np.linspace(0.0, theta_max, n_theta)
        self.phi = np.linspace(0.0, 180.0, n_phi)
        self.d_theta = self.theta[1]
        self.d_phi = math.radians(self.phi[1])
        edges = np.radians(np.append(self.theta, 90.0))
        self.mu_edges = np.cos(edges)  # descending: cell k is [mu_edges[k+1], mu_edges[k]]
        self.d_mu = self.mu_edges[:-1] - self.mu_edges[1:]
        self.f: dict[tuple[str, bool], np.ndarray] = {}
        self.delta: dict[tuple[str, int], np.ndarray] = {}
        self.cdf: dict[tuple[str, bool], np.ndarray] = {}
        self.weights: dict[tuple[str, bool], np.ndarray] = {}
        self.lobes: dict[str, np.ndarray] = {}
        self.totals: dict[str, dict[str, np.ndarray]] = {}
        sides = SIDES if self.transmits else SIDES[:1]
        mu_o = np.cos(np.radians(self.theta))
        for side in sides:
            # The series alone: band-limited to the table's orders, which a
            # trilinear interpolation of this grid can follow (the exact
            # single rough path is narrower than its cells).
            tab = bsdf.table(self.theta, self.theta, self.phi, side=side,
                             exact_single_path=False)
            self.totals[side] = {k: tab[k] for k in ("reflectance", "transmittance",
                                                      "reflectance_specular",
                                                      "transmittance_direct")}
            self.delta[(side, SPEC)] = tab["reflectance_specular"]
            self.delta[(side, DIRECT)] = tab["transmittance_direct"]
            lobe = np.zeros((n_theta, 4))
            lobe[:, SPEC] = tab["reflectance_specular"].mean(axis=0)
            lobe[:, DIRECT] = tab["transmittance_direct"].mean(axis=0)
            for transmitted in (False, True):
                f = clipped(tab["btdf" if transmitted else "brdf"], self.theta, self.phi)
                self.f[(side, transmitted)] = f
                # Cell weights W_j(k, l): mean over the 4 corners of
                # max(f, 0) cos theta_o (channel mean; the corner at 90
                # degrees has cos = 0) times the cell's solid angle.
                g = np.clip(f, 0.0, None).mean(axis=0) * mu_o[None, :, None]
                g = np.concatenate([g, np.zeros_like(g[:, :1])], axis=1)
                corners = 0.25 * (g[:, :-1, :-1] + g[:, 1:, :-1] + g[:, :-1, 1:] + g[:, 1:, 1:])
                w = corners * self.d_mu[None, :, None] * self.d_phi
                flat = w.reshape(n_theta, -1)
                self.weights[(side, transmitted)] = w
                self.cdf[(side, transmitted)] = np.cumsum(flat, axis=1)
                lobe[:, TRANS if transmitted else REFL] = 2.0 * flat.sum(axis=1)
            self.lobes[side] = lobe

    # -- helpers ----------------------------------------------------------

    def _nodes(self, theta_i: float) -> tuple[int, float]:
        """Lower node and interpolation weight of ``theta_i`` (degrees)."""
        x = min(max(theta_i, 0.0), self.theta[-1]) / self.d_theta
        j = min(int(x), len(self.theta) - 2)
        return j, x - j

    def _cell(self, theta_o: float, phi: float) -> tuple[int, int, float, float]:
        """Cell (k, l) of an exit and its interpolation weights in theta and phi."""
        xo = min(max(theta_o, 0.0), self.theta[-1]) / self.d_theta
        k = min(int(xo), len(self.theta) - 2)
        xp = min(max(phi, 0.0), 180.0) / self.phi[1]
        l_ = min(int(xp), len(self.phi) - 2)
        return k, l_, xo - k, xp - l_

    def _mu_cell(self, mu_o: float) -> int:
        """Index of the sampling cell (in cos theta_o) holding ``mu_o``."""
        k = int(np.searchsorted(-self.mu_edges, -mu_o, side="right")) - 1
        return min(max(k, 0), len(self.d_mu) - 1)

    def _lobe_p(self, side: str, j: int, enabled: tuple[bool, ...]) -> np.ndarray:
        p: np.ndarray = self.lobes[side][j] * np.asarray(enabled, dtype=float)
        s = float(p.sum())
        return p / s if s > 0 else p

    # -- what a renderer asks --------------------------------------------

    def eval(self, side: str, transmitted: bool, theta_i: float, theta_o: float,
             phi: float) -> np.ndarray:
        """Smooth BRDF/BTDF (1/sr) per channel by trilinear interpolation, >= 0.

        ``phi`` in degrees, folded into [0, 180]."""
        if transmitted and not self.transmits:
            return np.zeros(self.channels)
        phi = abs((phi + 180.0) % 360.0 - 180.0)
        j, t = self._nodes(theta_i)
        k, l_, u, v = self._cell(theta_o, phi)
        c = self.f[(side, transmitted)][:, j:j + 2, k:k + 2, l_:l_ + 2]
        c = c[:, 0] * (1 - t) + c[:, 1] * t
        c = c[:, 0] * (1 - u) + c[:, 1] * u
        return np.clip(c[:, 0] * (1 - v) + c[:, 1] * v, 0.0, None)

    def delta_value(self, side: str, lobe: int, theta_i: float) -> np.ndarray:
        """Mirror reflectance (``SPEC``) or unscattered transmittance (``DIRECT``) per channel."""
        j, t = self._nodes(theta_i)
        d = self.delta[(side, lobe)]
        return d[:, j] * (1 - t) + d[:, j + 1] * t

    def albedo(self, side: str, theta_i: float) -> dict[str, np.ndarray]:
        """Totals per channel at ``theta_i`` (linear in theta_i between nodes)."""
        j, t = self._nodes(theta_i)
        return {k: v[:, j] * (1 - t) + v[:, j + 1] * t for k, v in self.totals[side].items()}

    def delta_probability(self, side: str, lobe: int, theta_i: float,
                          enabled: tuple[bool, ...] = (True,) * 4) -> float:
        """Discrete probability with which :meth:`sample` picks a delta lobe."""
        j, t = self._nodes(theta_i)
        return float((1 - t) * self._lobe_p(side, j, enabled)[lobe]
                     + t * self._lobe_p(side, j + 1, enabled)[lobe])

    def pdf(self, side: str, transmitted: bool, theta_i: float, mu_o: float, phi: float,
            enabled: tuple[bool, ...] = (True,) * 4) -> float:
        """Solid-angle density (eq. M1) of :meth:`sample` for a smooth exit
        with ``|cos theta_o| = mu_o`` at azimuth ``phi`` (degrees)."""
        if transmitted and not self.transmits:
            return 0.0
        phi = abs((phi + 180.0) % 360.0 - 180.0)
        lobe = TRANS if transmitted else REFL
        j0, t = self._nodes(theta_i)
        k = self._mu_cell(mu_o)
        l_ = min(int(phi / self.phi[1]), len(self.phi) - 2)
        w = self.weights[(side, transmitted)]
        total = 0.0
        for j, wj in ((j0, 1 - t), (j0 + 1, t)):
            a = 0.5 * self.lobes[side][j, lobe]
            if wj <= 0 or a <= 0:
                continue
            p = self._lobe_p(side, j, enabled)[lobe]
            total += wj * p * w[j, k, l_] / (2.0 * a * self.d_mu[k] * self.d_phi)
        return float(total)

    def sample(self, side: str, theta_i: float, u1: float, u2: float, u3: float,
               enabled: tuple[bool, ...] = (True,) * 4) -> tuple[int, float, float] | None:
        """Draw a lobe and, for a smooth lobe, an exit ``(mu_o, phi)``.

        ``u1``: node and lobe; ``u2``: cell and ``mu_o`` in it; ``u3``: side
        and ``phi`` in the cell. Returns ``(lobe, mu_o, phi_deg)`` (``phi``
        signed, in (-180, 180]; ``mu_o`` > 0 on the exit side), or None when
        every enabled lobe has zero albedo."""
        j, t = self._nodes(theta_i)
        if u1 < t:
            j, u1 = j + 1, u1 / t
        else:
            u1 = (u1 - t) / (1 - t)
        p = self._lobe_p(side, j, enabled)
        if p.sum() <= 0:
            return None
        cum = np.cumsum(p)
        lobe = min(int(np.searchsorted(cum, u1 * cum[-1], side="right")), 3)
        while p[lobe] <= 0:  # u1 on a boundary of a zero-probability lobe
            lobe -= 1
        if lobe in (SPEC, DIRECT):
            return lobe, 0.0, 0.0
        cdf = self.cdf[(side, lobe == TRANS)][j]
        x = u2 * cdf[-1]
        idx = min(int(np.searchsorted(cdf, x, side="right")), len(cdf) - 1)
        below = cdf[idx - 1] if idx > 0 else 0.0
        width = cdf[idx] - below
        frac = (x - below) / width if width > 0 else 0.5
        k, l_ = divmod(idx, len(self.phi) - 1)
        mu = self.mu_edges[k] - min(max(frac, 0.0), 1.0) * self.d_mu[k]
        sign = 1.0 if u3 < 0.5 else -1.0
        v = (2.0 * u3) % 1.0
        phi = sign * (self.phi[l_] + v * self.phi[1])
        return lobe, float(mu), float(phi)
