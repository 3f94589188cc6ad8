"""crashrig: photogrammetric uncertainty for on-board crash-test camera rigs, from Python.

Every command of the ``crashrig`` tool is a function that calls the same Rust library and
returns the same dict as the command's ``--json`` (``grid``: the ``grid.csv`` columns as NumPy
arrays, ready for ``pandas.DataFrame``); ``read_model`` reads COLMAP models into objects shaped
like pycolmap's. Errors raise :class:`crashrig.Error` (a ``ValueError``) with the command's
``error:`` text. See ``docs/PYTHON.md``.

Example::

    import crashrig, pandas
    model = crashrig.read_model("fixtures/paper/twoview/model")
    grid = pandas.DataFrame(crashrig.grid("fixtures/scenarios/three_cameras_z0.toml",
                                          samples=500, seed=1))
"""

from ._crashrig import (  # noqa: F401
    Camera,
    Error,
    Image,
    Point3D,
    Reconstruction,
    __version__,
    bootstrap,
    calibrate,
    covariance,
    grid,
    measure,
    merge,
    place,
    propagate,
    read_model,
    study,
)

__all__ = [
    "Camera",
    "Error",
    "Image",
    "Point3D",
    "Reconstruction",
    "__version__",
    "bootstrap",
    "calibrate",
    "covariance",
    "grid",
    "measure",
    "merge",
    "place",
    "propagate",
    "read_model",
    "study",
]
