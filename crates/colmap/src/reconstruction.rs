//! [`Reconstruction`]: a whole sparse model, read with COLMAP's rules and checked.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use crashrig_geometry::Rigid3;

use crate::error::{Error, Result};
use crate::record::{CameraRecord, DataId, Frame, Image, Point3D, Rig, SensorId, SensorType};
use crate::{binary, text};

/// On-disk flavour of a sparse model (serialised as its [`ModelFormat::name`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "commands",
    derive(serde::Serialize),
    serde(rename_all = "lowercase")
)]
pub enum ModelFormat {
    /// `*.bin` files.
    Binary,
    /// `*.txt` files.
    Text,
}

impl ModelFormat {
    /// File extension without the dot (`bin` or `txt`).
    pub fn extension(self) -> &'static str {
        match self {
            ModelFormat::Binary => "bin",
            ModelFormat::Text => "txt",
        }
    }

    /// `"binary"` or `"text"` (the `format` field of `crashrig colmap info --json`).
    pub fn name(self) -> &'static str {
        match self {
            ModelFormat::Binary => "binary",
            ModelFormat::Text => "text",
        }
    }
}

/// The five file stems, in COLMAP's write order.
const STEMS: [&str; 5] = ["rigs", "cameras", "frames", "images", "points3D"];

/// Paths of the five files of a model in `dir`.
struct Files {
    rigs: PathBuf,
    cameras: PathBuf,
    frames: PathBuf,
    images: PathBuf,
    points3d: PathBuf,
}

impl Files {
    fn new(dir: &Path, format: ModelFormat) -> Files {
        let f = |stem: &str| dir.join(format!("{stem}.{}", format.extension()));
        Files {
            rigs: f("rigs"),
            cameras: f("cameras"),
            frames: f("frames"),
            images: f("images"),
            points3d: f("points3D"),
        }
    }
}

/// A COLMAP sparse model: cameras, rigs, frames, images and 3-D points, as COLMAP reads them.
///
/// Records keep their file order and their stored values (poses are not normalized in the
/// records, so writing reproduces the input bit for bit); derived poses are normalized
/// [`Rigid3`]s. A legacy (3.x, three-file) model gets one trivial rig per camera and one frame
/// per image, exactly as COLMAP builds them.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    dir: PathBuf,
    format: ModelFormat,
    legacy: bool,
    cameras: Vec<CameraRecord>,
    rigs: Vec<Rig>,
    frames: Vec<Frame>,
    images: Vec<Image>,
    points: Vec<Point3D>,
    camera_idx: HashMap<u32, usize>,
    rig_idx: HashMap<u32, usize>,
    frame_idx: HashMap<u32, usize>,
    image_idx: HashMap<u32, usize>,
    name_idx: HashMap<String, usize>,
    point_idx: HashMap<u64, usize>,
    image_frame: Vec<usize>,
    cam_from_world: Vec<Option<Rigid3>>,
    num_observations: usize,
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    use crashrig_input::file;
    file::read_limited(path, file::MAX_MODEL_FILE_BYTES).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn parse<T>(
    path: &Path,
    format: ModelFormat,
    bin: fn(&Path, &[u8]) -> Result<T>,
    txt: fn(&Path, &str) -> Result<T>,
) -> Result<T> {
    let bytes = read_file(path)?;
    match format {
        ModelFormat::Binary => bin(path, &bytes),
        ModelFormat::Text => txt(path, text::decode(path, &bytes)?),
    }
}

impl Reconstruction {
    /// Reads the model in `dir` like COLMAP: binary when `cameras.bin`, `images.bin` and
    /// `points3D.bin` all exist, else text; rigs and frames when both exist, else legacy (also
    /// legacy, as in COLMAP, when both files exist but hold no record).
    /// Then checks the cross-file invariants (see the crate docs).
    ///
    /// # Errors
    /// [`Error::Missing`], [`Error::NotAModel`], [`Error::RigsWithoutFrames`], any parse error of a file, or
    /// [`Error::Invariant`] naming the file and record that breaks a rule.
    pub fn read(dir: &Path) -> Result<Reconstruction> {
        // A path that is not there: said so (the CLI and the Python module say the same).
        if std::fs::symlink_metadata(dir).is_err() {
            return Err(Error::Missing {
                path: dir.to_path_buf(),
            });
        }
        let complete =
            |f: &Files| f.cameras.is_file() && f.images.is_file() && f.points3d.is_file();
        let format = if complete(&Files::new(dir, ModelFormat::Binary)) {
            ModelFormat::Binary
        } else if complete(&Files::new(dir, ModelFormat::Text)) {
            ModelFormat::Text
        } else {
            return Err(Error::NotAModel {
                path: dir.to_path_buf(),
            });
        };
        let files = Files::new(dir, format);
        let legacy = match (files.rigs.is_file(), files.frames.is_file()) {
            (true, true) => false,
            (false, false) => true,
            _ => {
                return Err(Error::RigsWithoutFrames {
                    path: dir.to_path_buf(),
                });
            }
        };
        let cameras = parse(
            &files.cameras,
            format,
            binary::read_cameras,
            text::read_cameras,
        )?;
        let (rigs, frames) = if legacy {
            (Vec::new(), Vec::new())
        } else {
            (
                parse(&files.rigs, format, binary::read_rigs, text::read_rigs)?,
                parse(
                    &files.frames,
                    format,
                    binary::read_frames,
                    text::read_frames,
                )?,
            )
        };
        let images = parse(
            &files.images,
            format,
            binary::read_images,
            text::read_images,
        )?;
        let points = parse(
            &files.points3d,
            format,
            binary::read_points3d,
            text::read_points3d,
        )?;
        // COLMAP takes the legacy path whenever no rig and no frame was loaded, files or not.
        let legacy = legacy || (rigs.is_empty() && frames.is_empty());
        Self::build(dir, format, legacy, cameras, rigs, frames, images, points).map_err(|e| {
            if format == ModelFormat::Text {
                text::with_line(e)
            } else {
                e
            }
        })
    }

    /// Builds and checks a model from records (e.g. a synthetic scene to write). With no rigs
    /// and no frames the model is legacy and gets COLMAP's trivial rigs and frames. Errors name
    /// the would-be files in the current directory; [`Reconstruction::format`] is `Binary`.
    ///
    /// # Errors
    /// As [`Reconstruction::read`] for the invariants.
    pub fn from_records(
        cameras: Vec<CameraRecord>,
        rigs: Vec<Rig>,
        frames: Vec<Frame>,
        images: Vec<Image>,
        points: Vec<Point3D>,
    ) -> Result<Reconstruction> {
        let legacy = rigs.is_empty() && frames.is_empty();
        Self::build(
            Path::new(""),
            ModelFormat::Binary,
            legacy,
            cameras,
            rigs,
            frames,
            images,
            points,
        )
    }

    /// Checks the records of a model and indexes them (the steps below, in this order, so the
    /// first broken rule in file order is the one reported).
    #[allow(clippy::too_many_arguments)]
    fn build(
        dir: &Path,
        format: ModelFormat,
        legacy: bool,
        cameras: Vec<CameraRecord>,
        mut rigs: Vec<Rig>,
        mut frames: Vec<Frame>,
        images: Vec<Image>,
        points: Vec<Point3D>,
    ) -> Result<Reconstruction> {
        let files = Files::new(dir, format);
        crate::bounds::check(
            (&cameras, &files.cameras),
            (&rigs, &files.rigs),
            (!legacy).then_some((frames.as_slice(), files.frames.as_path())),
            (&images, &files.images),
            (&points, &files.points3d),
        )?;
        if legacy {
            (rigs, frames) = trivial_rigs_and_frames(&cameras, &images);
        }
        // The synthesized rigs/frames of a legacy model come from cameras/images.
        let (rigs_path, frames_path) = if legacy {
            (&files.cameras, &files.images)
        } else {
            (&files.rigs, &files.frames)
        };
        let camera_idx = index_cameras(&cameras, &files.cameras)?;
        let rig_idx = index_rigs(&rigs, &camera_idx, rigs_path)?;
        let ImageIndex {
            by_id: image_idx,
            by_name: name_idx,
            num_observations,
        } = index_images(&images, &camera_idx, &files.images)?;
        let point_idx = index_points(&points, &files.points3d)?;
        let links = Links {
            rigs: &rigs,
            rig_idx: &rig_idx,
            images: &images,
            image_idx: &image_idx,
        };
        let (frame_idx, image_frame) = index_frames(&frames, &links, frames_path)?;
        let cam_from_world = images_cam_from_world(&frames, &links, &image_frame, &files.images)?;
        check_tracks(&points, &point_idx, &links, num_observations, &files)?;

        Ok(Reconstruction {
            dir: dir.to_path_buf(),
            format,
            legacy,
            cameras,
            rigs,
            frames,
            images,
            points,
            camera_idx,
            rig_idx,
            frame_idx,
            image_idx,
            name_idx,
            point_idx,
            image_frame,
            cam_from_world,
            num_observations,
        })
    }

    /// The five files of the model in COLMAP ≥ 3.12 layout and `format`: `(file name, bytes)`
    /// for rigs, cameras, frames, images and points3D. Stored values are written unchanged, so
    /// a read followed by a write reproduces binary input byte for byte, and text written from
    /// binary reads back bit-exactly (`%.17g`). `colmap convert` writes them into its staged
    /// output directory; [`Reconstruction::write`] into a directory.
    ///
    /// # Errors
    /// [`Error::Unwritable`] (naming the file by its name) for an image name that the format
    /// cannot hold.
    pub fn encode(&self, format: ModelFormat) -> Result<Vec<(String, Vec<u8>)>> {
        // Binary names end at a NUL byte. Text pairs lines and trims them: a name must be one
        // non-empty line without leading or trailing whitespace to read back unchanged (inner
        // spaces are fine for our reader; COLMAP's keeps only the first word).
        for (i, im) in self.images.iter().enumerate() {
            let n = &im.name;
            let text_ok = !n.is_empty() && !n.contains(['\n', '\r']) && n.trim() == n;
            if n.contains('\0') || (format == ModelFormat::Text && !text_ok) {
                return Err(Error::Unwritable {
                    path: PathBuf::from(format!("images.{}", format.extension())),
                    record: i,
                    what: "image name has a NUL byte, or (text) is empty, has a line break or \
                           leading/trailing whitespace",
                });
            }
        }
        let mean_obs = if self.images.is_empty() {
            0.0
        } else {
            self.num_observations as f64 / self.images.len() as f64
        };
        let track_total: usize = self.points.iter().map(|p| p.track.len()).sum();
        let mean_track = if self.points.is_empty() {
            0.0
        } else {
            track_total as f64 / self.points.len() as f64
        };
        let contents: [Vec<u8>; 5] = match format {
            ModelFormat::Binary => [
                binary::write_rigs(&self.rigs),
                binary::write_cameras(&self.cameras),
                binary::write_frames(&self.frames),
                binary::write_images(&self.images),
                binary::write_points3d(&self.points),
            ],
            ModelFormat::Text => [
                text::write_rigs(&self.rigs).into_bytes(),
                text::write_cameras(&self.cameras).into_bytes(),
                text::write_frames(&self.frames).into_bytes(),
                text::write_images(&self.images, mean_obs).into_bytes(),
                text::write_points3d(&self.points, mean_track).into_bytes(),
            ],
        };
        Ok(STEMS
            .iter()
            .zip(contents)
            .map(|(stem, bytes)| (format!("{stem}.{}", format.extension()), bytes))
            .collect())
    }

    /// Writes all five files of [`Reconstruction::encode`] into `dir` (created if missing).
    /// Each file goes to a temporary file in `dir` first; the renames happen only after all
    /// five were written.
    ///
    /// # Errors
    /// [`Error::Io`] naming the directory or file; [`Error::Unwritable`] for an image name
    /// that text cannot hold (checked before anything is written).
    pub fn write(&self, dir: &Path, format: ModelFormat) -> Result<()> {
        let contents = self.encode(format).map_err(|e| match e {
            Error::Unwritable { path, record, what } => Error::Unwritable {
                path: dir.join(path),
                record,
                what,
            },
            other => other,
        })?;
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let mut temps = Vec::with_capacity(5);
        for (name, bytes) in &contents {
            let target = dir.join(name);
            let io = |source| Error::Io {
                path: target.clone(),
                source,
            };
            let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(io)?;
            tmp.write_all(bytes).map_err(io)?;
            // tempfile creates 0600; model files are ordinary files (0644, like COLMAP's).
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                tmp.as_file()
                    .set_permissions(std::fs::Permissions::from_mode(0o644))
                    .map_err(io)?;
            }
            tmp.as_file().sync_all().map_err(io)?;
            temps.push((tmp, target));
        }
        // Rename all five into place; if one rename fails, remove the ones already renamed so
        // a failed write never leaves a mixed model behind.
        let mut done: Vec<PathBuf> = Vec::with_capacity(temps.len());
        for (tmp, target) in temps {
            if let Err(e) = tmp.persist(&target) {
                for d in &done {
                    let _ = std::fs::remove_file(d);
                }
                return Err(Error::Io {
                    path: target,
                    source: e.error,
                });
            }
            done.push(target);
        }
        Ok(())
    }

    /// The directory the model was read from (empty for [`Reconstruction::from_records`]).
    pub fn dir(&self) -> &Path {
        &self.dir
    }
    /// Binary or text, as read.
    pub fn format(&self) -> ModelFormat {
        self.format
    }
    /// `true` when the model had no rigs/frames files, or both were empty (trivial rigs and
    /// frames were built, as COLMAP does).
    pub fn is_legacy(&self) -> bool {
        self.legacy
    }
    /// Cameras in file order.
    pub fn cameras(&self) -> &[CameraRecord] {
        &self.cameras
    }
    /// The camera with this id.
    pub fn camera(&self, camera_id: u32) -> Option<&CameraRecord> {
        self.camera_idx.get(&camera_id).map(|&i| &self.cameras[i])
    }
    /// Rigs in file order (synthesized for a legacy model: one per camera, `rig_id = camera_id`).
    pub fn rigs(&self) -> &[Rig] {
        &self.rigs
    }
    /// The rig with this id.
    pub fn rig(&self, rig_id: u32) -> Option<&Rig> {
        self.rig_idx.get(&rig_id).map(|&i| &self.rigs[i])
    }
    /// Frames in file order (synthesized for a legacy model: one per image, same id).
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }
    /// The frame with this id.
    pub fn frame(&self, frame_id: u32) -> Option<&Frame> {
        self.frame_idx.get(&frame_id).map(|&i| &self.frames[i])
    }
    /// Images in file order (COLMAP writes them in registration order, not sorted by id).
    pub fn images(&self) -> &[Image] {
        &self.images
    }
    /// The image with this id.
    pub fn image(&self, image_id: u32) -> Option<&Image> {
        self.image_idx.get(&image_id).map(|&i| &self.images[i])
    }
    /// The first image with this name: the exact name, else the first whose name is equal in
    /// Unicode normal form C (`Cópia` typed composed finds a name stored decomposed).
    pub fn image_by_name(&self, name: &str) -> Option<&Image> {
        if let Some(&i) = self.name_idx.get(name) {
            return Some(&self.images[i]);
        }
        let want = crate::select::nfc(name);
        self.images
            .iter()
            .find(|im| crate::select::nfc(&im.name) == want)
    }

    /// The names of the model's images nearest to `name` (Levenshtein distance in Unicode
    /// normal form C, ties in file order), at most `shown`: for the error when
    /// [`Reconstruction::image_by_name`] finds nothing.
    pub fn nearest_image_names(&self, name: &str, shown: usize) -> Vec<&str> {
        let want = crate::select::nfc(name);
        let mut by_distance: Vec<(usize, usize, &str)> = self
            .images
            .iter()
            .enumerate()
            .map(|(k, im)| {
                let d = strsim::levenshtein(&crate::select::nfc(&im.name), &want);
                (d, k, im.name.as_str())
            })
            .collect();
        by_distance.sort_unstable();
        by_distance.into_iter().take(shown).map(|t| t.2).collect()
    }
    /// Names of images that COLMAP's text format cannot hold: a name containing ASCII
    /// whitespace (COLMAP and pycolmap read an `images.txt` name up to the first blank, and
    /// blanks at either end are lost in any reader), in file order. Empty when the model
    /// round-trips through `--to txt`.
    pub fn names_unsafe_for_text(&self) -> Vec<&str> {
        self.images
            .iter()
            .map(|im| im.name.as_str())
            .filter(|n| n.chars().any(|c| c.is_ascii_whitespace()))
            .collect()
    }
    /// One line for stderr when [`Reconstruction::names_unsafe_for_text`] is not empty: how
    /// many names, the first one, and that the binary format keeps them.
    pub fn text_format_warning(&self) -> Option<String> {
        let bad = self.names_unsafe_for_text();
        let first = bad.first()?;
        Some(format!(
            "{} image name(s) contain whitespace, which COLMAP's text format cannot hold \
             (COLMAP and pycolmap read a name only up to its first blank), first {first:?}; \
             the binary format keeps them",
            bad.len()
        ))
    }
    /// The frame that contains this image.
    pub fn image_frame(&self, image_id: u32) -> Option<&Frame> {
        let i = *self.image_idx.get(&image_id)?;
        self.frames.get(*self.image_frame.get(i)?)
    }
    /// `cam_from_world` of an image, as COLMAP computes it: `sensor_from_rig ∘ rig_from_world`
    /// of its frame (for a legacy model, the stored image pose), quaternions normalized.
    /// `None` when the image does not exist or its camera's `sensor_from_rig` is unknown.
    pub fn image_cam_from_world(&self, image_id: u32) -> Option<Rigid3> {
        let i = *self.image_idx.get(&image_id)?;
        self.cam_from_world.get(i).copied().flatten()
    }
    /// The 3×4 matrix `[R | t]` of an image's `cam_from_world` exactly as COLMAP and pycolmap
    /// give it (`Image::CamFromWorld().ToMatrix()`): `sensor_from_rig ∘ rig_from_world` of its
    /// frame composed with COLMAP's formulas from the quaternions as stored, which COLMAP does
    /// not normalise on reading ([`crate::RawPose::colmap_matrix`]); the rotation of
    /// [`Reconstruction::image_cam_from_world`] is the normalised one the commands use. For a
    /// model written with unit quaternions both agree to rounding. `None` as for
    /// [`Reconstruction::image_cam_from_world`].
    pub fn image_cam_from_world_colmap(&self, image_id: u32) -> Option<[[f64; 4]; 3]> {
        let i = *self.image_idx.get(&image_id)?;
        self.cam_from_world.get(i).copied().flatten()?;
        let im = &self.images[i];
        let frame = self.frames.get(*self.image_frame.get(i)?)?;
        let rig = self.rig(frame.rig_id)?;
        let sensor = SensorId::camera(im.camera_id);
        let pose = if rig.ref_sensor == Some(sensor) {
            frame.rig_from_world
        } else {
            rig.sensor_from_rig(sensor)??
                .colmap_compose(&frame.rig_from_world)
        };
        Some(pose.colmap_matrix())
    }

    /// How far the pose stored in `images.*` is from the pose COLMAP uses (composed from the
    /// frame and rig): `(rotation angle in rad, translation difference in model units)`. COLMAP
    /// ignores the stored pose when rigs and frames exist, and some tools have written
    /// inconsistent ones (colmap#4752); both are `0` for a legacy model. `None` when the image
    /// does not exist or either pose is unavailable.
    pub fn stored_pose_deviation(&self, image_id: u32) -> Option<(f64, f64)> {
        let used = self.image_cam_from_world(image_id)?;
        let stored = self.image(image_id)?.stored_cam_from_world.to_rigid()?;
        let angle = used.rotation.angle_to(&stored.rotation);
        let dt = (used.translation.vector - stored.translation.vector).norm();
        Some((angle, dt))
    }

    /// 3-D points in file order.
    pub fn points3d(&self) -> &[Point3D] {
        &self.points
    }
    /// The 3-D point with this id.
    pub fn point3d(&self, point3d_id: u64) -> Option<&Point3D> {
        self.point_idx.get(&point3d_id).map(|&i| &self.points[i])
    }
    /// Number of 2-D points observing a 3-D point (= total track length after the checks).
    pub fn num_observations(&self) -> usize {
        self.num_observations
    }
    /// The data ids of a frame that are images present in the model.
    pub fn frame_images(&self, frame: &Frame) -> Vec<&Image> {
        frame
            .data_ids
            .iter()
            .filter(|d: &&DataId| d.sensor.sensor_type == SensorType::Camera)
            .filter_map(|d| u32::try_from(d.id).ok().and_then(|id| self.image(id)))
            .collect()
    }
}

/// [`Error::Invariant`] for record `record` of the file `path`.
fn invariant(path: &Path, record: usize, what: &'static str, id: u64) -> Error {
    Error::Invariant {
        path: path.to_path_buf(),
        record,
        line: None,
        what,
        id,
    }
}

/// COLMAP's rigs and frames of a legacy model: one rig per camera (the camera its reference
/// sensor), one frame per image (the image's stored pose as `rig_from_world`).
fn trivial_rigs_and_frames(cameras: &[CameraRecord], images: &[Image]) -> (Vec<Rig>, Vec<Frame>) {
    let rigs = cameras
        .iter()
        .map(|c| Rig {
            rig_id: c.camera_id,
            ref_sensor: Some(SensorId::camera(c.camera_id)),
            sensors: Vec::new(),
        })
        .collect();
    let frames = images
        .iter()
        .map(|im| Frame {
            frame_id: im.image_id,
            rig_id: im.camera_id,
            rig_from_world: im.stored_cam_from_world,
            data_ids: vec![im.data_id()],
        })
        .collect();
    (rigs, frames)
}

/// Camera id → index; camera ids are unique.
fn index_cameras(cameras: &[CameraRecord], path: &Path) -> Result<HashMap<u32, usize>> {
    let mut camera_idx = HashMap::with_capacity(cameras.len());
    for (i, c) in cameras.iter().enumerate() {
        if camera_idx.insert(c.camera_id, i).is_some() {
            return Err(invariant(
                path,
                i,
                "duplicate camera id",
                c.camera_id.into(),
            ));
        }
    }
    Ok(camera_idx)
}

/// Rig id → index; rig ids are unique, camera sensors exist, `sensor_from_rig` poses are valid.
fn index_rigs(
    rigs: &[Rig],
    camera_idx: &HashMap<u32, usize>,
    path: &Path,
) -> Result<HashMap<u32, usize>> {
    let mut rig_idx = HashMap::with_capacity(rigs.len());
    for (i, r) in rigs.iter().enumerate() {
        if rig_idx.insert(r.rig_id, i).is_some() {
            return Err(invariant(path, i, "duplicate rig id", r.rig_id.into()));
        }
        let sensors = r
            .ref_sensor
            .iter()
            .chain(r.sensors.iter().map(|s| &s.sensor));
        for s in sensors {
            if s.sensor_type == SensorType::Camera && !camera_idx.contains_key(&s.id) {
                return Err(invariant(
                    path,
                    i,
                    "rig sensor is a missing camera",
                    s.id.into(),
                ));
            }
        }
        for s in &r.sensors {
            if s.sensor_from_rig.is_some_and(|p| p.to_rigid().is_none()) {
                return Err(invariant(
                    path,
                    i,
                    "sensor_from_rig is not a valid pose",
                    r.rig_id.into(),
                ));
            }
        }
    }
    Ok(rig_idx)
}

/// The indices of the images.
struct ImageIndex {
    /// Image id → index.
    by_id: HashMap<u32, usize>,
    /// Name → index of the first image of that name.
    by_name: HashMap<String, usize>,
    /// Observations of 3-D points, all images together.
    num_observations: usize,
}

/// Indexes the images; image ids are unique and images name existing cameras.
fn index_images(
    images: &[Image],
    camera_idx: &HashMap<u32, usize>,
    path: &Path,
) -> Result<ImageIndex> {
    let mut image_idx = HashMap::with_capacity(images.len());
    let mut name_idx = HashMap::with_capacity(images.len());
    let mut num_observations = 0usize;
    for (i, im) in images.iter().enumerate() {
        if image_idx.insert(im.image_id, i).is_some() {
            return Err(invariant(path, i, "duplicate image id", im.image_id.into()));
        }
        name_idx.entry(im.name.clone()).or_insert(i);
        if !camera_idx.contains_key(&im.camera_id) {
            return Err(invariant(
                path,
                i,
                "image names a missing camera",
                im.camera_id.into(),
            ));
        }
        num_observations += im.num_points3d();
    }
    Ok(ImageIndex {
        by_id: image_idx,
        by_name: name_idx,
        num_observations,
    })
}

/// Point3D id → index; point ids are unique.
fn index_points(points: &[Point3D], path: &Path) -> Result<HashMap<u64, usize>> {
    let mut point_idx = HashMap::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        if point_idx.insert(p.point3d_id, i).is_some() {
            return Err(invariant(path, i, "duplicate 3D point id", p.point3d_id));
        }
    }
    Ok(point_idx)
}

/// The rigs and images already indexed, which frames and tracks link to.
struct Links<'a> {
    rigs: &'a [Rig],
    rig_idx: &'a HashMap<u32, usize>,
    images: &'a [Image],
    image_idx: &'a HashMap<u32, usize>,
}

/// Frame id → index and, per image, the index of its frame (`usize::MAX` for none yet); frame
/// ids are unique, frames name existing rigs, valid poses, sensors of their rig and existing
/// images of the same camera, and no image is in two frames.
fn index_frames(
    frames: &[Frame],
    links: &Links<'_>,
    path: &Path,
) -> Result<(HashMap<u32, usize>, Vec<usize>)> {
    let mut frame_idx = HashMap::with_capacity(frames.len());
    let mut image_frame = vec![usize::MAX; links.images.len()];
    for (i, f) in frames.iter().enumerate() {
        if frame_idx.insert(f.frame_id, i).is_some() {
            return Err(invariant(path, i, "duplicate frame id", f.frame_id.into()));
        }
        let Some(&ri) = links.rig_idx.get(&f.rig_id) else {
            return Err(invariant(
                path,
                i,
                "frame names a missing rig",
                f.rig_id.into(),
            ));
        };
        if f.rig_from_world.to_rigid().is_none() {
            return Err(invariant(
                path,
                i,
                "rig_from_world is not a valid pose",
                f.frame_id.into(),
            ));
        }
        let rig = &links.rigs[ri];
        for d in &f.data_ids {
            if rig.sensor_from_rig(d.sensor).is_none() {
                return Err(invariant(
                    path,
                    i,
                    "frame data sensor is not in the frame's rig",
                    d.sensor.id.into(),
                ));
            }
            if d.sensor.sensor_type != SensorType::Camera {
                continue;
            }
            let Some(&ii) = u32::try_from(d.id)
                .ok()
                .and_then(|id| links.image_idx.get(&id))
            else {
                return Err(invariant(path, i, "frame names a missing image", d.id));
            };
            if links.images[ii].camera_id != d.sensor.id {
                return Err(invariant(
                    path,
                    i,
                    "frame data camera differs from the image's camera",
                    d.id,
                ));
            }
            if image_frame[ii] != usize::MAX {
                return Err(invariant(path, i, "image is in two frames", d.id));
            }
            image_frame[ii] = i;
        }
    }
    Ok((frame_idx, image_frame))
}

/// Per image, `cam_from_world` as COLMAP composes it (`sensor_from_rig ∘ rig_from_world` of its
/// frame; `None` when the camera's `sensor_from_rig` is unknown); every image is in a frame.
fn images_cam_from_world(
    frames: &[Frame],
    links: &Links<'_>,
    image_frame: &[usize],
    images_path: &Path,
) -> Result<Vec<Option<Rigid3>>> {
    let mut cam_from_world = Vec::with_capacity(links.images.len());
    for (i, im) in links.images.iter().enumerate() {
        let Some(f) = frames.get(image_frame[i]) else {
            return Err(invariant(
                images_path,
                i,
                "image is in no frame",
                im.image_id.into(),
            ));
        };
        let rig = links.rig_idx.get(&f.rig_id).map(|&ri| &links.rigs[ri]);
        let sensor = SensorId::camera(im.camera_id);
        let pose = match rig {
            Some(r) if r.ref_sensor == Some(sensor) => f.rig_from_world.to_rigid(),
            Some(r) => match r.sensor_from_rig(sensor) {
                Some(Some(s)) => s
                    .to_rigid()
                    .zip(f.rig_from_world.to_rigid())
                    .map(|(s, f)| s * f),
                _ => None,
            },
            None => None,
        };
        cam_from_world.push(pose);
    }
    Ok(cam_from_world)
}

/// Tracks and observations describe the same links, both ways: every track element names an
/// existing image and point2D that observes the track's point, once; every observation is in
/// its point's track.
fn check_tracks(
    points: &[Point3D],
    point_idx: &HashMap<u64, usize>,
    links: &Links<'_>,
    num_observations: usize,
    files: &Files,
) -> Result<()> {
    let images = links.images;
    let mut seen: Vec<Vec<bool>> = images
        .iter()
        .map(|im| vec![false; im.points2d.len()])
        .collect();
    let mut linked = 0usize;
    for (i, p) in points.iter().enumerate() {
        for t in &p.track {
            let Some(&ii) = links.image_idx.get(&t.image_id) else {
                return Err(invariant(
                    &files.points3d,
                    i,
                    "track names a missing image",
                    t.image_id.into(),
                ));
            };
            let idx = t.point2d_idx as usize;
            let Some(p2) = images[ii].points2d.get(idx) else {
                return Err(invariant(
                    &files.points3d,
                    i,
                    "track names a missing point2D index",
                    t.point2d_idx.into(),
                ));
            };
            if p2.point3d_id != Some(p.point3d_id) {
                return Err(invariant(
                    &files.points3d,
                    i,
                    "track element's point2D observes another 3D point",
                    p.point3d_id,
                ));
            }
            if let Some(flag) = seen.get_mut(ii).and_then(|s| s.get_mut(idx)) {
                if *flag {
                    return Err(invariant(
                        &files.points3d,
                        i,
                        "duplicate track element",
                        t.image_id.into(),
                    ));
                }
                *flag = true;
            }
            linked += 1;
        }
    }
    if linked == num_observations {
        return Ok(());
    }
    for (i, im) in images.iter().enumerate() {
        for (k, p2) in im.points2d.iter().enumerate() {
            let marked = seen.get(i).and_then(|s| s.get(k)).copied().unwrap_or(false);
            if let (Some(pid), false) = (p2.point3d_id, marked) {
                let what = if point_idx.contains_key(&pid) {
                    "point2D observes a 3D point whose track lacks it"
                } else {
                    "point2D observes a missing 3D point"
                };
                return Err(invariant(&files.images, i, what, pid));
            }
        }
    }
    Ok(())
}
