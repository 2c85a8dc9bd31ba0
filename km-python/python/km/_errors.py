"""The exceptions of km: :class:`KmError` and its standard-library flavours."""

from __future__ import annotations

from typing import Any

from ._km import KmError


class KmTypeError(KmError, TypeError):
    """An argument of the wrong type: a :class:`KmError` and a ``TypeError``.

    Raised for a keyword argument that is not a setting of the solve, a
    setting given a value of the wrong type (``streams="8"``), or a Python
    value that cannot stand in a scene (an object where a number belongs).
    ``except km.KmError``, ``except TypeError`` and (as every
    :class:`KmError`) ``except ValueError`` all catch it.

    Attributes
    ----------
    key : str or None
        The keyword argument or scene key named.
    line : int or None
        Always None (no scene text is involved).

    Examples
    --------
    >>> import km
    >>> scene = km.Scene(layers=[km.layer(tau=1.0, albedo=0.9)])
    >>> try:
    ...     km.solve(scene, streams="eight")
    ... except TypeError as e:
    ...     print(type(e).__name__, e.key)
    KmTypeError streams
    """

    __module__ = "km"


class KmFileNotFoundError(KmError, FileNotFoundError):
    """A file that does not exist: a :class:`KmError` and a ``FileNotFoundError``.

    Raised by :meth:`km.Scene.from_file` and :func:`km.fit_file`.
    ``errno`` is ``ENOENT`` (2), ``filename`` the path given and ``str(err)``
    the message of the ``km`` command (``cannot read ...``).

    Attributes
    ----------
    key : str or None
        ``"file"`` (a scene file) or ``"path"`` (a measurement file).
    line : int or None
        Always None.
    errno : int
        2 (``ENOENT``).
    filename : str
        The path given.

    Examples
    --------
    >>> import km
    >>> try:
    ...     km.Scene.from_file("no-such-scene.toml")
    ... except FileNotFoundError as e:
    ...     print(e.errno, e.filename)
    2 no-such-scene.toml
    """

    __module__ = "km"

    def __str__(self) -> str:
        # The command's message, not OSError's "[Errno 2] ...".
        return str(self.args[0]) if self.args else ""

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickled with errno, strerror and filename (OSError's own reduce
        # keeps only the message), e.g. across Dask workers.
        state = dict(self.__dict__, errno=self.errno, strerror=self.strerror,
                     filename=self.filename)
        return (type(self), tuple(self.args), state)


__all__ = ["KmError", "KmTypeError", "KmFileNotFoundError"]
