"""progress= and cancellation of measure, covariance and merge: the callback sees monotone
reports that end at the total, results do not depend on it, and a callback that raises (or
Ctrl-C) stops the call through the library's cancellation with no output written."""

import pathlib
import signal
import subprocess
import sys
import time

import pytest

import crashrig
from conftest import FIXTURES, strip_timing
from test_commands import SEQ, measure_kwargs
from test_place_merge import shards

COV = FIXTURES / "covariance" / "mc"


def recorder():
    seen = []

    def cb(stage, done, total):
        seen.append((stage, done, total))

    return seen, cb


def assert_monotone(seen, stage, total):
    assert seen, "the callback was called"
    assert all(s == stage and t == total for s, _, t in seen), seen
    done = [d for _, d, _ in seen]
    assert done == sorted(done) and 0 < done[0], seen
    assert done[-1] == total, "the last report is the total"


def test_measure_progress_is_monotone_and_changes_nothing(tmp_path):
    kw = measure_kwargs()
    seen, cb = recorder()
    a = crashrig.measure(SEQ / "model", out=tmp_path / "a", progress=cb, **kw)
    b = crashrig.measure(SEQ / "model", out=tmp_path / "b", **kw)
    assert strip_timing(a) == strip_timing(b)
    for f in ("trajectories.csv", "displacements.csv"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()
    assert_monotone(seen, "replicates", kw["samples"])
    # With a sync σ the run is made twice: 2 × samples units.
    seen, cb = recorder()
    crashrig.measure(SEQ / "model", sync_sigma_ms=0.2, progress=cb, **kw)
    assert_monotone(seen, "replicates", 2 * kw["samples"])


def test_covariance_progress_and_a_raising_callback(tmp_path):
    args = dict(camera="cam_out/", control_points=COV / "control_points.csv", mm_per_unit=1000.0)
    seen, cb = recorder()
    a = crashrig.covariance(COV / "model", progress=cb, **args)
    assert a == crashrig.covariance(COV / "model", **args)
    assert_monotone(seen, "phases", 4)

    def stop(stage, done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        crashrig.covariance(COV / "model", out=tmp_path / "a.json", progress=stop, **args)
    assert not (tmp_path / "a.json").exists()


def test_merge_progress_counts_shards(cli, tmp_path):
    dirs = shards(cli, tmp_path, 3, FIXTURES / "scenarios" / "three_cameras_z0.toml",
                  "--samples", "100", "--seed", "3")
    seen, cb = recorder()
    a = crashrig.merge(dirs, out=tmp_path / "a", plots=False, progress=cb)
    b = crashrig.merge(dirs, out=tmp_path / "b", plots=False)
    assert strip_timing(a) == strip_timing(b)
    assert (tmp_path / "a" / "grid.csv").read_bytes() == (tmp_path / "b" / "grid.csv").read_bytes()
    assert_monotone(seen, "shards read", 3)


def test_a_raising_callback_stops_measure_with_no_output(tmp_path):
    calls = []

    def stop(stage, done, total):
        calls.append(done)
        raise KeyboardInterrupt

    kw = dict(measure_kwargs(), samples=1_000_000)
    t = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        crashrig.measure(SEQ / "model", out=tmp_path / "out", progress=stop, **kw)
    assert len(calls) == 1 and calls[0] < kw["samples"]
    assert time.monotonic() - t < 30, "stopped long before its end"
    assert not (tmp_path / "out").exists()


def test_ctrl_c_stops_a_long_measure_with_no_output(tmp_path):
    """SIGINT during a long `measure` raises KeyboardInterrupt within seconds; no output."""
    out = tmp_path / "out"
    kw = {k: (str(v) if isinstance(v, pathlib.PurePath) else v)
          for k, v in dict(measure_kwargs(), samples=1_000_000).items()}
    script = (
        "import crashrig, sys\n"
        "print('start', flush=True)\n"
        "try:\n"
        f"    crashrig.measure({str(SEQ / 'model')!r}, out={str(out)!r}, **{kw!r})\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True); sys.exit(3)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "start"
    time.sleep(1.0)
    t = time.monotonic()
    p.send_signal(signal.SIGINT)
    stdout, _ = p.communicate(timeout=60)
    assert p.returncode == 3 and "interrupted" in stdout
    assert time.monotonic() - t < 10
    assert not out.exists()
