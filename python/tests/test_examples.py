"""The examples of examples/python run and write their plots (tiny settings). They need
matplotlib, which only they use: without it these tests skip, unless STOKES_REQUIRE_MATPLOTLIB=1
(scripts/python-test.sh installs it and sets that)."""

import os
import subprocess
import sys

import pytest

from conftest import REPO

EXAMPLES = REPO / "examples" / "python"


def have_matplotlib():
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        if os.environ.get("STOKES_REQUIRE_MATPLOTLIB") == "1":
            pytest.fail("STOKES_REQUIRE_MATPLOTLIB=1 but matplotlib is not installed")
        pytest.skip("matplotlib is not installed (pip install matplotlib)")


def run(script, *args):
    p = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True,
                       text=True)
    assert p.returncode == 0, p.stderr
    return p.stdout


def test_sweep_concentration_writes_its_plot(tmp_path):
    have_matplotlib()
    out = tmp_path / "sweep.png"
    text = run("sweep_concentration.py", "--spp", "2", "--size", "16", "--values", "0,0.5,1",
               "--out", str(out))
    assert out.stat().st_size > 1000
    rows = [l for l in text.splitlines() if l.strip()[:1].isdigit()]
    assert len(rows) == 3
    # black without fluorescence, not with it
    assert [float(x) for x in rows[0].split()[1:4]] == [0.0, 0.0, 0.0]
    assert float(rows[2].split()[3]) > 0


def test_compare_integrators_writes_its_plot(tmp_path):
    have_matplotlib()
    out = tmp_path / "compare.png"
    text = run("compare_integrators.py", "--size", "16", "--budgets", "0.05,0.1",
               "--reference-spp", "16", "--out", str(out))
    assert out.stat().st_size > 1000
    for name in ["pt-mono", "pt-hero", "bdpt-forward", "bdpt-backward", "bdpt-combined",
                 "bdpt-allbins"]:
        assert text.count(f" {name} ") == 2, text
