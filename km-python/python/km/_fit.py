"""Fitting: :func:`km.fit` (slab inverse, docs/inverse.md), :func:`km.fit_file`
(a measurement file, as ``km fit FILE``) and :func:`km.fit_km` (the
Kubelka-Munk inverse of paint films, docs/inverse-km.md).

Over many points all three return one shape: :class:`FitResults`, a dict of
numpy arrays with documented keys (and ``rows``, the per-point JSON objects
of the ``km fit --json`` output).
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _km
from ._errors import KmError
from ._km import FitResult
from ._repr import fit_results_html
from ._solve import _integers_named

# Columns of a slab fit: (key, where in the JSON object).
_SLAB = (("albedo", ("albedo",)), ("tau", ("tau",)), ("g", ("g",)), ("mu_a", ("mu_a",)),
         ("mu_s", ("mu_s",)), ("mu_s_prime", ("mu_s_prime",)), ("residual", ("residual",)),
         ("m_r_fitted", ("fitted", "m_r")), ("m_t_fitted", ("fitted", "m_t")),
         ("m_u_fitted", ("fitted", "m_u")), ("u_albedo", ("uncertainty", "albedo")),
         ("u_tau", ("uncertainty", "tau")), ("u_g", ("uncertainty", "g")),
         ("u_mu_a", ("uncertainty", "mu_a")), ("u_mu_s", ("uncertainty", "mu_s")),
         ("u_mu_s_prime", ("uncertainty", "mu_s_prime")),
         ("evaluations", ("evaluations",)), ("streams", ("streams",)))
# Columns of a Kubelka-Munk fit.
_KM = (("K", ("K",)), ("S", ("S",)), ("K_over_S", ("K_over_S",)), ("S_X", ("S_X",)),
       ("R_inf", ("R_inf",)), ("R_0", ("R_0",)), ("T", ("T",)), ("thickness", ("thickness",)),
       ("u_K", ("uncertainty", "K")), ("u_S", ("uncertainty", "S")))


def _get(row: dict[str, Any], path: tuple[str, ...]) -> float:
    v: Any = row
    for p in path:
        v = v.get(p) if isinstance(v, dict) else None
    return float("nan") if v is None or isinstance(v, bool) else float(v)


def _scalar(v: npt.ArrayLike) -> float:
    return float(np.asarray(v, dtype=np.float64))


def _optional(v: npt.ArrayLike | None) -> float | None:
    return None if v is None else _scalar(v)


class FitResults(dict[str, Any]):
    """The results of a fit over many points: a dict of numpy arrays.

    Every array has the shape of the points (the broadcast shape of the
    readings for :func:`fit` and :func:`fit_km`, ``(rows,)`` for
    :func:`fit_file`); a point that could not be fitted is NaN in every
    float column, ``"invalid"`` in ``status`` and has its message in ``error``.

    Keys of a slab fit (:func:`fit`, :func:`fit_file`): ``albedo``, ``tau``,
    ``g``, ``mu_a``, ``mu_s``, ``mu_s_prime`` (1/unit of the thickness),
    ``residual``, ``m_r_fitted``, ``m_t_fitted``, ``m_u_fitted`` (what the
    fitted sample would read; NaN where not measured), ``u_albedo``,
    ``u_tau``, ``u_g``, ``u_mu_a``, ``u_mu_s``, ``u_mu_s_prime`` (standard
    uncertainties), ``evaluations``, ``streams`` (float arrays), ``status``
    and ``error`` (str arrays); :func:`fit_file` adds ``wavelength_nm``.

    Keys of a Kubelka-Munk fit (:func:`fit_km`): ``K``, ``S``,
    ``K_over_S``, ``S_X``, ``R_inf``, ``R_0``, ``T``, ``thickness``,
    ``u_K``, ``u_S`` (NaN where the mode does not give them), ``mode``,
    ``status``, ``error``.

    Parameters
    ----------
    rows : sequence of dict
        Per point, the ``km fit --json`` object, or ``{"status": "invalid",
        "error": message}``.
    shape : tuple of int
        The shape of the points.
    kind : {"slab", "km"}
        Which fit.

    Attributes
    ----------
    rows : list of dict
        The per-point JSON objects, in C order (``km fit FILE --json`` prints
        this list for a file).
    shape : tuple of int
        The shape of the points.

    Examples
    --------
    >>> import km, numpy as np
    >>> r = km.fit(np.array([0.2726, 0.30]), np.array([0.2991, 0.28]), thickness=1,
    ...            n_sample=1.4, n_slide=1.5)
    >>> sorted(k for k in r if k.startswith("mu_"))
    ['mu_a', 'mu_s', 'mu_s_prime']
    >>> r["albedo"].shape
    (2,)
    """

    KEYS = tuple(k for k, _ in _SLAB) + tuple(k for k, _ in _KM) + ("wavelength_nm",)

    def __init__(self, rows: Sequence[dict[str, Any]], shape: tuple[int, ...],
                 kind: Literal["slab", "km"] = "slab") -> None:
        super().__init__()
        self.rows = list(rows)
        self.shape = tuple(shape)
        cols = _SLAB if kind == "slab" else _KM
        for key, path in cols:
            self[key] = np.array([_get(r, path) for r in self.rows],
                                 dtype=np.float64).reshape(self.shape)
        if kind == "km":
            self["mode"] = np.array([str(r.get("mode", "")) for r in self.rows],
                                    dtype=str).reshape(self.shape)
        if any("wavelength_nm" in r for r in self.rows):
            self["wavelength_nm"] = np.array([_get(r, ("wavelength_nm",)) for r in self.rows],
                                             dtype=np.float64).reshape(self.shape)
        self["status"] = np.array([str(r.get("status", "converged")) for r in self.rows],
                                  dtype=str).reshape(self.shape)
        self["error"] = np.array([str(r.get("error", "")) for r in self.rows],
                                 dtype=str).reshape(self.shape)

    def __repr__(self) -> str:
        ok = int(np.sum(self["status"] != "invalid"))
        return f"km.FitResults({len(self.rows)} point(s), {ok} fitted, keys={list(self)})"

    def _repr_html_(self) -> str:
        return fit_results_html(self)


def fit(m_r: npt.ArrayLike, m_t: npt.ArrayLike, m_u: npt.ArrayLike | None = None, *,
        thickness: float, n_sample: float = 1.0, n_slide: float | None = None,
        g: npt.ArrayLike | None = None, sigma_r: npt.ArrayLike | None = None,
        sigma_t: npt.ArrayLike | None = None, sigma_u: npt.ArrayLike | None = None,
        specular_in_m_r: float = 1.0, unscattered_in_m_t: float = 1.0,
        incidence: float = 0.0, streams: int | None = None,
        errors: Literal["raise", "keep"] = "raise",
        budget: float = 1.0) -> FitResult | FitResults:
    """Albedo, optical thickness and g of a slab from its measured readings.

    The slab inverse of ``km fit`` (after Prahl's inverse adding-doubling;
    docs/inverse.md): from the total reflectance ``m_r``, total
    transmittance ``m_t`` and, optionally, the unscattered transmittance
    ``m_u``. The keyword arguments are the flags of ``km fit``. Arrays (a
    spectrum) are fitted in parallel with the GIL released.

    Parameters
    ----------
    m_r, m_t : float or array_like
        Measured total reflectance and transmittance (fractions).
    m_u : float or array_like, optional
        Measured unscattered transmittance; with it ``g`` is fitted too.
    thickness : float
        Sample thickness; the coefficients come out in its inverse unit.
    n_sample : float, default 1.0
        Refractive index of the sample.
    n_slide : float, optional
        Refractive index of glass slides on both faces.
    g : float or array_like, optional
        Fixed anisotropy (default 0, or fitted when ``m_u`` is given).
    sigma_r, sigma_t, sigma_u : float or array_like, optional
        Standard uncertainties of the readings (default 1e-4).
    specular_in_m_r, unscattered_in_m_t : float, default 1.0
        Fractions of the mirror reflection and the unscattered beam that the
        readings include (iad's ``-c``/``-C``).
    incidence : float, default 0.0
        Angle of incidence, degrees.
    streams : int, optional
        Streams of the forward model.
    errors : {"raise", "keep"}, default "raise"
        For arrays: a point that cannot be fitted raises (naming the point),
        or (``"keep"``) is NaN with ``status == "invalid"`` and its message
        in ``error``.
    budget : float, default 1.0
        For arrays: factor on the budget of readings a call (10**4, about
        0.5 ms of fitting each; docs/limits.md); more readings are refused
        before any is fitted.

    Returns
    -------
    FitResult or FitResults
        For scalar readings one :class:`FitResult` (``to_dict()`` is the
        ``km fit --json`` object); for arrays (broadcast together; NaN in
        ``m_u``, ``g`` or ``sigma_*`` means "not given" at that point) a
        :class:`FitResults` dict of arrays of the broadcast shape.

    Raises
    ------
    KmError
        A reading outside [0, 1], an impossible combination, a point that
        cannot be fitted (``errors="raise"``); ``key`` names the argument.

    Examples
    --------
    >>> import km
    >>> r = km.fit(0.2726, 0.2991, thickness=1, n_sample=1.4, n_slide=1.5)
    >>> round(r.albedo, 3), round(r.tau, 2)
    (0.9, 2.0)
    >>> rs = km.fit([0.2726, 0.2726], [0.2991, 0.2991], thickness=1, n_sample=1.4,
    ...             n_slide=1.5)
    >>> rs["albedo"].round(3).tolist()
    [0.9, 0.9]
    """
    if errors not in ("raise", "keep"):
        raise KmError(f'invalid option errors: "{errors}": expected "raise" or "keep"')
    kw: dict[str, Any] = dict(thickness=thickness, n_sample=n_sample, n_slide=n_slide,
                              specular_in_m_r=specular_in_m_r,
                              unscattered_in_m_t=unscattered_in_m_t,
                              incidence=incidence, streams=streams)
    per_point = dict(m_r=m_r, m_t=m_t, m_u=m_u, g=g, sigma_r=sigma_r, sigma_t=sigma_t,
                     sigma_u=sigma_u)
    if all(v is None or np.ndim(v) == 0 for v in per_point.values()):
        one: FitResult = _km._fit(_scalar(m_r), _scalar(m_t), _optional(m_u), g=_optional(g),
                                  sigma_r=_optional(sigma_r), sigma_t=_optional(sigma_t),
                                  sigma_u=_optional(sigma_u), **kw)
        return one
    given = {k: np.asarray(v, dtype=np.float64) for k, v in per_point.items() if v is not None}
    arrays = dict(zip(given, np.broadcast_arrays(*given.values())))
    shape = next(iter(arrays.values())).shape
    col = {k: (np.ascontiguousarray(arrays[k].ravel()) if k in arrays else None)
           for k in per_point}
    out = _km._fit_many(np.ascontiguousarray(arrays["m_r"].ravel()),
                        np.ascontiguousarray(arrays["m_t"].ravel()), col["m_u"], col["g"],
                        col["sigma_r"], col["sigma_t"], col["sigma_u"], budget=budget, **kw)
    rows: list[dict[str, Any]] = []
    for i, r in enumerate(out):
        if isinstance(r, BaseException):
            if errors == "raise":
                raise KmError(f"point {i}: {r}") from r
            rows.append({"status": "invalid", "error": str(r)})
        else:
            rows.append(r.to_dict())
    return FitResults(rows, shape, "slab")


def fit_file(path: str | PathLike[str], *, thickness: float | None = None,
             n_sample: float = 1.0, n_slide: float | None = None, g: float | None = None,
             sigma_r: float | None = None, sigma_t: float | None = None,
             sigma_u: float | None = None, specular_in_m_r: float = 1.0,
             unscattered_in_m_t: float = 1.0, incidence: float = 0.0,
             streams: int | None = None, fix_mu_s: float | str | None = None,
             fix_mu_a: float | None = None, semi_infinite: bool = False,
             budget: float = 1.0) -> FitResults:
    """Fit every row of a measurement file, as ``km fit FILE --json`` does.

    iad's ``.rxt`` (sample and spheres from its header) or a ``.csv`` with
    columns ``wavelength_nm, m_r, m_t[, m_u, sigma_r, sigma_t, sigma_u, g]``.
    Rows are fitted in parallel with the GIL released.

    Parameters
    ----------
    path : str or path-like
        The ``.rxt`` or ``.csv`` file.
    thickness : float, optional
        Sample thickness (required for a ``.csv``; an ``.rxt`` has its own).
    n_sample, n_slide, g, sigma_r, sigma_t, sigma_u : float, optional
        As for :func:`fit`; the sigmas and ``g`` stand where a row has none.
    specular_in_m_r, unscattered_in_m_t : float, default 1.0
        As for :func:`fit`; values other than 1 override the file's.
    incidence : float, default 0.0
        Angle of incidence, degrees.
    streams : int, optional
        Streams of the forward model.
    fix_mu_s : float or str, optional
        For the rows of an ``.rxt`` that give ``M_R`` alone (``km fit
        --fix-mu-s``, iad's ``-F``): ``mu_s`` fixed (1/length) and ``mu_a``
        fitted; or a power law of the row's wavelength, ``"P L0 MU_S0 EXP"``
        for ``mu_s`` or ``"R L0 MU_SP0 EXP"`` for ``mu_s'`` (docs/inverse.md
        eq. R3).
    fix_mu_a : float, optional
        For those rows: ``mu_a`` fixed and ``mu_s`` fitted.
    semi_infinite : bool, default False
        For those rows: a semi-infinite sample, the albedo fitted. At most
        one of ``fix_mu_s``, ``fix_mu_a``, ``semi_infinite``.
    budget : float, default 1.0
        Factor on the row budget of a file (10**4 rows, about 0.5 ms of
        fitting each; docs/limits.md): a file of more rows is refused,
        naming its count, as soon as the count is passed.

    Returns
    -------
    FitResults
        Arrays of shape ``(rows,)`` with ``wavelength_nm``; a row that
        cannot be fitted has ``status == "invalid"`` and its ``error``.
        ``.rows`` is the list that ``km fit FILE --json`` prints.

    Raises
    ------
    KmFileNotFoundError
        The file does not exist (a ``FileNotFoundError`` too).
    KmError
        Not a ``.rxt`` or ``.csv``, a ``.csv`` without ``thickness``, a file
        of which no row can be fitted, a file of more rows than the budget.

    Examples
    --------
    >>> import km
    >>> r = km.fit_file("examples/fit-synthetic.rxt")    # doctest: +SKIP
    >>> r["wavelength_nm"].shape == r["albedo"].shape    # doctest: +SKIP
    True
    """
    rows = _km.fit_file(path, thickness=thickness, n_sample=n_sample, n_slide=n_slide, g=g,
                        sigma_r=sigma_r, sigma_t=sigma_t, sigma_u=sigma_u,
                        specular_in_m_r=specular_in_m_r, unscattered_in_m_t=unscattered_in_m_t,
                        incidence=incidence, streams=streams, fix_mu_s=fix_mu_s,
                        fix_mu_a=fix_mu_a, semi_infinite=semi_infinite, budget=budget)
    return FitResults(rows, (len(rows),), "slab")


def fit_km(*, r_black: npt.ArrayLike | None = None, r_white: npt.ArrayLike | None = None,
           r_white_ground: npt.ArrayLike | None = None,
           r_black_ground: npt.ArrayLike | None = None, r_inf: npt.ArrayLike | None = None,
           r_zero: npt.ArrayLike | None = None, thickness: npt.ArrayLike | None = None,
           n: float | None = None, k2: float | None = None,
           errors: Literal["raise", "keep"] = "raise") -> dict[str, Any] | FitResults:
    """Kubelka-Munk inverse of a paint film (``km fit --km``; docs/inverse-km.md).

    Three ways in: ``r_black``, ``r_white``, ``r_white_ground``
    [``r_black_ground``] and ``thickness`` (a drawdown over two grounds,
    Kubelka 1948); ``r_inf``, ``r_zero`` and ``thickness`` (an opaque film
    and one over ideal black); ``r_inf`` alone (only K/S). With ``n`` (and
    optionally ``k2``) the readings are instrument readings and get
    Saunderson's correction.

    Parameters
    ----------
    r_black, r_white : float or array_like, optional
        Reflectance of the film over the black and the white ground.
    r_white_ground, r_black_ground : float or array_like, optional
        Reflectance of the grounds (black default 0).
    r_inf : float or array_like, optional
        Reflectance of an opaque film.
    r_zero : float or array_like, optional
        Reflectance of the film over an ideal black.
    thickness : float or array_like, optional
        Film thickness; K and S come out in its inverse unit.
    n : float, optional
        Refractive index for Saunderson's correction.
    k2 : float, optional
        Saunderson's internal reflection k2 (default from ``n``).
    errors : {"raise", "keep"}, default "raise"
        For arrays: as for :func:`fit`.

    Returns
    -------
    dict or FitResults
        For scalar readings the ``km fit --km --json`` object (``K``, ``S``,
        ``K_over_S``, ``S_X``, ``R_inf``, ``R_0``, ``T``, ``thickness``,
        ``mode``, ``uncertainty``, ``saunderson``, ``inputs``,
        ``internal``); for arrays (broadcast together) a :class:`FitResults`
        of their shape.

    Raises
    ------
    KmError
        A reading at fault (``key`` names it), or a combination of readings
        that is none of the three ways in.

    Examples
    --------
    >>> import km
    >>> km.fit_km(r_inf=0.5)["K_over_S"]
    0.25
    >>> km.fit_km(r_inf=[0.5, 0.8])["K_over_S"].round(4).tolist()
    [0.25, 0.025]
    """
    if errors not in ("raise", "keep"):
        raise KmError(f'invalid option errors: "{errors}": expected "raise" or "keep"')
    readings = dict(r_black=r_black, r_white=r_white, r_white_ground=r_white_ground,
                    r_black_ground=r_black_ground, r_inf=r_inf, r_zero=r_zero,
                    thickness=thickness)
    given = {k: np.asarray(v, dtype=np.float64) for k, v in readings.items() if v is not None}
    if all(a.ndim == 0 for a in given.values()):
        one: dict[str, Any] = _km.fit_km(**{k: float(a) for k, a in given.items()}, n=n, k2=k2)
        return one
    arrays = dict(zip(given, np.broadcast_arrays(*given.values())))
    shape = next(iter(arrays.values())).shape
    rows: list[dict[str, Any]] = []
    for i in range(int(np.prod(shape))):
        point = {k: float(a.ravel()[i]) for k, a in arrays.items()}
        try:
            rows.append(_km.fit_km(**point, n=n, k2=k2))
        except KmError as e:
            if errors == "raise":
                raise KmError(f"point {i}: {e}") from e
            rows.append({"status": "invalid", "error": str(e)})
    return FitResults(rows, shape, "km")


fit = _integers_named(fit)
fit_file = _integers_named(fit_file)
