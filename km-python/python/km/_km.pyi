"""Type stubs of the extension module km._km (the Rust side of the package km)."""

from __future__ import annotations

from os import PathLike
from typing import Any, Literal, Mapping, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = ["KmError", "Scene", "Solution", "Partial", "_BsdfCore", "FitResult", "_fit",
           "_fit_many", "fit_file", "fit_km", "colour", "delta_e2000", "srgb", "_solve",
           "_solve_scenes", "_solve_sweep", "run_shard", "merge", "field", "profile",
           "_phase", "_mie", "_settings", "__version__"]

_Method = Literal["km", "multiflux", "mc", "dipole", "direction-set"]
_FloatOrArray = float | npt.NDArray[np.float64]

class KmError(ValueError):
    """Bad input: a scene, an option, or a scene the method cannot treat.

    ``km.KmTypeError`` (also a ``TypeError``) and ``km.KmFileNotFoundError``
    (also a ``FileNotFoundError``) are its subclasses (km/_errors.py).

    ``str(err)`` is the message of the ``km`` command (``line 3:
    `layer[1].albedo`: 1.5: albedo must lie in [0, 1]``).
    """

    key: str | None
    """The scene key or option named (``layer[1].albedo``, ``streams``), or None."""
    line: int | None
    """1-based line of the scene text, or None (scenes from keyword arguments)."""

@final
class Scene:
    """A validated scene: a stack of layers, its light, ambient medium,
    substrate, output directions, and one or more spectral channels.

    Immutable, comparable with ``==`` and picklable.
    """

    def __new__(
        cls,
        layers: Sequence[Mapping[str, Any]],
        *,
        light: str | Mapping[str, Any] | None = None,
        theta_deg: float | None = None,
        ambient_n: float | Sequence[float] | None = None,
        substrate: str | Mapping[str, Any] | None = None,
        directions_deg: Sequence[Sequence[float]] | npt.ArrayLike | None = None,
        spectrum: Mapping[str, Any] | None = None,
    ) -> Scene:
        """A scene from keyword arguments: the keys of the scene file.

        ``layers``: top first, each a mapping of ``[[layer]]`` keys (see
        :func:`km.layer`); ``light``: ``"collimated"`` (default) or
        ``"diffuse"``, or a mapping of ``[light]``; ``theta_deg``: polar angle
        of a collimated beam; ``ambient_n``: index above the stack;
        ``substrate``: ``"transparent"``, ``"lambertian"`` or ``"black"``, or a
        mapping of ``[substrate]`` (``{"kind": "lambertian", "albedo": 0.8}``);
        ``directions_deg``: ``[[theta, phi], ...]`` exit directions of the
        BRDF/BTDF samples; ``spectrum``: ``{"labels": [...], "wavelengths_nm": [...]}``.

        Raises :class:`KmError` naming the key, as the scene file does.
        """
    @staticmethod
    def from_toml(text: str) -> Scene:
        """A scene from the text of a scene file (docs/scene-file.md)."""
    @staticmethod
    def from_file(path: str | PathLike[str]) -> Scene:
        """A scene from a scene file on disk."""
    def to_toml(self) -> str:
        """The scene as the text of a scene file (``km check`` and ``km solve`` read it)."""
    @property
    def channels(self) -> int:
        """Number of spectral channels."""
    @property
    def labels(self) -> list[str]:
        """Channel labels."""
    @property
    def wavelengths_nm(self) -> list[float] | None:
        """Wavelengths (nm) when the scene gives them."""
    def layers(self, channel: int = 0) -> list[dict[str, float]]:
        """The layers of one channel, top first: sigma_a, sigma_s, sigma_t,
        thickness, tau, albedo, g, n."""
    @property
    def light(self) -> dict[str, Any]:
        """``{"kind": "collimated", "theta_deg": ...}`` or ``{"kind": "diffuse"}``."""
    @property
    def substrate(self) -> dict[str, Any]:
        """``{"kind": ..., "n" | "albedo": ...}`` of channel 0."""
    @property
    def directions_deg(self) -> list[tuple[float, float]]:
        """Exit directions ``[theta_deg, phi_deg]`` of the BRDF/BTDF samples."""
    def __eq__(self, other: object, /) -> bool: ...

@final
class Solution:
    """What a solve returns.

    For a one-channel scene the totals are floats and ``brdf``/``btdf``
    1-D arrays over the output directions; for ``C`` channels each total is
    an array of shape ``(C,)`` and ``brdf``/``btdf`` have shape ``(C, D)``.
    ``to_dict()`` is the ``km solve --json`` object.
    """

    @property
    def method(self) -> str: ...
    @property
    def channels(self) -> int: ...
    @property
    def labels(self) -> list[str]: ...
    @property
    def reflectance(self) -> _FloatOrArray:
        """Total reflectance (specular part included)."""
    @property
    def reflectance_specular(self) -> _FloatOrArray:
        """The mirror (delta) part of the reflectance."""
    @property
    def transmittance(self) -> _FloatOrArray:
        """Total transmittance (unscattered part included)."""
    @property
    def transmittance_direct(self) -> _FloatOrArray:
        """The unscattered (delta) part of the transmittance."""
    @property
    def absorptance(self) -> _FloatOrArray:
        """Absorbed fraction."""
    @property
    def brdf(self) -> npt.NDArray[np.float64]:
        """Smooth BRDF (1/sr) at the scene's output directions."""
    @property
    def btdf(self) -> npt.NDArray[np.float64]:
        """Smooth BTDF (1/sr) at the scene's output directions."""
    @property
    def absorptance_layers(self) -> npt.NDArray[np.float64] | None:
        """Absorbed fraction per layer, top first, when the method gives it."""
    @property
    def field(self) -> dict[str, Any] | None:
        """The field at the scene's ``[output] depths``, as ``km.field`` gives it (with
        ``radiance`` for ``[output] inside_directions_deg``, multiflux and mc), or None."""
    @property
    def stderr(self) -> dict[str, _FloatOrArray] | None:
        """Standard errors by key (Monte Carlo), or None."""
    @property
    def error_estimate(self) -> dict[str, _FloatOrArray] | None:
        """Estimated errors by key (an accuracy target was given), or None."""
    @property
    def model_error_estimate(self) -> dict[str, _FloatOrArray] | None:
        """How far a closed form (km, dipole) may be off, by key (eq. K25), or None."""
    @property
    def notes(self) -> list[str]:
        """What the solver simplified, with bounds of what it neglected."""
    @property
    def plan(self) -> dict[str, Any] | None:
        """The plan obeyed: effects present, work skipped and why."""
    @property
    def seconds(self) -> float:
        """The solver's own wall time, seconds."""
    @property
    def accuracy(self) -> dict[str, Any] | None:
        """How an accuracy target was met, or None."""
    @property
    def directions_deg(self) -> list[list[float]]:
        """The output directions ``[theta_deg, phi_deg]`` of ``brdf``/``btdf``."""
    @property
    def extra(self) -> dict[str, Any]:
        """Method settings and diagnostics."""
    def _repr_html_(self) -> str: ...
    def to_dict(self) -> dict[str, Any]:
        """The ``km solve --json`` object (there ``channels``, for several
        channels, is the list of labels; the attribute is their number)."""
    def to_json(self, indent: bool = False) -> str:
        """The ``km solve --json`` object as text."""

@final
class Partial:
    """The partial tally of one Monte Carlo shard; picklable, exact."""

    @staticmethod
    def from_json(text: str) -> Partial:
        """A part from its JSON text (the ``km solve --shard --out`` file)."""
    def to_json(self) -> str:
        """The part as the ``km solve --shard --out`` file (``km merge`` reads it)."""
    @property
    def index(self) -> int: ...
    @property
    def count(self) -> int: ...
    @property
    def samples(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def seconds(self) -> float: ...

def _solve(scene: Scene, method: str = ..., **settings: Any) -> Solution:
    """The extension's solve: ``km.solve`` (km/_solve.py) documents the settings."""

def _settings() -> list[dict[str, Any]]:
    """The table ``km::settings::SETTINGS``: per setting ``name``, ``methods``,
    ``kind``, ``min``, ``max``, ``choices``, ``default``, ``conflicts``, ``help``."""

def field(
    scene: Scene,
    method: _Method = "multiflux",
    *,
    depths: Sequence[float] | None = None,
    streams: int | None = None,
    samples: int | None = None,
    seed: int | None = None,
    dz: float | None = None,
    fdr: str | None = None,
    dipole: str | None = None,
    directions: Sequence[Sequence[float]] | None = None,
    mc_cone: float | None = None,
) -> dict[str, Any]:
    """The light field inside the stack, as ``km field SCENE --json`` (docs/field.md).

    At the scene's ``[output] depths`` (or ``depths``): a dict of numpy
    arrays ``depths`` (D,), ``fluence``, ``absorbed``, ``net_flux`` (C x D,
    per unit incident irradiance; ``absorbed`` per unit depth),
    ``absorptance_layers`` (C x L), ``stderr`` (Monte Carlo: the same three
    keys), ``method``, ``labels``, ``seconds``. ``method`` is
    ``"multiflux"``, ``"km"``, ``"mc"`` or ``"dipole"`` (the diffusion
    field of a half-space, docs/diffusion.md eq. D24-D27; the direction set
    raises :class:`KmError` with the reason); ``streams`` [multiflux],
    ``samples`` (default 10^5), ``seed``, ``dz`` (bin width) [mc].
    With ``directions`` (``[theta, phi]`` degrees, theta from the downward
    normal; default the scene's ``[output] inside_directions_deg``) also
    ``radiance``: a dict of ``directions`` (J x 2), ``values`` (C x D x J,
    1/sr), ``stderr`` (Monte Carlo, else None), ``beam_down``, ``beam_up``
    (C x D, multiflux, else None), ``cone_half_angle_deg`` (J, Monte Carlo:
    ``mc_cone`` narrowed near the horizon, else None); multiflux and mc only.
    """

def profile(
    scene: Scene,
    method: Literal["dipole", "mc"] = "dipole",
    *,
    r_max: float | None = None,
    points: int = 20,
    samples: int = 1000000,
    seed: int = 1,
    depths: Sequence[float] | None = None,
) -> dict[str, Any]:
    """``Rd(r)`` of a pencil beam, as ``km profile SCENE --json`` (docs/diffusion.md).

    A dict: ``r`` (N,), ``rd`` (C x N, 1/length^2 per unit power entering),
    ``stderr`` (C x N, Monte Carlo; else None), ``depths`` (D,) and
    ``fluence`` (C x D x N: the dipole's ``phi(r, z)`` of the pencil beam,
    eq. D14, diffuse light only; None without ``depths``), ``method``,
    ``labels``. ``depths`` are for the dipole only.
    """

def _phase(
    scene: Scene,
    angles_deg: Sequence[float] | None = None,
    moments: int | None = None,
) -> dict[str, Any]:
    """The extension's phase report: ``km.phase`` (km/_phase.py) documents it."""

def _mie(
    radius_um: float,
    n: float,
    k: float,
    wavelength_nm: float,
    n_host: float = 1.0,
    angles_deg: Sequence[float] | None = None,
    moments: int | None = None,
) -> dict[str, Any]:
    """The extension's sphere by Mie theory: ``km.mie`` (km/_phase.py) documents it."""

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
    """Shard ``index`` of ``count`` of a Monte Carlo run of ``samples`` photons."""

def merge(parts: Sequence[Partial]) -> Solution:
    """Merge all shards of a run into exactly (bit for bit) the single-run result."""

def _solve_scenes(scenes: Sequence[Scene], method: str = ..., *, errors: str = ...,
                  **settings: Any) -> dict[str, Any]: ...
def _solve_sweep(scene: Scene, keys: Sequence[str], values: npt.NDArray[np.float64],
                 method: str = ..., *, errors: str = ..., **settings: Any) -> dict[str, Any]: ...

@final
class _BsdfCore:
    """The BSDF of a scene's stack; use :func:`km.bsdf` (km/_bsdf.py wraps it)."""
    def __new__(cls, scene: Scene, streams: int | None = None,
                max_fourier_order: int | None = None,
                fourier_tol: float | None = None) -> _BsdfCore: ...
    @property
    def streams(self) -> int: ...
    @property
    def max_fourier_order(self) -> int | None: ...
    @property
    def fourier_tol(self) -> float: ...
    @property
    def transmits(self) -> bool: ...
    @property
    def n_above(self) -> float: ...
    @property
    def n_below(self) -> float | None: ...
    @property
    def max_values(self) -> int: ...
    @property
    def channels(self) -> int: ...
    @property
    def labels(self) -> list[str]: ...
    @property
    def wavelengths_nm(self) -> list[float] | None: ...
    def scene_toml(self) -> str: ...
    def _eval(self, side: str, transmitted: bool, theta_i: npt.NDArray[np.float64],
              theta_o: npt.NDArray[np.float64],
              phi: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def _totals(self, side: str, theta_i: npt.NDArray[np.float64]) -> dict[str, Any]: ...
    def _table(self, side: str, theta_i: npt.NDArray[np.float64],
               theta_o: npt.NDArray[np.float64],
               phi: npt.NDArray[np.float64], exact: bool) -> dict[str, Any]: ...

@final
class FitResult:
    """The result of :func:`km.fit` (``to_dict()`` is the ``km fit --json`` object)."""
    @property
    def albedo(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def g(self) -> float: ...
    @property
    def mu_a(self) -> float: ...
    @property
    def mu_s(self) -> float: ...
    @property
    def mu_s_prime(self) -> float: ...
    @property
    def fitted(self) -> dict[str, float]: ...
    @property
    def residual(self) -> float: ...
    @property
    def status(self) -> str: ...
    @property
    def uncertainty(self) -> dict[str, Any]: ...
    @property
    def streams(self) -> int: ...
    @property
    def evaluations(self) -> int: ...
    @property
    def notes(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def _repr_html_(self) -> str: ...

def _fit(m_r: float, m_t: float, m_u: float | None = None, *, thickness: float,
         n_sample: float = 1.0, n_slide: float | None = None, g: float | None = None,
         sigma_r: float | None = None, sigma_t: float | None = None,
         sigma_u: float | None = None, specular_in_m_r: float = 1.0,
         unscattered_in_m_t: float = 1.0, incidence: float = 0.0,
         streams: int | None = None) -> FitResult: ...
def _fit_many(m_r: npt.NDArray[np.float64], m_t: npt.NDArray[np.float64],
              m_u: npt.NDArray[np.float64] | None, g: npt.NDArray[np.float64] | None,
              sigma_r: npt.NDArray[np.float64] | None, sigma_t: npt.NDArray[np.float64] | None,
              sigma_u: npt.NDArray[np.float64] | None, *, thickness: float,
              n_sample: float = 1.0, n_slide: float | None = None,
              specular_in_m_r: float = 1.0, unscattered_in_m_t: float = 1.0,
              incidence: float = 0.0, streams: int | None = None,
              budget: float = 1.0) -> list[FitResult | KmError]: ...

def fit_km(*, r_black: float | None = None, r_white: float | None = None,
           r_white_ground: float | None = None, r_black_ground: float | None = None,
           r_inf: float | None = None, r_zero: float | None = None,
           thickness: float | None = None, n: float | None = None,
           k2: float | None = None) -> dict[str, Any]:
    """Kubelka-Munk inverse of one paint film (``km.fit_km`` wraps it, km/_fit.py).

    Three ways in: ``r_black``, ``r_white``, ``r_white_ground``
    [``r_black_ground``] and ``thickness`` (a drawdown over two grounds,
    Kubelka 1948); ``r_inf``, ``r_zero`` and ``thickness`` (an opaque film
    and one over ideal black); ``r_inf`` alone (only K/S). With ``n`` (and
    optionally ``k2``) the readings are instrument readings and get
    Saunderson's correction. Returns the ``km fit --km --json`` object as a
    dict (``K``, ``S``, ``K_over_S``, ``S_X``, ``R_inf``, ``R_0``, ``T``,
    ``thickness``, ``mode``, ``uncertainty``, ``saunderson``, ``inputs``,
    ``internal``). Raises :class:`KmError` naming the reading at fault.
    """

def colour(wavelengths_nm: Sequence[float], values: Sequence[float], *,
           observer: str = "1931", illuminant: str = "D65") -> dict[str, Any]:
    """Colour of a spectrum as tuples and bytes (``km.colour``, km/_colour.py,
    returns numpy arrays).

    ``observer``: ``"1931"`` (2 degrees) or ``"1964"`` (10 degrees);
    ``illuminant``: ``"D65"`` or ``"D50"``. Returns ``xyz`` (Y = 100 for
    the perfect diffuser), ``white`` (the illuminant's white point),
    ``lab`` (CIELAB), ``srgb`` (0..1, encoded) and ``srgb_u8``.
    """

def delta_e2000(lab1: tuple[float, float, float], lab2: tuple[float, float, float]) -> float:
    """CIEDE2000 of two triples (``km.delta_e2000`` takes any sequences and arrays)."""

def srgb(xyz: tuple[float, float, float]) -> tuple[float, float, float]:
    """sRGB of one XYZ triple (``km.srgb`` takes any sequences and arrays)."""

def fit_file(path: str | PathLike[str], *, thickness: float | None = None,
             n_sample: float = 1.0, n_slide: float | None = None, g: float | None = None,
             sigma_r: float | None = None, sigma_t: float | None = None,
             sigma_u: float | None = None, specular_in_m_r: float = 1.0,
             unscattered_in_m_t: float = 1.0, incidence: float = 0.0,
             streams: int | None = None, fix_mu_s: float | str | None = None,
             fix_mu_a: float | None = None, semi_infinite: bool = False,
             budget: float = 1.0) -> list[dict[str, Any]]:
    """The rows of ``km fit FILE --json`` (``km.fit_file`` wraps them as
    ``km.FitResults``, km/_fit.py).

    iad's ``.rxt`` (sample and spheres from its header) or a ``.csv`` with
    columns wavelength_nm, m_r, m_t[, m_u, sigma_r, sigma_t, sigma_u, g]
    (``thickness`` required). Returns the command's list: per row the
    :class:`FitResult` dict plus ``wavelength_nm``, or ``{"wavelength_nm",
    "status": "invalid", "error"}`` for a row that cannot be fitted. Rows are
    fitted in parallel with the GIL released.
    """
