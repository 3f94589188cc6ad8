"""Every function against the CLI on the same inputs and seed: exact equality of the dict
(timing fields aside), and `grid`'s columns against the command's grid.csv."""

import csv
import math
import warnings

import numpy as np
import pytest

import crashrig
from conftest import FIXTURES, strip_timing

SCENARIOS = FIXTURES / "scenarios"
SEQ = FIXTURES / "measure" / "sequence"
TWOVIEW = FIXTURES / "paper" / "twoview"


def test_version_and_error_type():
    assert isinstance(crashrig.__version__, str) and crashrig.__version__
    assert issubclass(crashrig.Error, ValueError)


def test_propagate_equals_cli(cli):
    scenario = SCENARIOS / "paper_chain.toml"
    got = crashrig.propagate(str(scenario), samples=3000, seed=7)
    want = cli("propagate", scenario, "--samples", "3000", "--seed", "7")
    assert strip_timing(got) == strip_timing(want)
    # TOML text gives the same numbers as the file.
    text = scenario.read_text()
    assert strip_timing(crashrig.propagate(text, samples=3000, seed=7)) == strip_timing(want)


def read_grid_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize(
    "name", ["three_cameras_z0.toml", "fixed_three_cameras.toml", "three_cameras_correlated.toml"]
)
def test_grid_equals_cli(cli, tmp_path, name):
    scenario = SCENARIOS / name
    got = crashrig.grid(scenario, samples=400, seed=3)
    out = tmp_path / "grid"
    cli("grid", scenario, "--out", out, "--samples", "400", "--seed", "3", "--no-plots")
    rows = read_grid_csv(out / "grid.csv")
    assert list(got) == list(rows[0].keys()), "one array per grid.csv column, in order"
    for name_, column in got.items():
        assert isinstance(column, np.ndarray)
        assert len(column) == len(rows)
        for value, row in zip(column.tolist(), rows):
            cell = row[name_]
            if isinstance(value, bool) or value is None:
                assert cell == ("" if value is None else str(value).lower()), name_
            elif isinstance(value, float) and math.isnan(value):
                assert cell in ("", "NaN"), name_
            elif isinstance(value, float):
                assert value == float(cell), name_  # exact: Rust prints the shortest round trip
            else:
                assert value == int(cell), name_


def test_grid_writes_out_like_the_command(tmp_path):
    out = tmp_path / "g"
    crashrig.grid(str(SCENARIOS / "three_cameras_z0.toml"), samples=200, seed=1, out=out)
    assert (out / "grid.csv").is_file() and (out / "summary.json").is_file()


def test_grid_progress_callback_and_seed():
    seen = []
    a = crashrig.grid(
        SCENARIOS / "four_cameras_z0.toml",
        samples=2000,
        seed=5,
        progress=lambda stage, done, total: seen.append((stage, done, total)),
    )
    b = crashrig.grid(SCENARIOS / "four_cameras_z0.toml", samples=2000, seed=5)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert seen, "the callback was called"
    for stage, done, total in seen:
        assert isinstance(stage, str) and 0 <= done <= total


def test_progress_exception_stops_the_call():
    class Stop(Exception):
        pass

    def cb(stage, done, total):
        raise Stop()

    with pytest.raises(Stop):
        crashrig.grid(SCENARIOS / "four_cameras_z0.toml", samples=200000, seed=5, progress=cb)


def test_calibrate_equals_cli(cli):
    model = FIXTURES / "rig" / "paper"
    got = crashrig.calibrate(model, camera_a="cam_out/", camera_b="cam_in/", mm_per_unit=1000.0)
    want = cli("calibrate", model, "--camera-a", "cam_out/", "--camera-b", "cam_in/",
               "--mm-per-unit", "1000")
    assert strip_timing(got) == strip_timing(want)


def test_bootstrap_equals_cli(cli):
    args = dict(model=TWOVIEW / "model", image_a="cam_in/000001.png",
                image_b="cam_door/000001.png", iterations=40, mm_per_unit=1000.0, seed=4)
    got = crashrig.bootstrap(TWOVIEW / "database.db", **args)
    want = cli("bootstrap", TWOVIEW / "database.db", "--model", args["model"], "--image-a",
               args["image_a"], "--image-b", args["image_b"], "--iterations", "40",
               "--mm-per-unit", "1000", "--seed", "4")
    assert strip_timing(got) == strip_timing(want)


def measure_kwargs():
    return dict(
        camera_a="cam_out/", camera_b=2, camera_c=3, link=SEQ / "link.json", tie=SEQ / "tie.json",
        observations=SEQ / "observations.csv", a_covariance=SEQ / "a_covariance.json",
        mm_per_unit=1000.0, pixel_sigma_px=0.1, frame_rate_hz=1000.0, samples=300, seed=9,
    )


def test_measure_equals_cli(cli, tmp_path):
    got = crashrig.measure(SEQ / "model", out=tmp_path / "py", **measure_kwargs())
    want = cli("measure", SEQ / "model", "--camera-a", "cam_out/", "--camera-b", "2",
               "--camera-c", "3", "--link", SEQ / "link.json", "--tie", SEQ / "tie.json",
               "--observations", SEQ / "observations.csv", "--a-covariance",
               SEQ / "a_covariance.json", "--mm-per-unit", "1000", "--pixel-sigma-px", "0.1",
               "--frame-rate-hz", "1000", "--samples", "300", "--seed", "9",
               "--out", tmp_path / "cli")
    assert strip_timing(got) == strip_timing(want)
    py_csv = (tmp_path / "py" / "trajectories.csv").read_bytes()
    assert py_csv == (tmp_path / "cli" / "trajectories.csv").read_bytes()


def test_measure_estimate_and_frame_times_equal_cli(cli, tmp_path):
    # pixel_sigma_px="estimate" and frame_times= are --pixel-sigma-px estimate and --frame-times.
    times = tmp_path / "frames.csv"
    epochs = [line.split(",")[0] for line in (SEQ / "observations.csv").read_text().splitlines()[1:]]
    names = list(dict.fromkeys(epochs))
    times.write_text("epoch,time_s\n" + "".join(f"{e},{i * 0.001}\n" for i, e in enumerate(names)))
    kwargs = measure_kwargs()
    del kwargs["frame_rate_hz"]
    kwargs["pixel_sigma_px"] = "estimate"
    got = crashrig.measure(SEQ / "model", out=tmp_path / "py", frame_times=times, **kwargs)
    want = cli("measure", SEQ / "model", "--camera-a", "cam_out/", "--camera-b", "2",
               "--camera-c", "3", "--link", SEQ / "link.json", "--tie", SEQ / "tie.json",
               "--observations", SEQ / "observations.csv", "--a-covariance",
               SEQ / "a_covariance.json", "--mm-per-unit", "1000", "--pixel-sigma-px", "estimate",
               "--frame-times", times, "--samples", "300", "--seed", "9",
               "--out", tmp_path / "cli")
    assert strip_timing(got) == strip_timing(want)
    assert got["pixel_sigma_estimate"]["B"]["scale"] == got["pixel_sigma_check"]["sigma_ratio"]
    assert got["frame_times"]["frames"] == len(names)
    with pytest.raises(crashrig.Error, match="pixel_sigma_px: `guess` is neither"):
        crashrig.measure(SEQ / "model", **{**kwargs, "pixel_sigma_px": "guess"})


def test_measure_scale_bars_equals_cli(cli, tmp_path):
    kwargs = dict(measure_kwargs(), observations=SEQ / "observations_scale_bars.csv")
    got = crashrig.measure(SEQ / "model", out=tmp_path / "py", scale_bars=SEQ / "scale_bars.csv",
                           mpe_mm=1.0, **kwargs)
    want = cli("measure", SEQ / "model", "--camera-a", "cam_out/", "--camera-b", "2",
               "--camera-c", "3", "--link", SEQ / "link.json", "--tie", SEQ / "tie.json",
               "--observations", SEQ / "observations_scale_bars.csv", "--a-covariance",
               SEQ / "a_covariance.json", "--mm-per-unit", "1000", "--pixel-sigma-px", "0.1",
               "--frame-rate-hz", "1000", "--samples", "300", "--seed", "9",
               "--scale-bars", SEQ / "scale_bars.csv", "--mpe-mm", "1",
               "--out", tmp_path / "cli")
    assert strip_timing(got) == strip_timing(want)
    bars = got["length_check"]
    assert [b["name"] for b in bars] == ["bar_door", "bar_seat", "bar_roof"]
    assert all(b["verdict"] in ("consistent", "sigma_too_small", "bias") for b in bars)
    assert all(isinstance(b["within_mpe"], bool) for b in bars)
    py_csv = (tmp_path / "py" / "length_check.csv").read_bytes()
    assert py_csv == (tmp_path / "cli" / "length_check.csv").read_bytes()
    assert py_csv.startswith(b"epoch,bar,length_mm,measured_mm,error_mm,sigma_mm,z\n")
    # A bad scale-bar file: the command's one-line message.
    bad = tmp_path / "bars.csv"
    bad.write_text("name,marker_1,marker_2,length_mm,sigma_mm\nx,head_l,head_l,300,0\n")
    with pytest.raises(crashrig.Error) as e:
        crashrig.measure(SEQ / "model", scale_bars=bad, **kwargs)
    assert str(e.value).startswith(f"{bad}:2: ") and "to itself" in str(e.value)
    # mpe_mm alone: named as Python spells it.
    with pytest.raises(crashrig.Error, match="mpe_mm: needs scale_bars"):
        crashrig.measure(SEQ / "model", mpe_mm=1.0, **kwargs)


def test_covariance_equals_cli(cli, tmp_path):
    model = FIXTURES / "covariance" / "mc" / "model"
    cp = FIXTURES / "covariance" / "mc" / "control_points.csv"
    got = crashrig.covariance(model, camera="cam_out/", control_points=cp, mm_per_unit=1000.0,
                              out=tmp_path / "py.json")
    want = cli("covariance", model, "--camera", "cam_out/", "--control-points", cp,
               "--mm-per-unit", "1000", "--out", tmp_path / "cli.json")
    assert got == want
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "cli.json").read_bytes()


def test_study_equals_cli(cli, tmp_path):
    study = FIXTURES / "study" / "own" / "study.toml"
    got = crashrig.study(study, out=tmp_path / "py", seed=2, samples=60, no_sensitivity=True)
    want = cli("study", study, "--out", tmp_path / "cli", "--seed", "2", "--samples", "60",
               "--no-sensitivity")
    assert strip_timing(got) == strip_timing(want)
    assert (tmp_path / "py" / "results.json").read_bytes() == (
        tmp_path / "cli" / "results.json"
    ).read_bytes()


# --- bad input: crashrig.Error with the command's message, or TypeError ---------------------


def test_missing_path_has_the_cli_message(cli, tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(crashrig.Error) as e:
        crashrig.propagate(missing)
    assert str(e.value) == cli.fail("propagate", missing)
    # A missing model path: the message of the command that reads a model (issue 36 §4: it
    # differed).
    with pytest.raises(crashrig.Error) as e:
        crashrig.read_model(tmp_path / "no_model")
    assert str(e.value) == cli.fail("colmap", "info", tmp_path / "no_model")
    assert str(e.value) == cli.fail("calibrate", tmp_path / "no_model", "--camera-a", "a/",
                                    "--camera-b", "b/", "--mm-per-unit", "1")
    assert str(e.value) == f"{tmp_path / 'no_model'}: does not exist"


def test_bad_camera_name(cli):
    model = FIXTURES / "rig" / "paper"
    with pytest.raises(crashrig.Error) as e:
        crashrig.calibrate(model, camera_a="nope/", camera_b="cam_in/")
    assert str(e.value) == cli.fail("calibrate", model, "--camera-a", "nope/", "--camera-b",
                                    "cam_in/")


def test_empty_selectors_name_their_keyword():
    """Issue 36: an empty selector would select every image; it is refused by its keyword."""
    paper = FIXTURES / "rig" / "paper"
    with pytest.raises(crashrig.Error, match="^camera_b: must name a camera"):
        crashrig.calibrate(paper, camera_a="cam_out/", camera_b="")
    with pytest.raises(crashrig.Error, match="^camera: must name a camera"):
        crashrig.covariance(paper, camera=" ", control_points=paper / "x.csv", mm_per_unit=1.0)
    with pytest.raises(crashrig.Error, match="^image_a: must name an image"):
        crashrig.bootstrap(TWOVIEW / "database.db", TWOVIEW / "model", "", "b")


def test_malformed_toml(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("samples = [\n")
    with pytest.raises(crashrig.Error) as e:
        crashrig.grid(bad)
    assert str(e.value) == cli.fail("grid", bad, "--out", tmp_path / "o")
    with pytest.raises(crashrig.Error, match="<scenario>:1"):
        crashrig.propagate("samples = [\n")
    with pytest.raises(crashrig.Error):
        crashrig.study("seed = 'x'\n", out=tmp_path / "s")


def test_wrong_types():
    with pytest.raises(TypeError):
        crashrig.read_model(42)
    with pytest.raises(TypeError):
        crashrig.propagate(3.5)
    with pytest.raises(TypeError):
        crashrig.grid(SCENARIOS / "three_cameras_z0.toml", samples="many")
    with pytest.raises(TypeError):
        crashrig.calibrate(FIXTURES / "rig" / "paper", camera_a=[1], camera_b="cam_in/")
    with pytest.raises(TypeError):
        crashrig.measure(SEQ / "model", **{**measure_kwargs(), "sigma_a_position_mm": 5.0})


def test_bad_values_are_errors(tmp_path):
    with pytest.raises(crashrig.Error, match="mm_per_unit"):
        crashrig.calibrate(FIXTURES / "rig" / "paper", "cam_out/", "cam_in/", mm_per_unit=-1.0)
    with pytest.raises(crashrig.Error, match="--samples"):
        crashrig.grid(SCENARIOS / "three_cameras_z0.toml", samples=1)
    with pytest.raises(crashrig.Error, match="method"):
        crashrig.bootstrap(TWOVIEW / "database.db", TWOVIEW / "model", "a", "b", method="x")
    with pytest.raises(crashrig.Error, match="camera_c and tie"):
        crashrig.measure(SEQ / "model", **{**measure_kwargs(), "tie": None})


def test_warnings_are_python_warnings(tmp_path):
    kw = measure_kwargs()
    del kw["a_covariance"]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        crashrig.measure(SEQ / "model", **kw)
    assert any("treated as exact" in str(x.message) for x in w)


def test_ctrl_c_stops_a_long_grid(tmp_path):
    """SIGINT during a long `grid` raises KeyboardInterrupt within seconds, not at the end."""
    import signal
    import subprocess
    import sys
    import time

    script = (
        "import crashrig, sys\n"
        "print('start', flush=True)\n"
        "try:\n"
        f"    crashrig.grid({str(SCENARIOS / 'four_cameras_z0.toml')!r}, samples=5000000, seed=1)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True); sys.exit(3)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "start"
    time.sleep(1.0)
    t = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 3 and "interrupted" in out
    assert time.monotonic() - t < 10
