"""Shared fixtures: the repository's root, its scenes and data, and the CLI binary that the
Python renders are compared against (built by `cargo build --release` or `cargo test
--release`; STOKES_BIN overrides)."""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"
BFC = REPO / "data" / "bispectral"


@pytest.fixture(scope="session")
def cli() -> Path:
    exe = Path(os.environ.get("STOKES_BIN", REPO / "target" / "release" / "stokes"))
    if not exe.is_file():
        pytest.fail(
            f"the CLI binary '{exe}' is missing: run `cargo build --release` first "
            "(or set STOKES_BIN)"
        )
    return exe


def run_cli(exe: Path, *args: str) -> subprocess.CompletedProcess:
    p = subprocess.run([str(exe), *args], capture_output=True, text=True)
    assert p.returncode == 0, f"stokes {' '.join(args)} failed:\n{p.stderr}"
    return p
