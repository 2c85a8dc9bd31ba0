"""km: light in stacks of flat scattering layers, from Python.

Two-flux Kubelka-Munk, the multi-flux eigenvalue solver (discrete ordinates),
a Monte Carlo reference and the diffusion dipole over one scene description.

    >>> import km
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)])
    >>> sol = km.solve(scene, method="multiflux")
    >>> round(sol.reflectance + sol.transmittance + sol.absorptance, 9)
    1.0

The scene keys are those of the scene file (docs/scene-file.md); every
refusal is a :class:`KmError` naming the key (and the line of a scene
file's text). The user guide is docs/python.md.
"""

from __future__ import annotations

from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from ._km import KmError, Partial, Scene, Solution, __version__, field, merge, run_shard, solve
from . import _km
from ._bsdf import Bsdf, bsdf
from ._fit import fit
from ._km import FitResult, colour, delta_e2000, fit_file, fit_km, srgb

__all__ = [
    "Batch",
    "Bsdf",
    "FitResult",
    "KmError",
    "Partial",
    "Scene",
    "Solution",
    "bsdf",
    "colour",
    "delta_e2000",
    "field",
    "fit",
    "fit_file",
    "fit_km",
    "layer",
    "merge",
    "run_shard",
    "solve",
    "solve_many",
    "srgb",
    "__version__",
]


def layer(
    *,
    sigma_a: Any = None,
    sigma_s: Any = None,
    thickness: Any = None,
    tau: Any = None,
    albedo: Any = None,
    g: Any = None,
    n: Any = None,
    preset: str | None = None,
) -> dict[str, Any]:
    """One ``[[layer]]`` of a scene, as a dict of the keys given.

    Give ``sigma_a``, ``sigma_s`` (1/length) and ``thickness`` (length, or
    ``float("inf")`` for a half-space), or ``tau`` and ``albedo``; ``g``
    (Henyey-Greenstein asymmetry, default 0) and ``n`` (refractive index,
    default that of the ambient medium) are optional. Each value may be a
    number or a list (one value per spectral channel). The keys are checked
    when the :class:`Scene` is built, with the scene file's messages.
    """
    keys = dict(
        sigma_a=sigma_a, sigma_s=sigma_s, thickness=thickness, tau=tau, albedo=albedo, g=g, n=n,
        preset=preset,
    )
    return {k: v for k, v in keys.items() if v is not None}


_SCALARS = ("reflectance", "reflectance_specular", "transmittance", "transmittance_direct",
            "absorptance")


class Batch:
    """The answers of :func:`solve_many` as numpy arrays.

    For ``P`` points (the shape of the sweep, or ``(len(scenes),)``), ``C``
    channels and ``D`` output directions: each total (``reflectance``,
    ``reflectance_specular``, ``transmittance``, ``transmittance_direct``,
    ``absorptance``) has shape ``P`` for one channel and ``P + (C,)``
    otherwise; ``brdf`` and ``btdf`` have shape ``P + (D,)`` or
    ``P + (C, D)``. ``stderr`` and ``error_estimate`` are dicts of such arrays
    (or None). With ``errors="nan"`` a failed point is NaN and ``errors``
    holds its message (None elsewhere).
    """

    def __init__(self, columns: Mapping[str, Any], shape: tuple[int, ...]):
        self.shape = tuple(shape)
        self.labels: list[str] = list(columns["labels"])
        channels = columns["reflectance"].shape[1]
        self.channels = channels

        def fit(a: np.ndarray) -> np.ndarray:
            tail = a.shape[1:]
            if channels == 1:
                tail = tail[1:]
            return a.reshape(self.shape + tail)

        def fit_all(d: Mapping[str, np.ndarray] | None) -> dict[str, np.ndarray] | None:
            return None if d is None else {key: fit(v) for key, v in d.items()}

        self.reflectance: np.ndarray = fit(columns["reflectance"])
        self.reflectance_specular: np.ndarray = fit(columns["reflectance_specular"])
        self.transmittance: np.ndarray = fit(columns["transmittance"])
        self.transmittance_direct: np.ndarray = fit(columns["transmittance_direct"])
        self.absorptance: np.ndarray = fit(columns["absorptance"])
        self.brdf: np.ndarray = fit(columns["brdf"])
        self.btdf: np.ndarray = fit(columns["btdf"])
        self.stderr: dict[str, np.ndarray] | None = fit_all(columns["stderr"])
        self.error_estimate: dict[str, np.ndarray] | None = fit_all(columns["error_estimate"])
        self.errors: np.ndarray = np.array(columns["errors"], dtype=object).reshape(self.shape)

    def to_dict(self) -> dict[str, Any]:
        """The arrays by name."""
        out: dict[str, Any] = {k: getattr(self, k) for k in _SCALARS}
        out.update(brdf=self.brdf, btdf=self.btdf, stderr=self.stderr,
                   error_estimate=self.error_estimate, errors=self.errors, labels=self.labels)
        return out

    def __repr__(self) -> str:
        return f"km.Batch(shape={self.shape}, channels={self.channels})"


def solve_many(
    scenes: Scene | Iterable[Scene],
    method: str = "multiflux",
    *,
    params: Mapping[str, Any] | None = None,
    threads: int | None = None,
    errors: str = "raise",
    **options: Any,
) -> Batch:
    """Solve many scenes, or a parameter sweep of one, in parallel on all cores.

    ``solve_many([s1, s2, ...], method)`` solves each scene (all of one shape:
    the same number of channels and output directions).

    ``solve_many(scene, method, params={"layer[1].thickness": d, "layer[1].g": g})``
    sweeps the scene: the arrays of ``params`` are broadcast together (numpy
    rules) and every point is the scene with those values (keys:
    ``layer[i].sigma_a|sigma_s|thickness|tau|albedo|g|n`` with ``i`` from 1,
    ``light.theta_deg``, ``ambient.n``, ``substrate.n``, ``substrate.albedo``).

    Points run on ``threads`` workers (default: all cores) with the GIL
    released; each point's answer equals that of :func:`solve` with the same
    options (``streams``, ``order``, ``samples``, ``seed``, ``tolerance``,
    ``analog``, ``all_effects``), whatever the thread count. ``errors="raise"``
    raises :class:`KmError` for the first failed point; ``errors="nan"`` fills
    it with NaN and records its message in ``Batch.errors``.
    """
    if params is not None:
        if not isinstance(scenes, Scene):
            raise KmError("solve_many: params= sweeps one scene; pass a single Scene")
        if not params:
            raise KmError("solve_many: params= needs at least one key")
        keys = list(params)
        arrays = np.broadcast_arrays(*[np.asarray(params[k], dtype=np.float64) for k in keys])
        shape = arrays[0].shape
        values = np.ascontiguousarray(np.stack([a.ravel() for a in arrays], axis=1))
        cols = _km._solve_sweep(scenes, keys, values, method, threads=threads, errors=errors,
                                **options)
        return Batch(cols, shape)
    if isinstance(scenes, Scene):
        scenes = [scenes]
    scenes = list(scenes)
    cols = _km._solve_scenes(scenes, method, threads=threads, errors=errors, **options)
    return Batch(cols, (len(scenes),))


def _integers_named(f: Any) -> Any:
    """``f`` with an integer argument out of range (negative, or beyond
    2^64 - 1 where a count is asked; beyond a float's range for a float) a
    :class:`KmError` naming the argument, not a bare ``OverflowError``."""
    import functools

    @functools.wraps(f)
    def checked(*args: Any, **kwargs: Any) -> Any:
        try:
            return f(*args, **kwargs)
        except OverflowError as e:
            bad = [k for k, v in kwargs.items()
                   if isinstance(v, int) and not isinstance(v, bool)
                   and not (0 <= v < 2**64)]
            what = ", ".join(bad) if bad else "an integer argument (or an integer scene value)"
            raise KmError(
                f"{what}: out of range ({e}); counts and seeds are whole numbers in "
                f"[0, 2^64), and a value given as an integer must fit a float"
            ) from None

    return checked


solve = _integers_named(solve)
run_shard = _integers_named(run_shard)
fit_file = _integers_named(fit_file)
solve_many = _integers_named(solve_many)
bsdf = _integers_named(bsdf)
fit = _integers_named(fit)
