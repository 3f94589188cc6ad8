"""Type stubs of the crashrig module (docs/PYTHON.md)."""

import os
from typing import Any, Callable, Dict, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
#: A path, or the TOML text itself (a ``str`` holding a newline or ``=``).
PathOrToml = Union[str, "os.PathLike[str]"]
#: An image-name prefix such as ``"cam_out/"``, or a camera id.
CameraRef = Union[str, int]
#: ``progress(stage, done, total)``, called on the calling thread about every 50 ms.
Progress = Callable[[str, int, int], Any]

class Error(ValueError):
    """Bad input or a failed step, with the command's ``error:`` text."""

class Camera:
    """A camera: COLMAP model name, image size, parameters in COLMAP's order."""
    @property
    def camera_id(self) -> int: ...
    @property
    def model(self) -> str: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def params(self) -> npt.NDArray[np.float64]: ...

class Image:
    """An image: name, camera, pose, 2-D points."""
    @property
    def image_id(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def camera_id(self) -> int: ...
    def cam_from_world(self) -> npt.NDArray[np.float64]:
        """The pose as a 3×4 matrix ``[R | t]``, pycolmap's ``cam_from_world().matrix()``
        (quaternions as stored, not normalised); raises :class:`Error` without a pose."""
    @property
    def points2D_xy(self) -> npt.NDArray[np.float64]: ...
    @property
    def point3D_ids(self) -> List[Optional[int]]: ...
    def num_points3D(self) -> int: ...

class Point3D:
    """A 3-D point: position, colour, mean reprojection error, track."""
    @property
    def point3D_id(self) -> int: ...
    @property
    def xyz(self) -> npt.NDArray[np.float64]: ...
    @property
    def color(self) -> npt.NDArray[np.uint8]: ...
    @property
    def error(self) -> float: ...
    @property
    def track(self) -> List[Tuple[int, int]]: ...

class Reconstruction:
    """A COLMAP sparse model, shaped like ``pycolmap.Reconstruction``."""
    @property
    def cameras(self) -> Dict[int, Camera]: ...
    @property
    def images(self) -> Dict[int, Image]: ...
    @property
    def points3D(self) -> Dict[int, Point3D]: ...
    @property
    def path(self) -> str: ...
    @property
    def format(self) -> str: ...
    def num_observations(self) -> int: ...

def read_model(path: PathLike) -> Reconstruction:
    """Reads a COLMAP model directory (binary or text).

    >>> m = crashrig.read_model("fixtures/paper/twoview/model")
    >>> m.images[1].cam_from_world().shape
    (3, 4)
    """

def calibrate(
    model: PathLike,
    camera_a: CameraRef,
    camera_b: CameraRef,
    *,
    scale_points: Optional[Sequence[int]] = None,
    scale_length_mm: Optional[float] = None,
    mm_per_unit: Optional[float] = None,
    max_lag: int = 10,
    refine: bool = True,
    accept_rig_constrained: bool = False,
    plots: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig calibrate --json``.

    >>> r = crashrig.calibrate("lab/model", camera_a="cam_out/", camera_b="cam_in/")
    """

def bootstrap(
    database: PathLike,
    model: PathLike,
    image_a: str,
    image_b: str,
    *,
    method: str = "absolute",
    iterations: int = 500,
    mm_per_unit: float = 1.0,
    max_error_px: float = 4.0,
    base_mm: Optional[float] = None,
    resample: str = "inliers",
    seed: Optional[int] = None,
    plots: Optional[PathLike] = None,
    replicates: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig bootstrap --json`` (seed 1 when not given, as the command); ``plots``: a
    folder for the histograms, ``replicates``: a CSV of every replicate (``--plots``,
    ``--replicates``).

    >>> t = crashrig.bootstrap("db.db", model="model", image_a="a.png", image_b="b.png", seed=1)
    """

def propagate(
    scenario: PathOrToml,
    *,
    samples: Optional[int] = None,
    seed: Optional[int] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig propagate --json``.

    >>> p = crashrig.propagate("fixtures/scenarios/paper_chain.toml", samples=2000, seed=1)
    """

def grid(
    scenario: PathOrToml,
    *,
    samples: Optional[int] = None,
    seed: Optional[int] = None,
    out: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, npt.NDArray[Any]]:
    """``crashrig grid``: one NumPy array per ``grid.csv`` column (empty cells are NaN).

    >>> import pandas
    >>> df = pandas.DataFrame(crashrig.grid("fixtures/scenarios/three_cameras_z0.toml", samples=500, seed=1))
    """

def measure(
    model: PathLike,
    camera_a: CameraRef,
    camera_b: CameraRef,
    link: PathLike,
    observations: PathLike,
    *,
    out: Optional[PathLike] = None,
    camera_c: Optional[CameraRef] = None,
    tie: Optional[PathLike] = None,
    mm_per_unit: Optional[float] = None,
    sigma_a_position_mm: Optional[Sequence[float]] = None,
    sigma_a_angles_deg: Optional[Sequence[float]] = None,
    a_covariance: Optional[PathLike] = None,
    pixel_sigma_px: Union[float, Literal["estimate"]] = 0.5,
    samples: int = 2000,
    seed: Optional[int] = None,
    reference_epoch: Optional[str] = None,
    frame_rate_hz: Optional[float] = None,
    threshold_mm: float = 5.0,
    max_reprojection_px: Optional[float] = None,
    plots: bool = True,
    cfc: Optional[int] = None,
    cfc_standard: Optional[str] = None,
    sync_sigma_ms: float = 0.0,
    scale_bars: Optional[PathLike] = None,
    mpe_mm: Optional[float] = None,
    frame_times: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig measure --json`` (seed 1 when not given, as the command).

    ``pixel_sigma_px="estimate"`` (with ``camera_c``) uses the pixel σ check's estimate in the
    Monte Carlo (``s["numbers"]["pixel_sigma_estimate"]``, ``--pixel-sigma-px estimate``);
    ``frame_times`` (CSV ``epoch,time_s``, as ``track`` writes it) is the time axis instead of
    ``frame_rate_hz`` (``--frame-times``).

    ``scale_bars`` (CSV ``name,marker_1,marker_2,length_mm,sigma_mm``) adds the length check:
    ``s["length_check"]``, one dict per bar with its verdict (``--scale-bars``); ``mpe_mm`` the
    maximum permissible error (``--mpe-mm``).

    >>> s = crashrig.measure("model", camera_a="cam_out/", camera_b="cam_in/", link="link.json",
    ...                      observations="obs.csv", mm_per_unit=1000.0, seed=1)
    """

def covariance(
    model: PathLike,
    camera: CameraRef,
    control_points: PathLike,
    *,
    out: Optional[PathLike] = None,
    mm_per_unit: Optional[float] = None,
    scale_points: Optional[Sequence[int]] = None,
    scale_length_mm: Optional[float] = None,
    pixel_sigma_px: Optional[float] = None,
    intrinsics: str = "all",
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig covariance --json``.

    >>> c = crashrig.covariance("model", camera="cam_out/", control_points="cp.csv", mm_per_unit=1.0)
    """

def study(
    study: PathOrToml,
    out: PathLike,
    *,
    seed: Optional[int] = None,
    samples: Optional[int] = None,
    no_sensitivity: bool = False,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig study --json``: runs the study, writes ``out``, returns results.json.

    >>> r = crashrig.study("fixtures/study/study.toml", out="study_out", seed=1)
    """

def place(
    scenario: PathOrToml,
    candidates: PathLike,
    choose: int,
    out: PathLike,
    *,
    samples: Optional[int] = None,
    seed: Optional[int] = None,
    plots: bool = True,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig place --json``: writes ``out`` (placement.json, grid/), returns placement.json.

    >>> p = crashrig.place("examples/place/scenario.toml", candidates="examples/place/candidates.toml",
    ...                    choose=2, out="place_out", samples=300, seed=3)
    """

def merge(
    shards: Sequence[PathLike],
    out: PathLike,
    *,
    plots: bool = True,
    progress: Optional[Progress] = None,
) -> Dict[str, Any]:
    """``crashrig merge --json``: the shard directories of a ``--shard i/N`` run merged into
    ``out``; returns the merged run's summary (grid shards: summary.json).

    >>> s = crashrig.merge(["shards/1", "shards/2"], out="grid_out")
    """
