"""Renders from Python: the same pixels as the CLI, closed-form furnaces, dict scenes, input
errors, arrays, concurrency, Ctrl-C and progress."""

import json
import threading
import time

import numpy as np
import pytest

import stokes
from conftest import SCENES, run_cli, seconds_to_stop_on_ctrl_c


@pytest.mark.parametrize("integrator", ["pt-hero", "pt-mono", "bdpt-combined", "bdpt-allbins"])
def test_render_is_pixel_identical_to_cli(cli, tmp_path, integrator):
    scene = str(SCENES / "cornell-box.json")
    a = tmp_path / "cli.exr"
    run_cli(cli, "render", scene, "--integrator", integrator, "--spp", "2", "--seed", "5",
            "-o", str(a))
    r = stokes.load_scene(scene).render(integrator, spp=2, seed=5)
    b = tmp_path / "py.exr"
    r.save_exr(b)
    cli_rgb = stokes.read_exr(a)
    assert cli_rgb.shape == r.rgb.shape == (256, 256, 3)
    assert np.array_equal(cli_rgb, r.rgb)
    # the same file, attributes included (scene hash, integrator, options, seed, samples)
    assert a.read_bytes() == b.read_bytes()


def test_options_reach_the_integrator_as_on_the_cli(cli, tmp_path):
    scene = str(SCENES / "fluorescent-walls.json")
    a = tmp_path / "cli.exr"
    run_cli(cli, "render", scene, "--integrator", "pt-hero", "--spp", "1", "--seed", "2",
            "--lanes", "6", "--max-depth", "5", "--camera-wavelengths", "cmf", "-o", str(a))
    r = stokes.load_scene(scene).render("pt-hero", spp=1, seed=2, max_depth=5, lanes=6,
                                        camera_wavelengths="cmf")
    assert np.array_equal(stokes.read_exr(a), r.rgb)
    assert r.options["lanes"] == 6 and r.options["max_depth"] == 5
    assert r.stats["integrator"] == "pt-hero" and r.stats["spp"] == 1


def _y_of(spectrum, lo, hi):
    """Y of a spectral radiance over [lo, hi] nm, normalised as the film is (∫ȳ = 1)."""
    lam = np.arange(lo, hi, 0.01) + 0.005
    y = stokes.spectrum.cie_xyz(lam)[:, 1]
    return float(np.sum(spectrum(lam) * y) / np.sum(y))


def test_fluorescent_furnace_matches_its_closed_form():
    scene = stokes.load_scene(SCENES / "furnace-fluorescent.json")
    lo, hi = scene.wavelength_range

    def radiance(lam):  # the scene's comment: L = 5.2, 1/0.9 and 2
        return np.where((lam >= 500) & (lam < 550), 5.2,
                        np.where((lam >= 300) & (lam < 400), 1 / 0.9, 2.0))

    want = _y_of(radiance, lo, hi)
    r = scene.render("pt-hero", spp=256, seed=1, max_depth=64)
    got = float(r.xyz[..., 1].mean())
    assert r.stats["nan_inf_rejected"] == 0
    assert abs(got - want) < 0.01 * want, (got, want)


def test_lambert_furnace_is_two():
    r = stokes.load_scene(SCENES / "furnace-lambert.json").render("pt-mono", spp=256, seed=3,
                                                                     max_depth=40)
    assert abs(float(r.xyz[..., 1].mean()) - 2.0) < 0.02


def test_from_dict_of_a_modified_scene_equals_rendering_the_modified_file(cli, tmp_path):
    src = SCENES / "fluorescent-walls.json"
    d = stokes.load_scene(src).to_dict()
    assert d == json.loads(src.read_text())
    # a changed material parameter and a smaller image
    name = next(iter(d["materials"]))
    d["camera"]["width"], d["camera"]["height"] = 48, 32
    f = tmp_path / "modified.json"
    f.write_text(json.dumps(d))
    run_cli(cli, "render", str(f), "--integrator", "pt-hero", "--spp", "2", "--seed", "9",
            "-o", str(tmp_path / "file.exr"))
    r = stokes.Scene.from_dict(d, base_dir=SCENES).render("pt-hero", spp=2, seed=9)
    assert r.rgb.shape == (32, 48, 3)
    assert np.array_equal(stokes.read_exr(tmp_path / "file.exr"), r.rgb)
    assert name  # the scene has materials to sweep


def test_bad_scene_raises_input_error_naming_the_field(tmp_path):
    d = stokes.load_scene(SCENES / "cornell-box.json").to_dict()
    d["camera"]["width"] = -3
    with pytest.raises(stokes.InputError) as e:
        stokes.Scene.from_dict(d, base_dir=SCENES, name="swept.json")
    assert isinstance(e.value, ValueError)
    assert e.value.field == "camera.width"
    assert e.value.file.endswith("swept.json")
    assert "camera.width" in str(e.value)
    # the same from a file, as the CLI reports it
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(d))
    with pytest.raises(stokes.InputError) as e:
        stokes.load_scene(f)
    assert e.value.field == "camera.width" and e.value.file == str(f)
    with pytest.raises(stokes.InputError) as e:
        stokes.load_scene(tmp_path / "missing.json")
    assert e.value.file.endswith("missing.json") and e.value.field is None


def test_bad_options_raise_input_error_naming_the_option():
    scene = stokes.load_scene(SCENES / "furnace-lambert.json")
    cases = [
        (dict(integrator="pt-heroo"), "integrator"),
        (dict(spp=0), "spp"),
        (dict(threads=0), "threads"),
        (dict(time_limit=-1.0), "time_limit"),
        (dict(seed=-1), "seed"),
        (dict(max_depth=0), "max_depth"),
        (dict(max_depth=5000), "max_depth"),
        (dict(lanes=17), "lanes"),
        (dict(reset_choice="random"), "reset_choice"),
        (dict(mis="powerful"), "mis"),
        (dict(lanes="four"), "lanes"),
        (dict(integrator="bdpt-allbins", spectral=8), "spectral"),
    ]
    for kwargs, field in cases:
        with pytest.raises(stokes.InputError) as e:
            scene.render(**kwargs)
        assert e.value.field == field, (kwargs, e.value.field, str(e.value))
    with pytest.raises(stokes.InputError, match="no_such_option"):
        scene.render(no_such_option=1)


def test_arrays_are_c_contiguous_owned_copies():
    r = stokes.load_scene(SCENES / "furnace-lambert.json").render("pt-hero", spp=2,
                                                                     spectral=6)
    for a in (r.rgb, r.xyz, r.spectral):
        assert a.dtype == np.float32
        assert a.flags["C_CONTIGUOUS"] and a.flags["OWNDATA"] and a.flags["WRITEABLE"]
    assert r.spectral.shape == (32, 32, 6) and r.wavelengths.shape == (6,)
    assert len(r.wavelength_edges) == 7
    x = r.rgb
    x[...] = -1
    assert (r.rgb >= 0).all(), "each access is a copy of the film"
    # rgb is the film's XYZ through the sRGB matrix
    assert np.allclose(stokes.spectrum.xyz_to_srgb(r.xyz), r.rgb, rtol=1e-5, atol=1e-6)
    assert stokes.load_scene(SCENES / "furnace-lambert.json").render(spp=1).spectral is None


def test_two_threads_render_concurrently():
    scene = stokes.load_scene(SCENES / "cornell-box.json")

    def one():
        scene.render("pt-hero", spp=24, seed=1, threads=1)

    one()  # warm up
    t = time.perf_counter()
    one()
    one()
    sequential = time.perf_counter() - t
    ts = [threading.Thread(target=one) for _ in range(2)]
    t = time.perf_counter()
    for th in ts:
        th.start()
    for th in ts:
        th.join()
    concurrent = time.perf_counter() - t
    # with the GIL held the two would take as long as one after the other
    assert concurrent < 0.8 * sequential, (concurrent, sequential)


def test_ctrl_c_stops_a_render_within_a_second():
    scene = stokes.load_scene(SCENES / "cornell-box.json")
    took = seconds_to_stop_on_ctrl_c(lambda: scene.render("bdpt-forward", spp=100000), 0.5)
    assert took < 1.0, took
    # the scene renders again afterwards
    assert scene.render("pt-mono", spp=1).spp == 1


def test_progress_callback_sees_every_pass_and_can_stop():
    scene = stokes.load_scene(SCENES / "furnace-lambert.json")
    seen = []

    def progress(done, total, seconds):
        seen.append((done, total, seconds))

    r = scene.render("pt-mono", spp=5, progress=progress)
    assert [d for d, _, _ in seen] == [1, 2, 3, 4, 5] and all(t == 5 for _, t, _ in seen)
    # the image is the one rendered without a callback
    assert np.array_equal(r.rgb, scene.render("pt-mono", spp=5).rgb)
    r = scene.render("pt-mono", spp=1000, progress=lambda d, t, s: d < 3)
    assert 3 <= r.spp < 1000

    def fails(done, total, seconds):
        raise RuntimeError("from the callback")

    with pytest.raises(RuntimeError, match="from the callback"):
        scene.render("pt-mono", spp=1000, progress=fails)


def test_save_png_and_spectral_exr(tmp_path):
    r = stokes.load_scene(SCENES / "furnace-lambert.json").render("pt-hero", spp=1, spectral=4)
    r.save_png(tmp_path / "a.png")
    r.save_spectral_exr(tmp_path / "a.spectral.exr")
    assert (tmp_path / "a.png").stat().st_size > 0
    assert (tmp_path / "a.spectral.exr").stat().st_size > 0
    with pytest.raises(stokes.InputError):
        r.save_exr(tmp_path / "a.png")


def test_strategy_images_sum_to_the_image_and_match_the_cli(cli, tmp_path):
    scene = str(SCENES / "cornell-box.json")
    r = stokes.load_scene(scene).render("bdpt-forward", spp=1, seed=2, max_depth=4,
                                        strategy_images=True)
    layers = r.strategy_images
    assert {"s1_t1", "s2_t1", "s3_t0"} <= set(layers)
    total = sum(layers.values())
    assert np.allclose(total, r.rgb, rtol=1e-4, atol=1e-6)
    run_cli(cli, "render", scene, "--integrator", "bdpt-forward", "--spp", "1", "--seed", "2",
            "--max-depth", "4", "-o", str(tmp_path / "a.exr"), "--strategy-images",
            str(tmp_path / "layers"))
    for name, img in layers.items():
        assert np.array_equal(stokes.read_exr(tmp_path / "layers" / f"{name}.exr"), img), name
    assert stokes.load_scene(scene).render("pt-hero", spp=1).strategy_images == {}


def test_display_helpers():
    import zlib

    r = stokes.load_scene(SCENES / "cornell-box.json").render("pt-hero", spp=1)
    s = r.srgb()
    assert s.shape == r.rgb.shape and s.dtype == np.float32
    assert s.min() >= 0.0 and s.max() <= 1.0
    assert (r.srgb(exposure=-4) <= s + 1e-7).all()
    png = r._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # decode it: IHDR size, then rows of (filter 0, RGB bytes) that are round(srgb * 255)
    w, h = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert (w, h) == (256, 256)
    pos, idat = 8, b""
    while pos < len(png):
        n = int.from_bytes(png[pos:pos + 4], "big")
        if png[pos + 4:pos + 8] == b"IDAT":
            idat += png[pos + 8:pos + 8 + n]
        pos += 12 + n
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + 3 * w)
    assert (rows[:, 0] == 0).all()
    assert np.array_equal(rows[:, 1:].reshape(h, w, 3), np.round(s * 255).astype(np.uint8))
