"""Colour: :func:`km.colour`, :func:`km.delta_e2000`, :func:`km.srgb` (docs/colour.md).

Every colour argument is a sequence or a numpy array; results are numpy arrays.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _km
from ._errors import KmError


def _triples(name: str, v: Any) -> npt.NDArray[np.float64]:
    """``v`` as an array of shape ``(..., 3)``, or a :class:`KmError` naming ``name``."""
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise KmError(f"invalid option {name}: expected three numbers ({e})") from None
    if a.ndim == 0 or a.shape[-1] != 3:
        raise KmError(f"invalid option {name}: expected three numbers (last axis of length 3), "
                      f"got shape {a.shape}")
    return a


def colour(
    wavelengths_nm: npt.ArrayLike,
    values: npt.ArrayLike,
    *,
    observer: Literal["1931", "1964"] = "1931",
    illuminant: Literal["D65", "D50"] = "D65",
) -> dict[str, npt.NDArray[Any]]:
    """Colour of a reflectance or transmittance spectrum (docs/colour.md).

    Parameters
    ----------
    wavelengths_nm : array_like
        Wavelengths (nm), strictly increasing, covering the visible.
    values : array_like
        Reflectance or transmittance at those wavelengths (fractions).
    observer : {"1931", "1964"}, default "1931"
        The CIE 2-degree (1931) or 10-degree (1964) observer.
    illuminant : {"D65", "D50"}, default "D65"
        The illuminant.

    Returns
    -------
    dict of ndarray
        ``xyz`` (Y = 100 for the perfect diffuser), ``white`` (the
        illuminant's white point), ``lab`` (CIELAB), ``srgb`` (0..1,
        encoded), each float64 of shape (3,), and ``srgb_u8``, uint8 of shape (3,).

    Raises
    ------
    KmError
        Wavelengths not increasing, lengths that differ, an unknown observer
        or illuminant (``key`` names it).

    Examples
    --------
    >>> import km, numpy as np
    >>> wl = np.arange(380.0, 781.0, 5.0)
    >>> c = km.colour(wl, np.ones_like(wl))
    >>> round(float(c["lab"][0]), 6), c["srgb_u8"].dtype
    (100.0, dtype('uint8'))
    """
    wl = [float(x) for x in np.asarray(wavelengths_nm, dtype=np.float64).ravel()]
    v = [float(x) for x in np.asarray(values, dtype=np.float64).ravel()]
    d = _km.colour(wl, v, observer=observer, illuminant=illuminant)
    out: dict[str, npt.NDArray[Any]] = {
        k: np.asarray(d[k], dtype=np.float64) for k in ("xyz", "white", "lab", "srgb")}
    out["srgb_u8"] = np.frombuffer(bytes(d["srgb_u8"]), dtype=np.uint8).copy()
    return out


def delta_e2000(lab1: npt.ArrayLike, lab2: npt.ArrayLike) -> Any:
    """CIEDE2000 colour difference of CIELAB colours (Sharma, Wu & Dalal 2005).

    Parameters
    ----------
    lab1, lab2 : array_like
        ``(L*, a*, b*)`` triples: tuples, lists or arrays of shape ``(..., 3)``,
        broadcast against each other.

    Returns
    -------
    float or ndarray
        A float for two triples, else an array of the broadcast shape
        without the last axis.

    Raises
    ------
    KmError
        A value that is not finite, or a last axis that is not of length 3.

    Examples
    --------
    >>> import km
    >>> round(km.delta_e2000([50, 0, 0], (50, -1, 2)), 4)
    2.3669
    >>> km.delta_e2000([[50, 0, 0], [60, 0, 0]], [50, 0, 0]).shape
    (2,)
    """
    a, b = np.broadcast_arrays(_triples("lab1", lab1), _triples("lab2", lab2))
    flat = [_km.delta_e2000((p[0], p[1], p[2]), (q[0], q[1], q[2]))
            for p, q in zip(a.reshape(-1, 3).tolist(), b.reshape(-1, 3).tolist())]
    if a.ndim == 1:
        return float(flat[0])
    return np.asarray(flat, dtype=np.float64).reshape(a.shape[:-1])


def srgb(xyz: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """sRGB (IEC 61966-2-1, encoded, 0..1) of CIE XYZ with Y = 100 for white.

    Parameters
    ----------
    xyz : array_like
        ``(X, Y, Z)``, or an array of shape ``(..., 3)``.

    Returns
    -------
    ndarray
        The encoded sRGB values, of the shape of ``xyz``.

    Raises
    ------
    KmError
        A value that is not finite, or a last axis that is not of length 3.

    Examples
    --------
    >>> import km
    >>> km.srgb([95.047, 100.0, 108.883]).round(3)
    array([1., 1., 1.])
    """
    a = _triples("xyz", xyz)
    flat = [_km.srgb((p[0], p[1], p[2])) for p in a.reshape(-1, 3).tolist()]
    return np.asarray(flat, dtype=np.float64).reshape(a.shape)
