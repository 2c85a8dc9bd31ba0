"""`km.fit`: optical properties of a slab from measurements (docs/inverse.md)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _km


def fit(m_r: Any, m_t: Any, m_u: Any = None, *, thickness: float, n_sample: float = 1.0,
        n_slide: float | None = None, g: Any = None, sigma_r: Any = None,
        sigma_t: Any = None, sigma_u: Any = None, specular_in_m_r: float = 1.0,
        unscattered_in_m_t: float = 1.0, incidence: float = 0.0,
        streams: int | None = None, errors: str = "raise") -> Any:
    """Albedo, optical thickness and g of a slab from its measured total
    reflectance ``m_r``, total transmittance ``m_t`` and, optionally,
    unscattered transmittance ``m_u`` (the slab inverse of ``km fit``,
    after Prahl's inverse adding-doubling; docs/inverse.md).

    The keyword arguments are the flags of ``km fit``: ``thickness`` (the
    coefficients come out in its inverse unit), ``n_sample``, ``n_slide``
    (glass slides on both faces), ``g`` (fixed anisotropy; fitted when
    ``m_u`` is given and ``g`` is not), ``sigma_*`` (standard uncertainties
    of the readings, default 1e-4), ``specular_in_m_r`` and
    ``unscattered_in_m_t`` (fractions included, iad's ``-c``/``-C``),
    ``incidence`` (degrees), ``streams`` (forward model).

    Scalars give one :class:`km.FitResult`, whose ``to_dict()`` is the
    ``km fit --json`` object. Arrays (a spectrum: ``m_r``, ``m_t``, ``m_u``,
    ``g``, ``sigma_*`` broadcast against each other; NaN in ``m_u``, ``g``
    or ``sigma_*`` means "not given" at that point) are fitted in parallel
    with the GIL released and give a list of results in C order; a point
    that cannot be fitted raises its :class:`km.KmError` (``errors="raise"``)
    or stands as that exception in the list (``errors="keep"``).
    """
    if errors not in ("raise", "keep"):
        raise _km.KmError(f'invalid option errors: "{errors}": expected "raise" or "keep"')
    kw = dict(thickness=thickness, n_sample=n_sample, n_slide=n_slide,
              specular_in_m_r=specular_in_m_r, unscattered_in_m_t=unscattered_in_m_t,
              incidence=incidence, streams=streams)
    per_point = dict(m_r=m_r, m_t=m_t, m_u=m_u, g=g, sigma_r=sigma_r, sigma_t=sigma_t,
                     sigma_u=sigma_u)
    if all(v is None or np.ndim(v) == 0 for v in per_point.values()):
        scalars = {k: (None if v is None else float(v)) for k, v in per_point.items()}
        return _km._fit(scalars.pop("m_r"), scalars.pop("m_t"), scalars.pop("m_u"),
                        **scalars, **kw)
    given = {k: np.asarray(v, dtype=np.float64) for k, v in per_point.items() if v is not None}
    arrays = dict(zip(given, np.broadcast_arrays(*given.values())))
    col = {k: (np.ascontiguousarray(arrays[k].ravel()) if k in arrays else None)
           for k in per_point}
    out = _km._fit_many(col["m_r"], col["m_t"], col["m_u"], col["g"], col["sigma_r"],
                        col["sigma_t"], col["sigma_u"], **kw)
    if errors == "raise":
        for i, r in enumerate(out):
            if isinstance(r, BaseException):
                raise _km.KmError(f"point {i}: {r}") from r
    return out
