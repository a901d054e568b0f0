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


def seconds_to_stop_on_ctrl_c(work, after: float) -> float:
    """Run `work()` on the main thread, send this process SIGINT after `after` seconds, expect
    KeyboardInterrupt, and return the seconds from the signal to the exception."""
    import signal
    import threading
    import time

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    sent = []

    def interrupt():
        sent.append(time.perf_counter())
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(after, interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        work()
    stopped = time.perf_counter()
    timer.join()
    assert sent, "the work ended before the signal"
    return stopped - sent[0]
