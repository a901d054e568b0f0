"""Experiment runs from Python: a config as a dict or a file, the run read back, bad configs."""

import json

import numpy as np
import pytest

import stokes
from conftest import REPO, SCENES, seconds_to_stop_on_ctrl_c


def small_config(name="py-smoke"):
    return {
        "name": name,
        "scene": "fluorescent-walls.json",
        "reference": {"integrator": "pt-hero", "spp": 16, "seed": 1000},
        "variants": [
            {"name": "pt-mono", "integrator": "pt-mono"},
            {"name": "pt-hero", "integrator": "pt-hero"},
        ],
        "budget": {"spp": [1, 2]},
        "repeats": 1,
        "regions": {"by": "shape"},
    }


def test_run_experiment_from_a_dict(tmp_path):
    run = stokes.run_experiment(small_config(), quick=True, out=tmp_path, base_dir=SCENES)
    assert run.path.is_relative_to(tmp_path / "py-smoke" / "runs")
    assert run.name == "py-smoke"
    variants = {r["variant"] for r in run.metrics}
    assert variants == {"pt-mono", "pt-hero"}
    a = run.metrics_array()
    assert a.shape == (len(run.metrics),) and a.dtype == stokes.METRICS_DTYPE
    assert set(np.unique(a["spp"])) == {1, 2}
    assert np.isfinite(a["rel_mse"]).all() and (a["rel_mse"] >= 0).all()
    assert (a["region"] == "all").sum() == 4 and (a[a["region"] == "all"]["rel_mse"] > 0).all()
    assert run.images and all(p.suffix == ".exr" and p.is_file() for p in run.images)
    assert run.figures and all(p.is_file() for p in run.figures)
    assert run.reference is not None and run.reference.is_file()
    # read back from the experiment's folder, through `latest`
    again = stokes.load_run(tmp_path / "py-smoke")
    assert again.path == run.path and again.metrics == run.metrics


def test_run_experiment_from_a_file(tmp_path):
    cfg = small_config("py-file")
    cfg["scene"] = str(SCENES / "fluorescent-walls.json")
    f = tmp_path / "cfg.json"
    f.write_text(json.dumps(cfg))
    run = stokes.run_experiment(f, quick=True, out=tmp_path / "results")
    assert len(run.metrics) > 0 and run.info["quick"] is True


def test_bad_config_raises_input_error_naming_the_field(tmp_path):
    cfg = small_config()
    cfg["budget"] = {"spp": [0]}
    with pytest.raises(stokes.InputError) as e:
        stokes.run_experiment(cfg, quick=True, out=tmp_path, base_dir=SCENES)
    assert e.value.field is not None and e.value.field.startswith("budget"), str(e.value)
    cfg = small_config()
    cfg["variants"][0]["integrator"] = "pt-nope"
    with pytest.raises(stokes.InputError):
        stokes.run_experiment(cfg, quick=True, out=tmp_path, base_dir=SCENES)
    # nothing was run: no run folder
    assert not (tmp_path / "py-smoke" / "runs").exists() or not any(
        (tmp_path / "py-smoke" / "runs").iterdir()
    )


def test_load_run_of_a_stored_run_and_of_bad_folders(tmp_path):
    stored = REPO / "results" / "walls-integrators"
    run = stokes.load_run(stored)
    assert run.metrics and {"pt-hero", "bdpt-forward"} <= {r["integrator"] for r in run.metrics}
    with pytest.raises(stokes.InputError):
        stokes.load_run(tmp_path)
    # an interrupted run (its marker still there) is refused
    d = tmp_path / "run"
    d.mkdir()
    (d / "INCOMPLETE").write_text("experiment 'x'\n")
    with pytest.raises(stokes.InputError):
        stokes.load_run(d)


def test_ctrl_c_stops_an_experiment_and_keeps_its_marker(tmp_path):
    cfg = small_config("py-interrupted")
    cfg["budget"] = {"seconds": [30]}
    took = seconds_to_stop_on_ctrl_c(
        lambda: stokes.run_experiment(cfg, quick=False, out=tmp_path, base_dir=SCENES), 1.0
    )
    assert took < 1.0, took
    runs = list((tmp_path / "py-interrupted" / "runs").iterdir())
    assert len(runs) == 1 and (runs[0] / "INCOMPLETE").is_file()
    with pytest.raises(stokes.InputError):
        stokes.load_run(runs[0])


def test_load_run_refuses_a_run_without_its_summary(tmp_path):
    import shutil

    src = REPO / "results" / "walls-integrators"
    run = stokes.load_run(src).path
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    (copy / "summary.json").unlink()
    with pytest.raises(stokes.InputError) as e:
        stokes.load_run(copy)
    assert e.value.file.endswith("summary.json")
    (copy / "summary.json").write_text("{not json")
    with pytest.raises(stokes.InputError) as e:
        stokes.load_run(copy)
    assert e.value.file.endswith("summary.json")
