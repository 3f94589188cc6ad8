//! `crashrig.read_model(path)`: a COLMAP sparse model (text or binary, 3.x or ≥ 3.12) read by
//! `crashrig_colmap`, shaped like pycolmap's `Reconstruction`: `.cameras`, `.images` and
//! `.points3D` dicts keyed by `camera_id`, `image_id` and `point3D_id`, NumPy arrays for
//! numbers. The objects share the model read once (nothing is copied until asked for).

use crashrig_colmap::Reconstruction as Model;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;
use std::sync::Arc;

/// A COLMAP sparse model (`crashrig.read_model`).
#[pyclass(frozen, module = "crashrig", name = "Reconstruction")]
pub struct Reconstruction {
    model: Arc<Model>,
    cameras: PyOnceLock<Py<PyDict>>,
    images: PyOnceLock<Py<PyDict>>,
    points: PyOnceLock<Py<PyDict>>,
}

/// A camera of the model: COLMAP model name, image size and parameters in COLMAP's order.
#[pyclass(frozen, module = "crashrig", name = "Camera")]
pub struct Camera {
    model: Arc<Model>,
    index: usize,
}

/// An image of the model: name, camera, pose and 2-D points.
#[pyclass(frozen, module = "crashrig", name = "Image")]
pub struct Image {
    model: Arc<Model>,
    index: usize,
}

/// A 3-D point of the model: position, colour, error and track.
#[pyclass(frozen, module = "crashrig", name = "Point3D")]
pub struct Point3D {
    model: Arc<Model>,
    index: usize,
}

/// Reads a COLMAP sparse model directory (binary when `cameras.bin`, `images.bin` and
/// `points3D.bin` exist, else text).
///
/// Example:
///
/// ```python
/// m = crashrig.read_model("fixtures/paper/twoview/model")
/// cam = m.cameras[1]; print(cam.model, cam.params)
/// img = next(iter(m.images.values())); print(img.name, img.cam_from_world())
/// ```
///
/// Raises `crashrig.Error` naming the file (and record) when the model cannot be read.
#[pyfunction]
fn read_model(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Reconstruction> {
    let dir = crate::args::path(path, "read_model: path")?;
    let model = py.detach(|| Model::read(&dir)).map_err(crate::to_py_err)?;
    Ok(Reconstruction {
        model: Arc::new(model),
        cameras: PyOnceLock::new(),
        images: PyOnceLock::new(),
        points: PyOnceLock::new(),
    })
}

/// A dict `{id: object}` of `n` records, built once and shared.
fn dict<'py, K, T>(
    py: Python<'py>,
    cell: &PyOnceLock<Py<PyDict>>,
    n: usize,
    key: impl Fn(usize) -> K,
    item: impl Fn(usize) -> T,
) -> PyResult<Bound<'py, PyDict>>
where
    K: IntoPyObject<'py>,
    T: pyo3::PyClass + Into<pyo3::PyClassInitializer<T>>,
{
    let d = cell.get_or_try_init(py, || -> PyResult<Py<PyDict>> {
        let d = PyDict::new(py);
        for i in 0..n {
            d.set_item(key(i), Bound::new(py, item(i))?)?;
        }
        Ok(d.unbind())
    })?;
    Ok(d.bind(py).clone())
}

#[pymethods]
impl Reconstruction {
    /// `{camera_id: Camera}`.
    #[getter]
    fn cameras<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        dict(
            py,
            &self.cameras,
            m.cameras().len(),
            |i| m.cameras()[i].camera_id,
            |index| Camera {
                model: m.clone(),
                index,
            },
        )
    }

    /// `{image_id: Image}`.
    #[getter]
    fn images<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        dict(
            py,
            &self.images,
            m.images().len(),
            |i| m.images()[i].image_id,
            |index| Image {
                model: m.clone(),
                index,
            },
        )
    }

    /// `{point3D_id: Point3D}`.
    #[getter(points3D)]
    fn points3d<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        dict(
            py,
            &self.points,
            m.points3d().len(),
            |i| m.points3d()[i].point3d_id,
            |index| Point3D {
                model: m.clone(),
                index,
            },
        )
    }

    /// The model directory.
    #[getter]
    fn path(&self) -> std::path::PathBuf {
        self.model.dir().to_path_buf()
    }

    /// `"binary"` or `"text"`.
    #[getter]
    fn format(&self) -> &'static str {
        match self.model.format() {
            crashrig_colmap::ModelFormat::Binary => "binary",
            crashrig_colmap::ModelFormat::Text => "text",
        }
    }

    /// Number of image observations of 3-D points.
    fn num_observations(&self) -> usize {
        self.model.num_observations()
    }

    fn __repr__(&self) -> String {
        format!(
            "Reconstruction(num_cameras={}, num_images={}, num_points3D={})",
            self.model.cameras().len(),
            self.model.images().len(),
            self.model.points3d().len()
        )
    }
}

#[pymethods]
impl Camera {
    /// The camera id.
    #[getter]
    fn camera_id(&self) -> u32 {
        self.model.cameras()[self.index].camera_id
    }

    /// COLMAP's model name, e.g. `"SIMPLE_RADIAL"`.
    #[getter]
    fn model(&self) -> &'static str {
        self.model.cameras()[self.index].camera.model.name()
    }

    /// Image width (px).
    #[getter]
    fn width(&self) -> u64 {
        self.model.cameras()[self.index].camera.width
    }

    /// Image height (px).
    #[getter]
    fn height(&self) -> u64 {
        self.model.cameras()[self.index].camera.height
    }

    /// The parameters in COLMAP's order (NumPy float64).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.model.cameras()[self.index].camera.params)
    }

    fn __repr__(&self) -> String {
        let c = &self.model.cameras()[self.index];
        format!(
            "Camera(camera_id={}, model={}, width={}, height={}, params={:?})",
            c.camera_id,
            c.camera.model.name(),
            c.camera.width,
            c.camera.height,
            c.camera.params
        )
    }
}

#[pymethods]
impl Image {
    /// The image id.
    #[getter]
    fn image_id(&self) -> u32 {
        self.model.images()[self.index].image_id
    }

    /// The image name (its path below the image folder).
    #[getter]
    fn name(&self) -> String {
        self.model.images()[self.index].name.clone()
    }

    /// The camera id.
    #[getter]
    fn camera_id(&self) -> u32 {
        self.model.images()[self.index].camera_id
    }

    /// The pose `cam_from_world` as a 3×4 NumPy matrix `[R | t]`, the numbers of pycolmap's
    /// `image.cam_from_world().matrix()` (for a model with rigs and frames,
    /// `sensor_from_rig ∘ rig_from_world`): COLMAP keeps the quaternions as stored on reading
    /// (it normalises them only where a computation assumes a unit quaternion, as crashrig's
    /// commands do), so for a model written with rounded quaternions `R` is not exactly a
    /// rotation, here as in pycolmap.
    ///
    /// Raises `crashrig.Error` when the image has no pose.
    fn cam_from_world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let im = &self.model.images()[self.index];
        let m = self
            .model
            .image_cam_from_world_colmap(im.image_id)
            .ok_or_else(|| {
                crate::py_error(format!(
                    "{}: image {} ({:?}) has no pose",
                    self.model.dir().display(),
                    im.image_id,
                    im.name
                ))
            })?;
        let rows: Vec<f64> = m.iter().flatten().copied().collect();
        PyArray1::from_vec(py, rows).reshape([3, 4])
    }

    /// The 2-D points' pixel coordinates, an N×2 NumPy array (COLMAP convention).
    #[getter(points2D_xy)]
    fn points2d_xy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pts = &self.model.images()[self.index].points2d;
        let xy: Vec<f64> = pts.iter().flat_map(|p| p.xy).collect();
        PyArray1::from_vec(py, xy).reshape([pts.len(), 2])
    }

    /// The point3D id of each 2-D point (`None` where it observes no 3-D point).
    #[getter(point3D_ids)]
    fn point3d_ids(&self) -> Vec<Option<u64>> {
        self.model.images()[self.index]
            .points2d
            .iter()
            .map(|p| p.point3d_id)
            .collect()
    }

    /// Number of 2-D points that observe a 3-D point.
    #[pyo3(name = "num_points3D")]
    fn num_points3d(&self) -> usize {
        self.model.images()[self.index].num_points3d()
    }

    fn __repr__(&self) -> String {
        let im = &self.model.images()[self.index];
        format!(
            "Image(image_id={}, camera_id={}, name={:?}, num_points2D={})",
            im.image_id,
            im.camera_id,
            im.name,
            im.points2d.len()
        )
    }
}

#[pymethods]
impl Point3D {
    /// The point3D id.
    #[getter(point3D_id)]
    fn point3d_id(&self) -> u64 {
        self.model.points3d()[self.index].point3d_id
    }

    /// Position (model units), NumPy float64 of 3.
    #[getter]
    fn xyz<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.model.points3d()[self.index].xyz)
    }

    /// Colour (R, G, B), NumPy uint8 of 3.
    #[getter]
    fn color<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        PyArray1::from_slice(py, &self.model.points3d()[self.index].rgb)
    }

    /// Mean reprojection error (px).
    #[getter]
    fn error(&self) -> f64 {
        self.model.points3d()[self.index].error
    }

    /// The track: `(image_id, point2D_idx)` pairs.
    #[getter]
    fn track(&self) -> Vec<(u32, u32)> {
        self.model.points3d()[self.index]
            .track
            .iter()
            .map(|t| (t.image_id, t.point2d_idx))
            .collect()
    }

    fn __repr__(&self) -> String {
        let p = &self.model.points3d()[self.index];
        format!(
            "Point3D(point3D_id={}, xyz={:?}, track_length={})",
            p.point3d_id,
            p.xyz,
            p.track.len()
        )
    }
}

/// Adds the classes and `read_model` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Reconstruction>()?;
    m.add_class::<Camera>()?;
    m.add_class::<Image>()?;
    m.add_class::<Point3D>()?;
    m.add_function(wrap_pyfunction!(read_model, m)?)?;
    Ok(())
}
