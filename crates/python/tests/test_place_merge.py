"""`place`, `merge` and bootstrap's files against the CLI on the same inputs and seed: the same
dict as `--json` (timing fields aside) and byte-identical files."""

import pytest

import crashrig
from conftest import FIXTURES, ROOT, strip_timing

PLACE = ROOT / "examples" / "place"
SCENARIOS = FIXTURES / "scenarios"
TWOVIEW = FIXTURES / "paper" / "twoview"


def test_place_equals_cli(cli, tmp_path):
    got = crashrig.place(PLACE / "scenario.toml", candidates=PLACE / "candidates.toml", choose=2,
                         out=tmp_path / "py", samples=300, seed=3, plots=False)
    want = cli("place", PLACE / "scenario.toml", "--candidates", PLACE / "candidates.toml",
               "--choose", "2", "--out", tmp_path / "cli", "--samples", "300", "--seed", "3",
               "--no-plots")
    assert strip_timing(got) == strip_timing(want)
    assert len(got["chosen"]) == 2
    for name in ["grid/grid.csv"]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    # The scenario as TOML text gives the same placement.
    text = (PLACE / "scenario.toml").read_text()
    again = crashrig.place(text, candidates=PLACE / "candidates.toml", choose=2,
                           out=tmp_path / "text", samples=300, seed=3, plots=False)
    assert strip_timing(again) == strip_timing(got)


def test_place_bad_input_has_the_cli_message(cli, tmp_path):
    args = dict(candidates=PLACE / "candidates.toml", out=tmp_path / "py", samples=100)
    with pytest.raises(crashrig.Error) as e:
        crashrig.place(PLACE / "scenario.toml", choose=0, **args)
    assert str(e.value) == cli.fail("place", PLACE / "scenario.toml", "--candidates",
                                    args["candidates"], "--choose", "0", "--out",
                                    tmp_path / "cli", "--samples", "100")
    assert not (tmp_path / "py").exists()
    with pytest.raises(TypeError):
        crashrig.place(PLACE / "scenario.toml", choose="two", **args)


def shards(cli, tmp_path, n, scenario, *extra):
    dirs = [tmp_path / "shards" / str(i) for i in range(1, n + 1)]
    for i, d in enumerate(dirs, start=1):
        cli("grid", scenario, "--shard", f"{i}/{n}", "--out", d, *extra)
    return dirs


def test_merge_equals_cli(cli, tmp_path):
    scenario = SCENARIOS / "three_cameras_z0.toml"
    dirs = shards(cli, tmp_path, 3, scenario, "--samples", "300", "--seed", "3")
    got = crashrig.merge(dirs, out=tmp_path / "py", plots=False)
    want = cli("merge", *dirs, "--out", tmp_path / "cli", "--no-plots")
    assert strip_timing(got) == strip_timing(want)
    py_csv = (tmp_path / "py" / "grid.csv").read_bytes()
    assert py_csv == (tmp_path / "cli" / "grid.csv").read_bytes()
    # … and the unsharded run's grid.csv.
    cli("grid", scenario, "--out", tmp_path / "whole", "--samples", "300", "--seed", "3",
        "--no-plots")
    assert py_csv == (tmp_path / "whole" / "grid.csv").read_bytes()


def test_merge_bad_input_has_the_cli_message(cli, tmp_path):
    dirs = shards(cli, tmp_path, 2, SCENARIOS / "three_cameras_z0.toml", "--samples", "100")
    with pytest.raises(crashrig.Error) as e:
        crashrig.merge(dirs[:1], out=tmp_path / "py")
    assert str(e.value) == cli.fail("merge", dirs[0], "--out", tmp_path / "cli")
    with pytest.raises(crashrig.Error) as e:
        crashrig.merge([dirs[0], dirs[0]], out=tmp_path / "py")
    assert str(e.value) == cli.fail("merge", dirs[0], dirs[0], "--out", tmp_path / "cli")
    assert not (tmp_path / "py").exists()
    with pytest.raises(TypeError):
        crashrig.merge(str(dirs[0]), out=tmp_path / "py")


def test_bootstrap_plots_and_replicates_equal_cli(cli, tmp_path):
    got = crashrig.bootstrap(TWOVIEW / "database.db", model=TWOVIEW / "model",
                             image_a="cam_in/000001.png", image_b="cam_door/000001.png",
                             iterations=30, mm_per_unit=1000.0, seed=4, plots=tmp_path / "py",
                             replicates=tmp_path / "py.csv")
    want = cli("bootstrap", TWOVIEW / "database.db", "--model", TWOVIEW / "model", "--image-a",
               "cam_in/000001.png", "--image-b", "cam_door/000001.png", "--iterations", "30",
               "--mm-per-unit", "1000", "--seed", "4", "--plots", tmp_path / "cli",
               "--replicates", tmp_path / "cli.csv")
    assert strip_timing(got) == strip_timing(want)
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    names = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert len(names) == 12, names
    assert sorted(p.name for p in (tmp_path / "py").iterdir()) == names
    for name in names:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    rows = (tmp_path / "py.csv").read_text().splitlines()
    assert rows[0].startswith("replicate,") and len(rows) > 20, "a header and the replicates"


def test_merge_of_place_shards_equals_cli(cli, tmp_path):
    dirs = [tmp_path / "shards" / str(i) for i in (1, 2)]
    for i, d in enumerate(dirs, start=1):
        cli("place", PLACE / "scenario.toml", "--candidates", PLACE / "candidates.toml",
            "--choose", "2", "--out", d, "--samples", "200", "--seed", "3", "--shard", f"{i}/2")
    got = crashrig.merge(dirs, out=tmp_path / "py", plots=False)
    want = cli("merge", *dirs, "--out", tmp_path / "cli", "--no-plots")
    assert strip_timing(got) == strip_timing(want)
    assert len(got["chosen"]) == 2
    assert (tmp_path / "py" / "placement.json").is_file()
