"""`mypy --strict` accepts the examples (examples/python/*.py) and the
package's own modules with the type stubs of the extension (km/_km.pyi):
what an editor or a type checker sees of `km` is what the code does."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import REPO

mypy = pytest.importorskip("mypy", reason="mypy is not installed (scripts/test-all installs it)")


def test_mypy_strict_accepts_the_examples_and_the_package(tmp_path):
    # One run for both (mypy's cache of numpy and the standard library is
    # built once): the examples import the package from its source tree.
    examples = sorted(str(p) for p in (REPO / "examples" / "python").glob("*.py"))
    assert examples
    cmd = [sys.executable, "-m", "mypy", "--strict", "--no-error-summary",
           "--config-file", str(REPO / "km-python" / "pyproject.toml"),
           "--cache-dir", str(tmp_path / "mypy-cache"), *examples,
           str(REPO / "km-python" / "python" / "km")]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO / "km-python" / "python")
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_stubs_match_the_extension(tmp_path):
    # mypy's stubtest: every name, signature, default and class of km/_km.pyi
    # against the extension module as built (a parameter added on one side
    # only, a class left subclassable in the stub, ... fail).
    cmd = [sys.executable, "-m", "mypy.stubtest", "km._km",
           "--mypy-config-file", str(REPO / "km-python" / "pyproject.toml")]
    # From a directory outside the source tree: the package as installed
    # (its stubs and its extension), as a user's type checker sees it.
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
