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
