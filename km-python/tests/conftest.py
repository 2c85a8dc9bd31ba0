"""Shared fixtures: the repository root and the `km` command built from it."""

from __future__ import annotations

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.toml"))


@pytest.fixture(scope="session")
def km_cli() -> pathlib.Path:
    """The `km` binary of this checkout: $KM_CLI, or `cargo build -p km-cli` (dev profile)."""
    env = os.environ.get("KM_CLI")
    if env:
        path = pathlib.Path(env)
        assert path.is_file(), f"KM_CLI={env} is not a file"
        return path
    subprocess.run(["cargo", "build", "--quiet", "-p", "km-cli"], cwd=REPO, check=True)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    path = target / "debug" / "km"
    assert path.is_file(), f"cargo build did not produce {path}"
    return path
