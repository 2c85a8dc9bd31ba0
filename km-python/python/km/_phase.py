"""Phase functions and Mie theory: :func:`km.phase` (each layer's phase
function, moments and Mie efficiencies, as ``km phase SCENE``) and
:func:`km.mie` (one sphere)."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _km
from ._errors import KmError, KmTypeError
from ._km import Scene


def _refuse(cls: type[KmError], key: str, message: str) -> KmError:
    """A :class:`KmError` (or subclass) naming the argument ``key``."""
    e = cls(message)
    e.key = key
    e.line = None
    return e


def _angles(angles_deg: Any) -> list[float] | None:
    """The angles as a list of floats (any array_like of numbers), or None."""
    if angles_deg is None:
        return None
    try:
        a = np.asarray(angles_deg, dtype=float)
    except (TypeError, ValueError):
        raise _refuse(KmTypeError, "angles_deg",
                      f"invalid option angles_deg: {angles_deg!r} is not a sequence of "
                      "numbers (degrees in [0, 180])") from None
    return [float(x) for x in a.ravel()]


def _count(name: str, value: Any) -> int | None:
    """A whole number >= 0 (a Python or numpy integer), or None."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _refuse(KmTypeError, name,
                      f"invalid option {name}: {value!r} is not a whole number")
    count = int(value)
    if count < 0 or count >= 2**63:
        raise _refuse(KmError, name, f"invalid option {name}: {count} must be >= 0")
    return count


def _real(name: str, value: Any) -> float:
    """A real number (Python or numpy); its domain is checked by the library."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _refuse(KmTypeError, name, f"invalid option {name}: {value!r} is not a number")
    return float(value)


def phase(
    scene: Scene,
    angles_deg: npt.ArrayLike | None = None,
    moments: int | None = None,
) -> dict[str, Any]:
    """Each layer's phase function, Legendre moments, g and Mie efficiencies,
    as ``km phase SCENE --format json`` (docs/phase.md §6).

    ``p`` is in 1/sr, normalised over the sphere (``integral p dOmega = 1``,
    docs/phase.md eq. P1; DISORT's phase function, of mean 1, is
    ``4 pi p``). The moments are DISORT's ``PMOM``:
    ``chi_l = 2 pi integral p P_l dmu``, ``chi_0 = 1``, ``chi_1 = g``.

    Parameters
    ----------
    scene : Scene
        The scene.
    angles_deg : array_like, optional
        Scattering angles, degrees in [0, 180] (at most 10 000). Default:
        every 0.05 below 1, every 0.25 to 10, every degree to 180 (227).
    moments : int, optional
        ``K``: the moments ``chi_0 .. chi_K`` (at most 16 384; a table's
        first 4096 are known). Default ``2N``, ``N`` the multi-flux
        solver's default streams for the scene: the moments its delta-M
        uses (it keeps ``chi_0 .. chi_{2N-1}`` and truncates at ``chi_{2N}``).

    Returns
    -------
    dict
        ``angles_deg``, ``cos_theta`` (A,), ``labels``, ``wavelengths_nm``
        (C, or None), ``max_moment`` (``K``), ``default_streams`` (``N``
        when ``K`` was the default, else None), ``normalisation`` (in
        words) and ``layers``: one dict per layer (top first) with
        ``layer`` (1-based), ``kind`` (a list of C names), ``scatters``
        (C, bool), ``sigma_a``, ``sigma_s``, ``thickness``, ``tau``,
        ``albedo``, ``n``, ``g`` (C,), ``series_length`` (a list: the
        length of a finite Legendre series, else None), ``p`` (C x A),
        ``moments`` (C x (K + 1)) (rows of NaN where the layer does not
        scatter), and ``particles``: None, or for a layer of particles a
        dict with ``populations`` (a list of dicts of arrays (C,):
        ``index`` and ``m`` (complex), ``volume_fraction``, ``radius_um``
        or ``median_um`` and ``sigma``, ``r_eff_um``, ``x_eff``,
        ``q_ext``, ``q_sca``, ``q_abs``, ``g``, ``sigma_s``, ``sigma_a``,
        ``terms``, ``radii``; and ``distribution``, ``"mono"`` or
        ``"lognormal"``) and ``mixed`` (the mixture's ``q_ext``, ``q_sca``,
        ``q_abs``, ``g``, ``sigma_s``, ``sigma_a``, ``r_eff_um``,
        ``x_eff``).

    Raises
    ------
    KmError
        An angle outside [0, 180] or too many (key ``angles_deg``), ``K``
        too large or beyond a layer's known moments (key ``moments``).
    KmTypeError
        ``angles_deg`` not numbers, ``moments`` not a whole number.

    Examples
    --------
    >>> import km
    >>> s = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)])
    >>> r = km.phase(s, angles_deg=[0, 90, 180], moments=3)
    >>> r["layers"][0]["kind"], r["layers"][0]["moments"][0].tolist()
    (['hg'], [1.0, 0.5, 0.25, 0.125])
    >>> r["layers"][0]["p"].shape
    (1, 3)
    """
    if not isinstance(scene, Scene):
        raise _refuse(KmTypeError, "scene", f"invalid option scene: {scene!r} is not a km.Scene")
    out: dict[str, Any] = _km._phase(scene, _angles(angles_deg), _count("moments", moments))
    return out


def mie(
    radius_um: float,
    n: float,
    k: float,
    wavelength_nm: float,
    n_host: float = 1.0,
    angles_deg: npt.ArrayLike | None = None,
    moments: int | None = None,
) -> dict[str, Any]:
    """One homogeneous sphere by Mie theory (docs/mie.md): efficiencies,
    asymmetry, amplitudes, phase function and its Legendre moments.

    The sphere has radius ``radius_um`` and index ``n + i k`` (``k >= 0``
    absorbs) in a host of real index ``n_host``, at the vacuum wavelength
    ``wavelength_nm``: size parameter ``x = 2 pi radius_um n_host /
    wavelength`` and relative index ``m = (n + i k) / n_host`` (docs/mie.md
    eq. M1), ``1e-6 <= x <= 20 000`` and ``|m x| <= 200 000`` (M8).

    Parameters
    ----------
    radius_um : float
        Sphere radius, micrometres, > 0.
    n : float
        Real part of the sphere's index, > 0.
    k : float
        Imaginary part (absorption), >= 0.
    wavelength_nm : float
        Vacuum wavelength, nm, > 0.
    n_host : float, default 1.0
        Real index of the host medium, > 0.
    angles_deg : array_like, optional
        Scattering angles, degrees in [0, 180] (default as :func:`km.phase`).
    moments : int, optional
        ``K``: the moments ``chi_0 .. chi_K`` (at most 16 384; zeros beyond
        ``2N``). Default: all ``2N + 1`` of the series (``N`` = ``terms``).
        Their quadrature costs ``O(N^2)`` amplitude terms; ``moments=0``
        skips it.

    Returns
    -------
    dict
        ``qext``, ``qsca``, ``qabs``, ``qback`` (efficiencies, eq. M9,
        M10), ``g`` (M11), ``x``, ``m`` (complex), ``terms`` (``N``),
        ``angles_deg`` and ``cos_theta`` (A,), ``s1`` and ``s2`` (A,
        complex: the amplitudes of Bohren & Huffman, eq. M6, time
        dependence ``exp(-i omega t)``), ``p`` (A,: the phase function in
        1/sr, ``integral p dOmega = 1``, M12) and ``moments`` (``chi_0 = 1
        .. chi_K``, DISORT's ``PMOM``, M13).

    Raises
    ------
    KmError
        A value outside its domain, named by its argument (``radius_um``
        also for a size parameter outside the limits), ``angles_deg``,
        ``moments`` as :func:`km.phase`.
    KmTypeError
        An argument that is not a number.

    Examples
    --------
    >>> import km
    >>> s = km.mie(0.5, 1.5, 0.0, 550.0, angles_deg=[0.0, 180.0])
    >>> round(s["x"], 6), round(s["qext"], 6) == round(s["qsca"], 6)
    (5.711987, True)
    >>> str(s["s1"].dtype), float(s["moments"][0]), bool(abs(s["moments"][1] - s["g"]) < 1e-12)
    ('complex128', 1.0, True)
    """
    out: dict[str, Any] = _km._mie(
        _real("radius_um", radius_um), _real("n", n), _real("k", k),
        _real("wavelength_nm", wavelength_nm), _real("n_host", n_host),
        angles_deg=_angles(angles_deg), moments=_count("moments", moments))
    return out


__all__ = ["mie", "phase"]
