"""The whole BSDF of a stack as numpy arrays (:func:`km.bsdf`, :class:`Bsdf`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _km
from ._km import Scene
from ._repr import bsdf_html
from ._solve import _integers_named

_TOTALS = ("reflectance", "transmittance", "reflectance_specular", "transmittance_direct")


def _gauss_angles(n: int) -> np.ndarray:
    """Arccosines (degrees, ascending) of the n Gauss-Legendre nodes on mu in (0, 1)."""
    x, _ = np.polynomial.legendre.leggauss(n)
    return np.sort(np.degrees(np.arccos(0.5 * (x + 1.0))))


def _check_side(side: str) -> str:
    if side not in ("above", "below"):
        raise _km.KmError(f'invalid option side: "{side}": expected "above" or "below"')
    return side


def _shape(values: np.ndarray, channels: int, shape: tuple[int, ...]) -> Any:
    """A ``channels x n`` array as ``shape`` (one channel) or ``(channels,) + shape``."""
    if channels == 1:
        out = values[0].reshape(shape)
        return float(out) if shape == () else out
    return values.reshape((channels,) + shape)


class Bsdf:
    """The whole BSDF of a scene's stack (docs/bsdf.md), from :func:`km.bsdf`.

    The smooth parts (BRDF, BTDF, 1/sr per unit irradiance on the surface)
    at any incidence ``theta_i``, exit ``theta_o`` (degrees in [0, 90), each
    from the normal on its side) and azimuth ``phi`` (degrees; light arrives
    from ``phi = 0``, ``phi = 180`` is the mirror side), for light from
    above (the ambient medium) or from below (through a transparent
    substrate); the delta parts (mirror reflection, unscattered beam) and
    the totals per incidence. Every call solves the stack (multi-flux, one
    set of operators per Fourier order) on the distinct polar angles it is
    given, with the same streams each time (:attr:`streams`): the values are
    those of ``km bsdf`` at those angles, not an interpolation.

    Parameters
    ----------
    core : km._km._BsdfCore
        The extension's BSDF; use :func:`km.bsdf` to make one.

    Attributes
    ----------
    streams : int
        Gauss nodes per hemisphere and Snell segment of every evaluation.
    transmits : bool
        Whether light leaves through the far side.
    n_above, n_below : float, float or None
        Refractive indices above and below the stack (None: opaque).
    channels : int
        Number of spectral channels.
    labels : list of str
        Channel labels.
    wavelengths_nm : list of float or None
        Wavelengths of the channels.

    Examples
    --------
    >>> import km
    >>> b = km.bsdf(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)]), streams=8)
    >>> b.brdf(30.0, [0.0, 30.0], 180.0).shape
    (2,)
    >>> sorted(b.totals(30.0))[:2]
    ['reflectance', 'reflectance_specular']
    """

    def __init__(self, core: _km._BsdfCore) -> None:
        self._core = core

    def __reduce__(self) -> tuple[Any, ...]:  # picklable through the core
        return (Bsdf, (self._core,))

    def _repr_html_(self) -> str:
        return bsdf_html(self)

    def __repr__(self) -> str:
        return (f"km.Bsdf({self.channels} channel(s), streams={self.streams}, "
                f"transmits={self.transmits})")

    @property
    def streams(self) -> int:
        """Gauss nodes per hemisphere and Snell segment used by every evaluation."""
        return self._core.streams

    @property
    def fourier_tol(self) -> float:
        """Where the azimuthal series stops (``km bsdf --fourier-tol``)."""
        return self._core.fourier_tol

    @property
    def transmits(self) -> bool:
        """Whether light leaves through the far side (transparent substrate, no half-space)."""
        return self._core.transmits

    @property
    def n_above(self) -> float:
        """Refractive index of the ambient medium."""
        return self._core.n_above

    @property
    def n_below(self) -> float | None:
        """Refractive index of the medium below the stack, None when it is opaque."""
        return self._core.n_below

    @property
    def channels(self) -> int:
        """Number of spectral channels."""
        return self._core.channels

    @property
    def labels(self) -> list[str]:
        """Channel labels."""
        return self._core.labels

    @property
    def wavelengths_nm(self) -> list[float] | None:
        """Wavelengths (nm) of the channels when the scene gives them."""
        return self._core.wavelengths_nm

    def eval(self, theta_i: Any, theta_o: Any, phi: Any, *, transmitted: bool = False,
             side: str = "above") -> Any:
        """The smooth BRDF (or, with ``transmitted=True``, BTDF), 1/sr (eq. B1 of docs/bsdf.md).

        Parameters
        ----------
        theta_i, theta_o, phi : float or array_like
            Incidence, exit (degrees in [0, 90), each from the normal on its
            side) and azimuth (degrees; 180 is the mirror side), broadcast
            against each other (numpy rules).
        transmitted : bool, default False
            The BTDF instead of the BRDF (0 for an opaque stack).
        side : {"above", "below"}, default "above"
            Light from the ambient medium, or from below through a
            transparent substrate.

        Returns
        -------
        float or ndarray
            The broadcast shape for one channel (a float for scalars),
            ``(channels,) + shape`` otherwise.

        Raises
        ------
        KmError
            An angle out of range, an unknown side, ``side="below"`` on an
            opaque stack.

        Examples
        --------
        >>> import km
        >>> b = km.bsdf(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)]), streams=8)
        >>> b.eval(0.0, 0.0, 0.0) > 0
        True
        """
        ti, to, ph = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                           for a in (theta_i, theta_o, phi)))
        shape = ti.shape
        # At most a table's worth of values per call, checked before the
        # broadcast arrays are copied (10^7 azimuths took 870 MB).
        size = int(np.prod(shape, dtype=np.int64)) * self.channels
        if size > self._core.max_values:
            raise _km.KmError(
                f"invalid option phi: {self.channels} channel(s) x {size // self.channels} "
                f"points = {size} values, over the {self._core.max_values} of one call: "
                "evaluate in chunks")
        flat = [np.ascontiguousarray(a.ravel()) for a in (ti, to, ph)]
        values = self._core._eval(_check_side(side), bool(transmitted), *flat)
        return _shape(np.asarray(values), self.channels, shape)

    def brdf(self, theta_i: Any, theta_o: Any, phi: Any, *, side: str = "above") -> Any:
        """The smooth BRDF, 1/sr: ``eval(theta_i, theta_o, phi, side=side)``.

        Parameters
        ----------
        theta_i, theta_o, phi : float or array_like
            Angles in degrees, as for :meth:`eval`.
        side : {"above", "below"}, default "above"
            As for :meth:`eval`.

        Returns
        -------
        float or ndarray
            As for :meth:`eval`.
        """
        return self.eval(theta_i, theta_o, phi, transmitted=False, side=side)

    def btdf(self, theta_i: Any, theta_o: Any, phi: Any, *, side: str = "above") -> Any:
        """The smooth BTDF, 1/sr (0 when opaque): ``eval(..., transmitted=True)``.

        Parameters
        ----------
        theta_i, theta_o, phi : float or array_like
            Angles in degrees, as for :meth:`eval`.
        side : {"above", "below"}, default "above"
            As for :meth:`eval`.

        Returns
        -------
        float or ndarray
            As for :meth:`eval`.
        """
        return self.eval(theta_i, theta_o, phi, transmitted=True, side=side)

    def totals(self, theta_i: Any, *, side: str = "above") -> dict[str, Any]:
        """The totals and delta parts per incidence.

        Parameters
        ----------
        theta_i : float or array_like
            Incidence angles, degrees.
        side : {"above", "below"}, default "above"
            As for :meth:`eval`.

        Returns
        -------
        dict
            ``reflectance`` and ``transmittance`` (totals, delta parts
            included), ``reflectance_specular`` (mirror reflection) and
            ``transmittance_direct`` (unscattered beam), each with the shape
            of ``theta_i`` (one channel) or ``(channels,) + shape``.

        Notes
        -----
        The smooth parts' albedo is ``reflectance - reflectance_specular``
        (resp. ``transmittance - transmittance_direct``) = the integral of
        ``eval(...) * cos(theta_o)`` over the exit hemisphere.
        """
        ti = np.asarray(theta_i, dtype=np.float64)
        d = self._core._totals(_check_side(side), np.ascontiguousarray(ti.ravel()))
        return {k: _shape(np.asarray(d[k]), self.channels, ti.shape) for k in _TOTALS}

    def table(self, theta_i: Any = None, theta_o: Any = None, phi: Any = None, *,
              side: str = "above", exact_single_path: bool = True) -> dict[str, Any]:
        """The arrays that ``km bsdf --format npz`` writes, on the grids given.

        Parameters
        ----------
        theta_i, theta_o, phi : array_like, optional
            The grids, degrees.
        side : {"above", "below"}, default "above"
            As for :meth:`eval`.
        exact_single_path : bool, default True
            Through a rough face, the beam's path that meets it once is
            exact (point values of a lobe as narrow as the face's, as
            ``km bsdf`` writes them); ``False`` keeps the Fourier series
            alone, band-limited to the table's orders (for a grid coarser
            than the lobe that is interpolated, as :mod:`km.mitsuba` does;
            docs/rough.md eq. R18).

        Returns
        -------
        dict
            See below.

        Notes
        -----
        Defaults as ``km bsdf``: ``theta_i`` normal incidence (0) and the
        arccosines of 32 Gauss nodes in mu, ``theta_o`` those 32 Gauss angles
        (``theta_i`` itself when ``theta_i`` is given), ``phi`` = 0, 5, ..., 355. Keys:
        ``theta_i``, ``theta_o``, ``phi`` (1-D, degrees), ``brdf``, ``btdf``
        (``channels x n_i x n_o x n_phi``, 1/sr), ``reflectance``,
        ``transmittance``, ``reflectance_specular``, ``transmittance_direct``
        (``channels x n_i``), ``fourier_orders`` (per channel) and
        ``streams``. Always with the channel axis, as in the file.
        """
        gauss = _gauss_angles(32)
        if theta_i is None:
            ti = np.concatenate(([0.0], gauss))
            to = gauss if theta_o is None else np.asarray(theta_o, dtype=np.float64)
        else:
            ti = np.asarray(theta_i, dtype=np.float64)
            to = ti if theta_o is None else np.asarray(theta_o, dtype=np.float64)
        ph = np.arange(72) * 5.0 if phi is None else np.asarray(phi, dtype=np.float64)
        ti_, to_, ph_ = (np.ascontiguousarray(np.atleast_1d(a).ravel()) for a in (ti, to, ph))
        return dict(self._core._table(_check_side(side), ti_, to_, ph_, bool(exact_single_path)))


def bsdf(scene: Scene, *, streams: int | None = None,
         max_fourier_order: int | None = None,
         fourier_tol: float | None = None) -> Bsdf:
    """The whole BSDF of ``scene``'s stack (multi-flux; docs/bsdf.md).

    The scene's light and output directions are ignored.

    Parameters
    ----------
    scene : Scene
        The stack.
    streams : int, optional
        Gauss nodes per hemisphere and Snell segment (default: what
        ``km bsdf`` chooses, the solver's default for the most demanding of
        its 32 default incidences, over all channels).
    max_fourier_order : int, optional
        Bound of the azimuthal series (default: as the series needs).
    fourier_tol : float, optional
        Where the azimuthal series stops: after two orders whose light
        scattered more than once is below this fraction of the table's
        largest order-0 coefficient (``km bsdf --fourier-tol``; default
        1e-9, at most 0.1; docs/multiflux.md eq. 5j).

    Returns
    -------
    Bsdf
        Evaluates the BRDF/BTDF and totals at any angles.

    Raises
    ------
    KmError
        A scene the multi-flux solver refuses.

    Examples
    --------
    >>> import km
    >>> b = km.bsdf(km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)]), streams=8)
    >>> b.streams, b.transmits
    (8, True)
    """
    return Bsdf(_km._BsdfCore(scene, streams, max_fourier_order, fourier_tol))


bsdf = _integers_named(bsdf)
