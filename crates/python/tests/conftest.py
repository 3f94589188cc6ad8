"""Shared helpers: the repository root, the CLI binary the results are compared with."""

import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
FIXTURES = ROOT / "fixtures"

# Fields that are wall-clock measurements (or the thread count), never equal between runs.
TIMING = {"elapsed_s", "samples_per_second", "run_time_s", "time_s", "threads"}


def strip_timing(value):
    """The document without its timing fields (at any depth)."""
    if isinstance(value, dict):
        return {k: strip_timing(v) for k, v in value.items() if k not in TIMING}
    if isinstance(value, list):
        return [strip_timing(v) for v in value]
    return value


@pytest.fixture(scope="session")
def cli():
    """Runs the `crashrig` binary (CRASHRIG_BIN, default target/release/crashrig) and returns
    its parsed `--json` output."""
    binary = os.environ.get("CRASHRIG_BIN") or str(ROOT / "target" / "release" / "crashrig")
    if not os.path.exists(binary):
        pytest.fail(f"the CLI binary {binary} is missing: build it or set CRASHRIG_BIN")

    def run(*args):
        out = subprocess.run(
            [binary, *map(str, args), "--json"], capture_output=True, text=True, check=False
        )
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout)

    def fail(*args):
        out = subprocess.run([binary, *map(str, args)], capture_output=True, text=True, check=False)
        assert out.returncode != 0
        line = out.stderr.strip().splitlines()[-1]
        assert line.startswith("error: ")
        return line[len("error: "):]

    run.fail = fail
    return run
