"""Solving: :func:`km.solve`, :func:`km.solve_many` (:class:`km.Batch`),
Monte Carlo shards (:func:`km.run_shard`, :func:`km.merge`), the light field
(:func:`km.field`) and :func:`km.layer`.

The keyword arguments that set a solve are the rows of the one table of
settings of the library (``km::settings::SETTINGS``), which the ``km solve``
flags follow too; their documentation below is written from that table
(:func:`settings_doc`) so that it cannot drift from it.
"""

from __future__ import annotations

import functools
import inspect
import textwrap
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Literal, TypeVar

import numpy as np
import numpy.typing as npt

from . import _km
from ._errors import KmError
from ._km import Partial, Scene, Solution
from ._repr import batch_html


def _param_values(key: str, v: Any) -> npt.NDArray[np.float64]:
    """The values of one ``params`` key as floats; an integer beyond the
    largest float (``10**400``) is refused naming the key."""
    try:
        return np.asarray(v, dtype=np.float64)
    except OverflowError:
        raise KmError(f"params: {key}: an integer beyond the largest float (1.8e308)") from None


Method = Literal["km", "multiflux", "mc", "dipole", "direction-set"]
F = TypeVar("F", bound=Callable[..., Any])


def _integers_named(f: F) -> F:
    """``f`` with an integer argument out of range (negative, or beyond
    2^64 - 1 where a count is asked; beyond a float's range for a float) a
    :class:`KmError` naming the argument, not a bare ``OverflowError``."""

    try:
        signature: inspect.Signature | None = inspect.signature(f)
    except (TypeError, ValueError):
        signature = None

    def arguments(args: tuple[Any, ...], kwargs: dict[str, Any]) -> dict[str, Any]:
        """The call's arguments by name, positional ones included."""
        if signature is None:
            return kwargs
        try:
            bound = signature.bind_partial(*args, **kwargs).arguments
        except TypeError:
            return kwargs
        named: dict[str, Any] = {}
        for name, value in bound.items():
            kind = signature.parameters[name].kind
            if kind is inspect.Parameter.VAR_KEYWORD:
                named.update(value)
            elif kind is not inspect.Parameter.VAR_POSITIONAL:
                named[name] = value
        return named

    @functools.wraps(f)
    def checked(*args: Any, **kwargs: Any) -> Any:
        try:
            return f(*args, **kwargs)
        except OverflowError as e:
            bad = [k for k, v in arguments(args, kwargs).items()
                   if isinstance(v, int) and not isinstance(v, bool)
                   and not (0 <= v < 2**64)]
            what = ", ".join(bad) if bad else "an integer argument (or an integer scene value)"
            raise KmError(
                f"{what}: out of range ({e}); counts and seeds are whole numbers in "
                f"[0, 2^64), and a value given as an integer must fit a float"
            ) from None

    return checked  # type: ignore[return-value]


def settings_doc(exclude: Sequence[str] = ("shard",)) -> str:
    """The numpydoc entries of the solve settings, one per row of
    ``km::settings::SETTINGS`` (name, type, methods, range, default, help),
    leaving out the settings in ``exclude`` (and exclusions of them)."""
    table = _km._settings()
    every = {m for s in table for m in s["methods"]}
    out = []
    for s in table:
        if s["name"] in exclude:
            continue
        kind = s["kind"]
        if kind == "flag":
            typ = "bool, default False"
        elif kind == "count":
            typ = "int, optional"
        elif kind == "real":
            typ = "float, optional"
        else:
            typ = "{" + ", ".join(f'"{c}"' for c in s["choices"]) + "}, optional"
        rng = ""
        if kind == "count":
            hi = s["max"]
            rng = f" Range {int(s['min'])} to {int(hi) if hi < 2**63 else '2^64 - 1'}."
        elif kind == "real":
            rng = f" Range > {s['min']:g} and <= {s['max']:g}."
        if kind == "flag":
            default = ""
        elif s["default"] is None:
            default = " Default: not given (the method chooses)."
        else:
            default = f" Default ``{s['default']}``."
        methods = "all methods" if set(s["methods"]) == every else ", ".join(s["methods"])
        others = [c for c in s["conflicts"] if c not in exclude]
        conflicts = " Excludes " + ", ".join(f"``{c}``" for c in others) + "." if others else ""
        help_ = s["help"][0].upper() + s["help"][1:]
        text = f"[{methods}] {help_}.{rng}{default}{conflicts}"
        body = textwrap.fill(text, width=76, initial_indent="    ", subsequent_indent="    ")
        out.append(f"{s['name']} : {typ}\n{body}")
    return "\n".join(out)


def _given(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The settings actually given: ``None`` and a flag left ``False`` are not."""
    return {k: v for k, v in settings.items() if v is not None and v is not False}


def solve(
    scene: Scene,
    method: Method = "multiflux",
    *,
    tolerance: float | None = None,
    all_effects: bool = False,
    km_mapping: Literal["seed", "star1988", "gate1974"] | None = None,
    km_model: Literal["four-flux", "two-flux"] | None = None,
    cone: float | None = None,
    streams: int | None = None,
    order: int | None = None,
    fourier_tol: float | None = None,
    directions: int | None = None,
    samples: int | None = None,
    seed: int | None = None,
    threads: int | None = None,
    estimator: Literal["survival", "analog"] | None = None,
    budget: float | None = None,
    repeat: int | None = None,
    fdr: Literal["exact", "egan-hilgeman"] | None = None,
    dipole: Literal["jensen2001", "better"] | None = None,
    analog: bool = False,
) -> Solution:
    return _km._solve(scene, method, **_given(dict(
        tolerance=tolerance, all_effects=all_effects, km_mapping=km_mapping, km_model=km_model,
        cone=cone, streams=streams, order=order, fourier_tol=fourier_tol, directions=directions,
        samples=samples, seed=seed, threads=threads, estimator=estimator, budget=budget,
        repeat=repeat, fdr=fdr, dipole=dipole, analog=analog)))


solve.__doc__ = f"""Solve a scene, as ``km solve SCENE --method METHOD --json`` does.

The settings are the flags of ``km solve`` of the same names (``_`` for
``-``), read against the same table with the same messages: a setting the
method does not read, a value out of range, or two settings that exclude
each other (``streams`` and ``tolerance``) are refused, never ignored.
``None`` (the default of each) means "not given": the method's own default.
The GIL is released while the solver runs.

Parameters
----------
scene : Scene
    The scene to solve.
method : {{"multiflux", "km", "mc", "dipole", "direction-set"}}, default "multiflux"
    Multi-flux discrete ordinates, two-flux (four-flux) Kubelka-Munk,
    Monte Carlo, the diffusion dipole, or the seed's direction set.
{settings_doc()}
analog : bool, default False
    [mc] The older spelling of ``estimator="analog"``.

Returns
-------
Solution
    Totals (floats for one channel, arrays over channels otherwise),
    ``brdf``/``btdf`` at the scene's directions, uncertainties and the plan;
    ``to_dict()`` is the ``km solve --json`` object.

Raises
------
KmError
    A setting refused (``key`` names it), or a scene the method cannot treat.
KmTypeError
    A setting of the wrong type (``streams="8"``).

Examples
--------
>>> import km
>>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)])
>>> sol = km.solve(scene, "multiflux", streams=16)
>>> round(sol.reflectance + sol.transmittance + sol.absorptance, 9)
1.0
>>> km.solve(scene, "km", km_mapping="seed").method
'km'
"""


class Batch:
    """The answers of :func:`solve_many` as numpy arrays.

    For ``P`` points (the shape of the sweep, or ``(len(scenes),)``), ``C``
    channels and ``D`` output directions: each total has shape ``P`` for one
    channel and ``P + (C,)`` otherwise; ``brdf`` and ``btdf`` have shape
    ``P + (D,)`` or ``P + (C, D)``. With ``errors="nan"`` a failed point is
    NaN and ``errors`` holds its message (None elsewhere).

    Parameters
    ----------
    columns : mapping
        The flat columns of the extension (``km._km._solve_scenes``).
    shape : tuple of int
        The shape ``P`` of the points.

    Attributes
    ----------
    shape : tuple of int
        The shape of the points.
    channels : int
        Number of spectral channels ``C``.
    labels : list of str
        Channel labels.
    reflectance, reflectance_specular, transmittance, transmittance_direct, absorptance : ndarray
        The totals and their delta parts.
    brdf, btdf : ndarray
        Smooth BRDF/BTDF (1/sr) at the scene's directions.
    stderr, error_estimate : dict of ndarray or None
        Standard errors (Monte Carlo) and estimated errors (a tolerance), by key.
    errors : ndarray of object
        Per point, the message of its failure or None.

    Examples
    --------
    >>> import km, numpy as np
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
    >>> b = km.solve_many(scene, "km", params={"layer[1].tau": np.linspace(0.5, 2, 4)})
    >>> b.shape, b.reflectance.shape
    ((4,), (4,))
    """

    def __init__(self, columns: Mapping[str, Any], shape: tuple[int, ...]):
        self.shape = tuple(shape)
        self.labels: list[str] = list(columns["labels"])
        channels = int(columns["reflectance"].shape[1])
        self.channels = channels

        def fit(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
            tail = a.shape[1:]
            if channels == 1:
                tail = tail[1:]
            return a.reshape(self.shape + tail)

        def fit_all(d: Mapping[str, npt.NDArray[Any]] | None) -> dict[str, npt.NDArray[Any]] | None:
            return None if d is None else {key: fit(v) for key, v in d.items()}

        self.reflectance: npt.NDArray[np.float64] = fit(columns["reflectance"])
        self.reflectance_specular: npt.NDArray[np.float64] = fit(columns["reflectance_specular"])
        self.transmittance: npt.NDArray[np.float64] = fit(columns["transmittance"])
        self.transmittance_direct: npt.NDArray[np.float64] = fit(columns["transmittance_direct"])
        self.absorptance: npt.NDArray[np.float64] = fit(columns["absorptance"])
        self.brdf: npt.NDArray[np.float64] = fit(columns["brdf"])
        self.btdf: npt.NDArray[np.float64] = fit(columns["btdf"])
        self.stderr = fit_all(columns["stderr"])
        self.error_estimate = fit_all(columns["error_estimate"])
        self.errors: npt.NDArray[Any] = np.array(columns["errors"], dtype=object).reshape(
            self.shape)

    def to_dict(self) -> dict[str, Any]:
        """The arrays by name.

        Returns
        -------
        dict
            ``reflectance``, ``reflectance_specular``, ``transmittance``,
            ``transmittance_direct``, ``absorptance``, ``brdf``, ``btdf``,
            ``stderr``, ``error_estimate``, ``errors`` and ``labels``.
        """
        out: dict[str, Any] = {k: getattr(self, k) for k in _SCALARS}
        out.update(brdf=self.brdf, btdf=self.btdf, stderr=self.stderr,
                   error_estimate=self.error_estimate, errors=self.errors, labels=self.labels)
        return out

    def __repr__(self) -> str:
        return f"km.Batch(shape={self.shape}, channels={self.channels})"

    def _repr_html_(self) -> str:
        return batch_html(self)


_SCALARS = ("reflectance", "reflectance_specular", "transmittance", "transmittance_direct",
            "absorptance")


def solve_many(
    scenes: Scene | Iterable[Scene],
    method: Method = "multiflux",
    *,
    params: Mapping[str, Any] | None = None,
    errors: Literal["raise", "nan"] = "raise",
    tolerance: float | None = None,
    all_effects: bool = False,
    km_mapping: Literal["seed", "star1988", "gate1974"] | None = None,
    km_model: Literal["four-flux", "two-flux"] | None = None,
    cone: float | None = None,
    streams: int | None = None,
    order: int | None = None,
    fourier_tol: float | None = None,
    directions: int | None = None,
    samples: int | None = None,
    seed: int | None = None,
    threads: int | None = None,
    estimator: Literal["survival", "analog"] | None = None,
    budget: float | None = None,
    repeat: int | None = None,
    fdr: Literal["exact", "egan-hilgeman"] | None = None,
    dipole: Literal["jensen2001", "better"] | None = None,
    analog: bool = False,
) -> Batch:
    options = _given(dict(
        tolerance=tolerance, all_effects=all_effects, km_mapping=km_mapping, km_model=km_model,
        cone=cone, streams=streams, order=order, fourier_tol=fourier_tol, directions=directions,
        samples=samples, seed=seed, threads=threads, estimator=estimator, budget=budget,
        repeat=repeat, fdr=fdr, dipole=dipole, analog=analog))
    if params is not None:
        if not isinstance(scenes, Scene):
            raise KmError("solve_many: params= sweeps one scene; pass a single Scene")
        if not params:
            raise KmError("solve_many: params= needs at least one key")
        keys = list(params)
        arrays = np.broadcast_arrays(*[_param_values(k, params[k]) for k in keys])
        shape = arrays[0].shape
        values = np.ascontiguousarray(np.stack([a.ravel() for a in arrays], axis=1))
        cols = _km._solve_sweep(scenes, keys, values, method, errors=errors, **options)
        return Batch(cols, shape)
    listed = [scenes] if isinstance(scenes, Scene) else list(scenes)
    cols = _km._solve_scenes(listed, method, errors=errors, **options)
    return Batch(cols, (len(listed),))


solve_many.__doc__ = f"""Solve many scenes, or a parameter sweep of one, in parallel on all cores.

``solve_many([s1, s2, ...], method)`` solves each scene (all of one shape:
the same number of channels and output directions).
``solve_many(scene, method, params={{"layer[1].thickness": d}})`` sweeps
the scene: the arrays of ``params`` are broadcast together (numpy rules) and
every point is the scene with those values. Each point's answer equals that
of :func:`solve` with the same settings, whatever the thread count.

Parameters
----------
scenes : Scene or iterable of Scene
    The scenes, or the one scene a sweep varies.
method : {{"multiflux", "km", "mc", "dipole", "direction-set"}}, default "multiflux"
    As for :func:`solve`.
params : mapping of str to array_like, optional
    Sweep keys (``layer[i].sigma_a|sigma_s|thickness|tau|albedo|g|n|roughness``
    with ``i`` from 1, ``light.theta_deg``, ``ambient.n``,
    ``substrate.n|k|albedo|roughness``; the grammar of ``km sweep``) to
    arrays of values, broadcast together.
errors : {{"raise", "nan"}}, default "raise"
    ``"raise"``: the first failed point raises its error (``point 17: ...``);
    ``"nan"``: a failed point is NaN and its message is in ``Batch.errors``.
{settings_doc()}
    In a batch, ``threads`` is the number of workers over the points (each
    Monte Carlo point runs on one thread).
analog : bool, default False
    [mc] The older spelling of ``estimator="analog"``.

Returns
-------
Batch
    The answers as numpy arrays of the points' shape.

Raises
------
KmError
    A setting refused, a key that is not a sweep key, too many points for
    one call, or (``errors="raise"``) the first failed point.
KmTypeError
    A setting of the wrong type.

Examples
--------
>>> import km, numpy as np
>>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
>>> d = np.geomspace(0.1, 10, 5)
>>> g = np.array([0.0, 0.5])[:, None]
>>> b = km.solve_many(scene, params={{"layer[1].tau": d, "layer[1].g": g}})
>>> b.shape
(2, 5)
"""


def run_shard(
    scene: Scene,
    index: int,
    count: int,
    *,
    samples: int | None = None,
    seed: int | None = None,
    threads: int | None = None,
    analog: bool = False,
    all_effects: bool = False,
) -> Partial:
    """Trace shard ``index`` of ``count`` of one Monte Carlo run.

    The shards of a run are its fixed batches of photons dealt out; each
    shard's :class:`Partial` pickles exactly, and :func:`merge` combines all
    ``count`` of them into the single-run result, bit for bit
    (``km solve --shard I/N`` writes the same parts).

    Parameters
    ----------
    scene : Scene
        The scene.
    index : int
        This shard, ``0 <= index < count``.
    count : int
        Number of shards of the run.
    samples : int, optional
        Photons of the whole run per channel (default 10^6).
    seed : int, optional
        Seed of the run (default 1).
    threads : int, optional
        Worker threads of this shard (default all cores); never changes the result.
    analog : bool, default False
        Analog absorption instead of survival biasing.
    all_effects : bool, default False
        The planner off.

    Returns
    -------
    Partial
        The shard's partial tally.

    Raises
    ------
    KmError
        ``index >= count``, zero samples, a scene Monte Carlo cannot treat.

    Examples
    --------
    >>> import km
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
    >>> parts = [km.run_shard(scene, i, 2, samples=2000, seed=3) for i in range(2)]
    >>> km.merge(parts).reflectance == km.solve(scene, "mc", samples=2000, seed=3).reflectance
    True
    """
    return _km.run_shard(scene, index, count, samples=samples, seed=seed, threads=threads,
                         analog=analog, all_effects=all_effects)


def merge(parts: Sequence[Partial]) -> Solution:
    """Merge all shards of one Monte Carlo run into its single-run result.

    Parameters
    ----------
    parts : sequence of Partial
        Every shard of the run once, in any order.

    Returns
    -------
    Solution
        Bit for bit the result of the run in one call (``seconds`` is the
        sum of the shards' tracing times).

    Raises
    ------
    KmError
        Parts of different runs, a shard missing or given twice.

    Examples
    --------
    >>> import km
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
    >>> sol = km.merge([km.run_shard(scene, i, 3, samples=3000) for i in range(3)])
    >>> sol.method
    'mc'
    """
    return _km.merge(list(parts))


def field(
    scene: Scene,
    method: Literal["multiflux", "km", "mc", "dipole"] = "multiflux",
    *,
    depths: Sequence[float] | npt.ArrayLike | None = None,
    streams: int | None = None,
    samples: int | None = None,
    seed: int | None = None,
    dz: float | None = None,
    fdr: Literal["exact", "egan-hilgeman"] | None = None,
    dipole: Literal["jensen2001", "better"] | None = None,
    directions: Sequence[Sequence[float]] | npt.ArrayLike | None = None,
    mc_cone: float | None = None,
) -> dict[str, Any]:
    """The light field inside the stack, as ``km field SCENE --json`` (docs/field.md).

    Parameters
    ----------
    scene : Scene
        The scene.
    method : {"multiflux", "km", "mc", "dipole"}, default "multiflux"
        The dipole gives the diffusion field of its half-space (docs/diffusion.md
        eq. D24-D27); the direction set has no field (refused with the reason).
    depths : array_like, optional
        Depths (length unit of the scene, from the top) instead of the
        scene's ``[output] depths``.
    streams : int, optional
        [multiflux] Gauss nodes per hemisphere.
    samples : int, optional
        [mc] Photons (default 10^5).
    seed : int, optional
        [mc] Seed (default 1).
    dz : float, optional
        [mc] Width of the depth bins.
    fdr : {"exact", "egan-hilgeman"}, optional
        [dipole] How ``F_dr`` is computed (default "exact"), as ``km.solve``.
    dipole : {"jensen2001", "better"}, optional
        [dipole] Which dipole (default "jensen2001"), as ``km.solve``.
    directions : array_like of shape (J, 2), optional
        [multiflux, mc] Directions ``[theta, phi]`` in degrees of the
        radiance inside (theta from the downward normal, < 90 down-going,
        > 90 up-going, not 90; phi = 180 the side the beam travels to),
        instead of the scene's ``[output] inside_directions_deg``.
    mc_cone : float, optional
        [mc] Half-angle in degrees of the cone over which the radiance
        inside is averaged (default 5; docs/field.md §4a).

    Returns
    -------
    dict
        ``depths`` (D,), ``fluence``, ``absorbed`` (per unit depth) and
        ``net_flux`` (C x D, per unit incident irradiance),
        ``absorptance_layers`` (C x L), ``stderr`` (Monte Carlo: a dict of
        the same three arrays, else None), ``method``, ``labels``, ``seconds``;
        with directions, ``radiance``: a dict of ``directions`` (J x 2),
        ``values`` (C x D x J, 1/sr per unit incident irradiance, the
        collimated beams apart), ``stderr`` (Monte Carlo, else None),
        ``beam_down``, ``beam_up`` (C x D, multiflux, else None) and
        ``cone_half_angle_deg`` (J, Monte Carlo, else None).

    Raises
    ------
    KmError
        A method without a field, a depth outside the stack, an option the
        method does not read.

    Examples
    --------
    >>> import km
    >>> s = km.Scene(layers=[km.layer(sigma_a=0.3, sigma_s=3.0, thickness=1.0)])
    >>> f = km.field(s, depths=[0.0, 0.5, 1.0])
    >>> f["fluence"].shape
    (1, 3)
    """
    d = None if depths is None else [float(x) for x in np.asarray(depths, dtype=float).ravel()]
    dirs = None
    if directions is not None:
        a = np.asarray(directions, dtype=float)
        if a.ndim != 2 or a.shape[1] != 2:
            raise ValueError(f"directions: expected pairs [theta, phi], got shape {a.shape}")
        dirs = [[float(t), float(p)] for t, p in a]
    out: dict[str, Any] = _km.field(scene, method, depths=d, streams=streams, samples=samples,
                                    seed=seed, dz=dz, fdr=fdr, dipole=dipole, directions=dirs,
                                    mc_cone=mc_cone)
    return out


def profile(
    scene: Scene,
    method: Literal["dipole", "mc"] = "dipole",
    *,
    r_max: float | None = None,
    points: int = 20,
    samples: int = 1000000,
    seed: int = 1,
    depths: Sequence[float] | npt.ArrayLike | None = None,
) -> dict[str, Any]:
    """The radial profile of a pencil beam, as ``km profile SCENE --json``.

    The diffuse reflectance ``Rd(r)`` at distance ``r`` from a pencil beam
    entering the top of the stack (docs/diffusion.md), by the diffusion
    dipole or by Monte Carlo; with ``depths``, also the dipole's fluence
    rate ``phi(r, z)`` inside its half-space (docs/diffusion.md eq. D24-D27,
    docs/field.md).

    Parameters
    ----------
    scene : Scene
        The scene (the dipole needs a half-space; Monte Carlo any stack).
    method : {"dipole", "mc"}, default "dipole"
        The dipole's closed form (normal incidence only) or Monte Carlo
        (oblique incidence honoured).
    r_max : float, optional
        The largest radius (length unit of the scene); default: a radius
        that holds nearly all of ``Rd``.
    points : int, default 20
        Radii (annuli for Monte Carlo) from 0 to ``r_max``.
    samples : int, default 10**6
        [mc] Photons.
    seed : int, default 1
        [mc] Seed.
    depths : array_like, optional
        [dipole] Depths (from the top) at which ``phi(r, z)`` is given.

    Returns
    -------
    dict
        ``r`` (N,), ``rd`` (C x N, 1/length^2 per unit power entering),
        ``stderr`` (C x N for Monte Carlo, else None), ``depths`` (D,),
        ``fluence`` (C x D x N: the dipole's ``phi(r, z)``, diffuse light
        only; None without ``depths``), ``method``, ``labels``.

    Raises
    ------
    KmError
        A scene the method cannot treat (the dipole: a finite stack or
        oblique light), ``depths`` with Monte Carlo, more than 10^7 values.

    Examples
    --------
    >>> import km
    >>> s = km.Scene(layers=[km.layer(sigma_a=0.01, sigma_s=1.0, thickness="inf")])
    >>> p = km.profile(s, points=5, depths=[1.0, 2.0])
    >>> p["rd"].shape, p["fluence"].shape
    ((1, 5), (1, 2, 5))
    """
    d = None if depths is None else [float(x) for x in np.asarray(depths, dtype=float).ravel()]
    out: dict[str, Any] = _km.profile(scene, method, r_max=r_max, points=points,
                                      samples=samples, seed=seed, depths=d)
    return out


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

    Give ``sigma_a``, ``sigma_s`` and ``thickness``, or ``tau`` and
    ``albedo``. Each value may be a number, a sequence or a numpy array
    (one value per spectral channel). The keys are checked when the
    :class:`Scene` is built, with the scene file's messages.

    Parameters
    ----------
    sigma_a : float or array_like, optional
        Absorption coefficient, 1/length, >= 0.
    sigma_s : float or array_like, optional
        Scattering coefficient, 1/length, >= 0.
    thickness : float or array_like, optional
        Thickness (length), or ``float("inf")`` for a half-space.
    tau : float or array_like, optional
        Optical thickness, >= 0.
    albedo : float or array_like, optional
        Single-scattering albedo in [0, 1].
    g : float or array_like, optional
        Henyey-Greenstein asymmetry in (-1, 1), default 0.
    n : float or array_like, optional
        Refractive index, default that of the ambient medium.
    preset : str, optional
        A named material of the scene file (docs/scene-file.md).

    Returns
    -------
    dict
        The keys given (None left out).

    Raises
    ------
    KmError
        Never here; :class:`Scene` checks the keys.

    Examples
    --------
    >>> import km
    >>> km.layer(tau=1.0, albedo=0.9, g=0.5)
    {'tau': 1.0, 'albedo': 0.9, 'g': 0.5}
    """
    keys = dict(
        sigma_a=sigma_a, sigma_s=sigma_s, thickness=thickness, tau=tau, albedo=albedo, g=g, n=n,
        preset=preset,
    )
    return {k: v for k, v in keys.items() if v is not None}


run_shard = _integers_named(run_shard)
