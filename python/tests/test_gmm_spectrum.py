"""Mixture fits against the CLI, mixture sampling against its density, the CIE observer."""

import numpy as np
import pytest

import stokes
from conftest import BFC, run_cli


@pytest.mark.parametrize("components,seed", [(4, 3), ("auto:3", 0)])
def test_fit_equals_the_cli_byte_for_byte(cli, tmp_path, components, seed):
    bfc = BFC / "GOLFYE.BFC"
    run_cli(cli, "gmm", "fit", str(bfc), "--components", str(components), "--seed", str(seed),
            "-o", str(tmp_path / "cli.json"))
    m = stokes.gmm.fit(bfc, components, seed)
    m.save(tmp_path / "py.json")
    assert (tmp_path / "cli.json").read_bytes() == (tmp_path / "py.json").read_bytes()
    back = stokes.gmm.load(tmp_path / "cli.json")
    assert back.to_json() == m.to_json()
    assert m.means.shape == (m.n_components, 2) and m.covariances.shape == (m.n_components, 2, 2)


def test_sample_out_follows_its_density():
    m = stokes.gmm.fit(BFC / "GOLFYE.BFC", 4, 0, restarts=1)
    li = 450.0
    (lo_min, lo_max) = m.support[1]
    grid = np.linspace(lo_min, lo_max, 4001)
    pdf = m.pdf_out(li, grid)
    # the conditional density integrates to one
    assert abs(np.trapezoid(pdf, grid) - 1) < 2e-3
    n = 200_000
    s = m.sample_out(li, n, seed=7)
    assert s.shape == (n,) and (s > li).all()
    edges = np.linspace(lo_min, lo_max, 61)
    hist, _ = np.histogram(s, bins=edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    fine = np.linspace(edges[0], edges[-1], 60 * 50 + 1)
    dens = m.pdf_out(li, fine)
    expected = np.array([np.trapezoid(dens[i * 50:(i + 1) * 50 + 1], fine[i * 50:(i + 1) * 50 + 1])
                         for i in range(60)]) * n
    keep = expected > 20
    chi2 = float(np.sum((hist[keep] - expected[keep]) ** 2 / expected[keep]))
    dof = int(keep.sum()) - 1
    # far beyond the 99.9 % point of chi-square with this many degrees of freedom
    assert chi2 < dof + 5 * np.sqrt(2 * dof), (chi2, dof)
    assert centres.shape == (60,)
    # sample_in stays below its emission wavelength
    assert (m.sample_in(550.0, 1000, seed=1) < 550).all()
    with pytest.raises(stokes.InputError):
        m.sample_out(2000.0, 10)


def test_pdf_and_kernel_broadcast():
    m = stokes.gmm.fit(BFC / "GOLFYE.BFC", 2, 0, restarts=1)
    li = np.array([400.0, 450.0])[:, None]
    lo = np.array([380.0, 500.0, 600.0])[None, :]
    assert m.pdf(li, lo).shape == (2, 3)
    k = m.kernel(li, lo)
    assert k.shape == (2, 3) and k[0, 0] == 0.0  # λo < λi: no reradiation
    assert np.allclose(m.kernel(450.0, 500.0), m.scale * m.pdf(450.0, 500.0))


def test_fit_input_errors(tmp_path):
    with pytest.raises(stokes.InputError) as e:
        stokes.gmm.fit(BFC / "GOLFYE.BFC", 0)
    assert e.value.field == "components"
    with pytest.raises(stokes.InputError) as e:
        stokes.gmm.fit(BFC / "GOLFYE.BFC", 4, method="magic")
    assert e.value.field == "method"
    with pytest.raises(stokes.InputError):
        stokes.gmm.fit(tmp_path / "none.bfc")
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(stokes.InputError) as e:
        stokes.gmm.load(bad)
    assert e.value.file == str(bad)


def test_cie_and_srgb():
    xyz = stokes.spectrum.cie_xyz([555.0, 300.0, 900.0])
    assert xyz.shape == (3, 3)
    assert abs(xyz[0, 1] - 1.0) < 1e-3 and (xyz[1:] == 0).all()
    assert stokes.spectrum.cie_xyz(np.zeros((4, 5))).shape == (4, 5, 3)
    # the D65 white (Y = 1) is sRGB (1, 1, 1)
    white = np.linalg.solve(stokes.spectrum.XYZ_TO_SRGB, np.ones(3))
    assert np.allclose(stokes.spectrum.xyz_to_srgb(white), 1.0)
    with pytest.raises(ValueError):
        stokes.spectrum.xyz_to_srgb(np.ones(4))
