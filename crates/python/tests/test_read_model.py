"""`read_model` against pycolmap on the bundled real models: the same ids, cameras, poses and
points."""

import pathlib

import numpy as np
import pytest

import crashrig
from conftest import FIXTURES

pycolmap = pytest.importorskip("pycolmap")


def model_dirs():
    """Every bundled COLMAP model directory (binary or text)."""
    found = set()
    for f in FIXTURES.rglob("cameras.*"):
        if f.suffix in (".bin", ".txt") and (f.parent / f"images{f.suffix}").exists():
            found.add(f.parent)
    return sorted(found)


MODELS = model_dirs()


def readable_by_pycolmap(d):
    try:
        return pycolmap.Reconstruction(str(d))
    except Exception:  # a fixture that only crashrig reads (e.g. a hand-written edge case)
        return None


def test_found_models():
    assert len(MODELS) >= 5


@pytest.mark.parametrize("d", MODELS, ids=lambda d: str(d.relative_to(FIXTURES)))
def test_read_model_matches_pycolmap(d):
    ref = readable_by_pycolmap(d)
    if ref is None:
        pytest.skip("pycolmap cannot read this fixture")
    m = crashrig.read_model(d)
    assert set(m.cameras) == set(ref.cameras)
    for cid, c in m.cameras.items():
        r = ref.cameras[cid]
        assert c.camera_id == cid
        assert c.model == r.model.name
        assert (c.width, c.height) == (r.width, r.height)
        np.testing.assert_array_equal(c.params, np.asarray(r.params))
    assert set(m.images) == set(ref.images)
    for iid, im in m.images.items():
        r = ref.images[iid]
        assert (im.image_id, im.name, im.camera_id) == (iid, r.name, r.camera_id)
        if r.has_pose:
            np.testing.assert_allclose(im.cam_from_world(), r.cam_from_world().matrix(),
                                       rtol=0, atol=1e-12)
        assert im.points2D_xy.shape == (len(r.points2D), 2)
        if len(r.points2D):
            np.testing.assert_array_equal(im.points2D_xy,
                                          np.array([p.xy for p in r.points2D]))
    assert set(m.points3D) == set(ref.points3D)
    for pid, p in m.points3D.items():
        r = ref.points3D[pid]
        np.testing.assert_array_equal(p.xyz, r.xyz)
        np.testing.assert_array_equal(p.color, r.color)
        assert p.error == r.error
        assert len(p.track) == r.track.length()


def test_read_model_shapes():
    m = crashrig.read_model(str(FIXTURES / "paper" / "twoview" / "model"))
    im = next(iter(m.images.values()))
    pose = im.cam_from_world()
    assert pose.shape == (3, 4) and pose.dtype == np.float64
    r = pose[:, :3]
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    p = next(iter(m.points3D.values()))
    assert p.xyz.shape == (3,)
    assert isinstance(pathlib.Path(m.path), pathlib.Path)


def _round_quaternions(path, first_quat_token, digits=7):
    """Rewrite a text model file with its quaternions rounded to `digits` significant digits
    (as a tool writing 7-digit text does): their norms are then 1 ± ~1e-7."""
    out = []
    for line in path.read_text().splitlines():
        toks = line.split(" ")
        if line and not line.startswith("#") and len(toks) > first_quat_token + 3:
            try:
                q = [float(t) for t in toks[first_quat_token:first_quat_token + 4]]
            except ValueError:
                out.append(line)
                continue
            toks[first_quat_token:first_quat_token + 4] = [f"{v:.{digits - 1}e}" for v in q]
            line = " ".join(toks)
        out.append(line)
    path.write_text("\n".join(out) + "\n")


@pytest.mark.parametrize("rigged", [False, True], ids=["legacy", "rigs_and_frames"])
def test_cam_from_world_of_non_unit_quaternions_is_pycolmaps(tmp_path, rigged):
    """A real model whose quaternions are not unit (written with 7 digits): pycolmap keeps them
    as read (COLMAP >= 3.11 normalises only where a computation needs it), so read_model gives
    the same numbers (issue 36 §4: they differed by up to 8.5e-7)."""
    src = FIXTURES / "colmap" / "rig_opencv" / "txt"
    d = tmp_path / "model"
    d.mkdir()
    for name in ("cameras.txt", "images.txt", "points3D.txt") + (
        ("rigs.txt", "frames.txt") if rigged else ()
    ):
        (d / name).write_bytes((src / name).read_bytes())
    if rigged:
        _round_quaternions(d / "frames.txt", 2)
        # rigs.txt: RIG_ID NUM_SENSORS REF_TYPE REF_ID, then TYPE ID HAS_POSE QW QX QY QZ ...
        _round_quaternions(d / "rigs.txt", 7)
    else:
        # images.txt: the image lines (IMAGE_ID QW QX QY QZ ...) alternate with their POINTS2D
        # lines (every image of this fixture has points): round the image lines' quaternions.
        lines = (d / "images.txt").read_text().splitlines()
        data = [i for i, l in enumerate(lines) if l and not l.startswith("#")]
        for i in data[::2]:
            toks = lines[i].split(" ")
            toks[1:5] = [f"{float(v):.6e}" for v in toks[1:5]]
            lines[i] = " ".join(toks)
        (d / "images.txt").write_text("\n".join(lines) + "\n")
    ref = pycolmap.Reconstruction(str(d))
    m = crashrig.read_model(d)
    worst_normalised = 0.0
    for iid, im in m.images.items():
        r = ref.images[iid]
        want = r.cam_from_world().matrix()
        np.testing.assert_allclose(im.cam_from_world(), want, rtol=0, atol=1e-15)
        # The normalised rotation (what the commands use) differs: this test sees the change.
        q = np.asarray(r.cam_from_world().rotation.quat)
        x, y, z, w = q / np.linalg.norm(q)
        rot = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])
        worst_normalised = max(worst_normalised, np.abs(rot - want[:, :3]).max())
    assert worst_normalised > 1e-8
