"""`mypy --strict` accepts the examples (examples/python/*.py) and the
package's own modules with the type stubs of the extension (km/_km.pyi):
what an editor or a type checker sees of `km` is what the code does."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import REPO

mypy = pytest.importorskip("mypy", reason="mypy is not installed (scripts/test-all installs it)")


@pytest.mark.parametrize("what", ["examples", "package"])
def test_mypy_strict_accepts(what, tmp_path):
    paths = (sorted(str(p) for p in (REPO / "examples" / "python").glob("*.py"))
             if what == "examples" else [str(REPO / "km-python" / "python" / "km")])
    assert paths
    cmd = [sys.executable, "-m", "mypy", "--strict", "--no-error-summary",
           "--config-file", str(REPO / "km-python" / "pyproject.toml"),
           "--cache-dir", str(tmp_path / "mypy-cache"), *paths]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO / "km-python" / "python")
    assert r.returncode == 0, r.stdout + r.stderr
