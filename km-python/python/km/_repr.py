"""Rich display in Jupyter: ``_repr_html_`` of :class:`km.Solution`,
:class:`km.Bsdf`, :class:`km.Batch`, :class:`km.FitResult` and
:class:`km.FitResults`, each an HTML table of its numbers and an inline SVG
plot (no plotting library needed). :func:`svg_plot` is also what
examples/python/tour.py saves its figures with.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any

import numpy as np


def _num(x: Any) -> str:
    """A number as the table shows it (6 significant digits)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return html.escape(str(x))
    return "nan" if math.isnan(v) else f"{v:.6g}"


def table(title: str, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """An HTML table: a caption, a header row and rows of cells (numbers to 6 digits)."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join(
        "<tr><th style='text-align:left'>" + html.escape(str(r[0])) + "</th>"
        + "".join(f"<td>{_num(c)}</td>" for c in r[1:]) + "</tr>"
        for r in rows)
    return (f"<table><caption>{html.escape(title)}</caption>"
            f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")


def svg_plot(series: Sequence[tuple[str, Any, Any]], *, xlabel: str, ylabel: str,
             title: str = "", width: int = 420, height: int = 260) -> str:
    """An SVG line plot of ``(label, x, y)`` series (NaN points left out).

    Axes span the finite data (y from 0 when all values are >= 0); the ends
    of each axis are labelled with their values.
    """
    colours = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")
    pts = [(str(lab), np.asarray(x, dtype=float).ravel(), np.asarray(y, dtype=float).ravel())
           for lab, x, y in series]
    xs = np.concatenate([p[1][np.isfinite(p[1]) & np.isfinite(p[2])] for p in pts] or [[0.0]])
    ys = np.concatenate([p[2][np.isfinite(p[1]) & np.isfinite(p[2])] for p in pts] or [[0.0]])
    if xs.size == 0:
        xs, ys = np.array([0.0, 1.0]), np.array([0.0, 1.0])
    x0, x1 = float(xs.min()), float(xs.max())
    y0, y1 = (0.0 if ys.min() >= 0 else float(ys.min())), float(ys.max())
    x1 = x1 if x1 > x0 else x0 + 1.0
    y1 = y1 if y1 > y0 else y0 + 1.0
    left, right, top, bottom = 60, 10, 24, 40
    pw, ph = width - left - right, height - top - bottom

    def px(x: float) -> float:
        return left + (x - x0) / (x1 - x0) * pw

    def py(y: float) -> float:
        return top + ph - (y - y0) / (y1 - y0) * ph

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">',
           f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>',
           f'<text x="{left + pw / 2}" y="14" text-anchor="middle">{html.escape(title)}</text>',
           f'<text x="{left + pw / 2}" y="{height - 6}" text-anchor="middle">'
           f'{html.escape(xlabel)}</text>',
           f'<text x="12" y="{top + ph / 2}" text-anchor="middle" '
           f'transform="rotate(-90 12 {top + ph / 2})">{html.escape(ylabel)}</text>',
           f'<text x="{left}" y="{top + ph + 14}" text-anchor="middle">{x0:.4g}</text>',
           f'<text x="{left + pw}" y="{top + ph + 14}" text-anchor="middle">{x1:.4g}</text>',
           f'<text x="{left - 4}" y="{top + ph}" text-anchor="end">{y0:.4g}</text>',
           f'<text x="{left - 4}" y="{top + 8}" text-anchor="end">{y1:.4g}</text>']
    for i, (lab, x, y) in enumerate(pts):
        ok = np.isfinite(x) & np.isfinite(y)
        c = colours[i % len(colours)]
        coords = " ".join(f"{px(a):.2f},{py(b):.2f}" for a, b in zip(x[ok], y[ok]))
        if ok.sum() == 1:
            a, b = x[ok][0], y[ok][0]
            out.append(f'<circle cx="{px(a):.2f}" cy="{py(b):.2f}" r="3" fill="{c}"/>')
        elif coords:
            out.append(f'<polyline fill="none" stroke="{c}" stroke-width="1.5" '
                       f'points="{coords}"/>')
        out.append(f'<text x="{left + pw - 4}" y="{top + 14 + 13 * i}" text-anchor="end" '
                   f'fill="{c}">{html.escape(lab)}</text>')
    out.append("</svg>")
    return "".join(out)


def _per_channel(v: Any, channels: int) -> list[Any]:
    a = np.atleast_1d(np.asarray(v, dtype=float))
    return list(a) if a.size == channels else [v] * channels


def _wavelengths(labels: Sequence[str]) -> list[float] | None:
    """The wavelengths of labels such as ``"400 nm"`` (the scene file's
    labels of a spectrum), or None when a label is not one."""
    out = []
    for lab in labels:
        try:
            out.append(float(lab.removesuffix("nm").strip()))
        except ValueError:
            return None
    return out


def solution_html(sol: Any) -> str:
    """The HTML of a :class:`km.Solution`: its totals per channel and a plot of
    its BRDF/BTDF (or, without output directions, of its totals over the channels)."""
    c = sol.channels
    keys = ("reflectance", "reflectance_specular", "transmittance", "transmittance_direct",
            "absorptance")
    rows = [[k] + _per_channel(getattr(sol, k), c) for k in keys]
    t = table(f"km.Solution, method {sol.method}", ["", *sol.labels], rows)
    d = np.asarray(sol.directions_deg, dtype=float).reshape(-1, 2)
    if d.shape[0] == 0 and c > 1:
        # No directions: the totals over the channels (a spectrum).
        wl = _wavelengths(sol.labels)
        x = np.asarray(wl, dtype=float) if wl else np.arange(c, dtype=float)
        series = [(k, x, _per_channel(getattr(sol, k), c))
                  for k in ("reflectance", "transmittance", "absorptance")]
        svg = svg_plot(series, xlabel="wavelength (nm)" if wl else "channel", ylabel="fraction",
                       title="Totals over the channels")
        return f"<div>{t}{svg}</div>"
    if d.shape[0] == 0:
        return f"<div>{t}</div>"
    # Signed exit angle: phi near 180 (the mirror side) to the right, else left.
    signed = np.where(np.cos(np.radians(d[:, 1])) < 0, d[:, 0], -d[:, 0])
    order = np.argsort(signed)
    brdf = np.atleast_2d(np.asarray(sol.brdf, dtype=float))
    btdf = np.atleast_2d(np.asarray(sol.btdf, dtype=float))
    series = [(f"BRDF {lab}", signed[order], brdf[i][order]) for i, lab in enumerate(sol.labels)]
    if np.any(btdf > 0):
        series += [(f"BTDF {lab}", signed[order], btdf[i][order])
                   for i, lab in enumerate(sol.labels)]
    svg = svg_plot(series, xlabel="exit angle theta (deg, mirror side > 0)", ylabel="1/sr",
                   title="BRDF / BTDF at the output directions")
    return f"<div>{t}{svg}</div>"


def bsdf_html(b: Any, theta_i: float = 30.0) -> str:
    """The HTML of a :class:`km.Bsdf`: its settings, totals at ``theta_i`` and
    its BRDF in the plane of incidence at ``theta_i``."""
    tot = b.totals(theta_i)
    rows = [["streams", b.streams], ["n above", b.n_above],
            ["n below", "opaque" if b.n_below is None else b.n_below]]
    rows += [[f"{k} at {theta_i:g} deg", *_per_channel(v, b.channels)] for k, v in tot.items()]
    t = table(f"km.Bsdf, {b.channels} channel(s)", ["", *b.labels], rows)
    theta_o = np.linspace(0.0, 85.0, 35)
    fwd = np.atleast_2d(b.brdf(theta_i, theta_o, 180.0))
    back = np.atleast_2d(b.brdf(theta_i, theta_o, 0.0))
    x = np.concatenate([-theta_o[::-1], theta_o])
    series = [(f"BRDF {lab}", x, np.concatenate([back[i][::-1], fwd[i]]))
              for i, lab in enumerate(b.labels)]
    svg = svg_plot(series, xlabel="theta_o (deg, mirror side > 0)", ylabel="BRDF (1/sr)",
                   title=f"In the plane of incidence, theta_i = {theta_i:g} deg")
    return f"<div>{t}{svg}</div>"


def batch_html(b: Any) -> str:
    """The HTML of a :class:`km.Batch`: its shape and totals over the points."""
    r = np.asarray(b.reflectance).reshape(b.shape + ((b.channels,) if b.channels > 1 else ()))
    t_ = np.asarray(b.transmittance).reshape(r.shape)
    rows = [["points", int(np.prod(b.shape))], ["channels", b.channels],
            ["reflectance min", float(np.nanmin(r))], ["reflectance max", float(np.nanmax(r))],
            ["transmittance min", float(np.nanmin(t_))],
            ["transmittance max", float(np.nanmax(t_))]]
    t = table(f"km.Batch, shape {b.shape}", ["", "value"], rows)
    flat_r = r.reshape(-1, b.channels)[:, 0]
    flat_t = t_.reshape(-1, b.channels)[:, 0]
    idx = np.arange(flat_r.size)
    svg = svg_plot([("reflectance", idx, flat_r), ("transmittance", idx, flat_t)],
                   xlabel="point (C order)", ylabel="channel 0", title="Totals over the points")
    return f"<div>{t}{svg}</div>"


def fit_html(r: Any) -> str:
    """The HTML of a :class:`km.FitResult`: the fitted properties and readings."""
    keys = ("albedo", "tau", "g", "mu_a", "mu_s", "mu_s_prime", "residual")
    rows = [[k, getattr(r, k)] for k in keys] + [["status", r.status]]
    rows += [[f"fitted {k}", v] for k, v in r.fitted.items()]
    t = table("km.FitResult", ["", "value"], rows)
    names = list(r.fitted)
    svg = svg_plot([("fitted readings", np.arange(len(names)), list(r.fitted.values()))],
                   xlabel=" / ".join(names), ylabel="reading", title="What the fit would read")
    return f"<div>{t}{svg}</div>"


def fit_results_html(f: Any) -> str:
    """The HTML of :class:`km.FitResults`: one row per point, and the fitted
    properties over the points (or wavelengths)."""
    cols = [k for k in f.KEYS if k in f and np.asarray(f[k]).dtype.kind == "f"]
    n = len(f.rows)
    show = range(min(n, 20))
    flat = {k: np.asarray(f[k]).ravel() for k in cols}
    rows = [[str(i), *[flat[k][i] for k in cols]] for i in show]
    t = table(f"km.FitResults, {n} point(s)" + (" (first 20)" if n > 20 else ""),
              ["point", *cols], rows)
    x = np.asarray(f["wavelength_nm"]).ravel() if "wavelength_nm" in f else np.arange(n)
    xl = "wavelength (nm)" if "wavelength_nm" in f else "point (C order)"
    shown = ("albedo", "g") if "albedo" in f else ("R_inf", "K_over_S")
    series = [(k, x, np.asarray(f[k]).ravel()) for k in shown if k in f]
    svg = svg_plot(series, xlabel=xl, ylabel=", ".join(shown), title="Fitted over the points")
    return f"<div>{t}{svg}</div>"
