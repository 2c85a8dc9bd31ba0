"""km: light in stacks of flat scattering layers, from Python.

Two-flux Kubelka-Munk, the multi-flux eigenvalue solver (discrete ordinates),
a Monte Carlo reference and the diffusion dipole over one scene description;
the whole BSDF of a stack; the inverse problems of ``km fit``; colour; each
layer's phase function and Mie theory (:func:`phase`, :func:`mie`).

    >>> import km
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9, g=0.5)])
    >>> sol = km.solve(scene, method="multiflux")
    >>> round(sol.reflectance + sol.transmittance + sol.absorptance, 9)
    1.0

The scene keys are those of the scene file (docs/scene-file.md); every
refusal is a :class:`KmError` (a ``ValueError``) naming the key (and the
line of a scene file's text); :class:`KmTypeError` and
:class:`KmFileNotFoundError` add ``TypeError`` and ``FileNotFoundError``.
The user guide is docs/python.md; ``help(km.solve)`` and the other
functions' docstrings give every parameter.
"""

from ._km import FitResult, Partial, Scene, Solution, __version__
from ._errors import KmError, KmFileNotFoundError, KmTypeError
from ._solve import Batch, field, layer, merge, profile, run_shard, solve, solve_many
from ._bsdf import Bsdf, bsdf
from ._fit import FitResults, fit, fit_file, fit_km
from ._colour import colour, delta_e2000, srgb
from ._phase import mie, phase

__all__ = [
    "Batch",
    "Bsdf",
    "FitResult",
    "FitResults",
    "KmError",
    "KmFileNotFoundError",
    "KmTypeError",
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
    "mie",
    "phase",
    "profile",
    "run_shard",
    "solve",
    "solve_many",
    "srgb",
    "__version__",
]
