//! Read-only access to COLMAP's `database.db` (SQLite), columns selected by name.
//!
//! Opening never creates or changes a file beside the database: when no non-empty `-wal` file
//! sits next to it, the database is opened with `mode=ro&immutable=1` (no locks, no `-shm`, no
//! journal); when a non-empty `-wal` exists (COLMAP has the database open, or crashed), the
//! database and its WAL are copied into a private temporary directory and that copy is opened,
//! so what the WAL holds is read while the user's `-wal` and `-shm` (if any) are never touched.
//! The copy is removed when the [`Database`] is dropped. Either way `PRAGMA query_only` is set
//! and nothing is migrated. (`immutable` assumes nobody writes the file meanwhile; COLMAP
//! always writes in WAL mode, which leaves a `-wal` file.)
//!
//! Pairs follow COLMAP: `pair_id = 2147483647·min(a, b) + max(a, b)`, data stored with the
//! smaller image id first. [`Database::matches`] and [`Database::two_view_geometry`] return
//! the data oriented as asked (image `a` first), swapping columns and inverting F, E, H and
//! the relative pose when `a > b`. Databases older than 4.0 (`user_version ≤ 3130000`) use
//! identity/zero sentinels for an unset relative pose and all-zero F/E/H for unset matrices;
//! they are read as `None`, as COLMAP's migration does.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::Rigid3;
use nalgebra::Matrix3;
use rusqlite::types::ValueRef;
use rusqlite::{Connection, OpenFlags, Row};

use crate::error::{Error, Result};
use crate::record::{CameraRecord, DataId, RawPose, Rig, RigSensor, SensorId, SensorType};

/// COLMAP's `kMaxNumImages`: image ids are below it and pair ids are built from it.
pub const MAX_IMAGE_ID: u64 = 2_147_483_647;

/// COLMAP's pair id of two images (order-independent: the smaller id comes first).
pub fn pair_id(image_a: u32, image_b: u32) -> u64 {
    let (lo, hi) = if image_a <= image_b {
        (image_a, image_b)
    } else {
        (image_b, image_a)
    };
    MAX_IMAGE_ID * u64::from(lo) + u64::from(hi)
}

/// The two image ids of a pair id, smaller first (integer division, as COLMAP).
pub fn image_ids_from_pair_id(pair_id: u64) -> (u64, u64) {
    let b = pair_id % MAX_IMAGE_ID;
    ((pair_id - b) / MAX_IMAGE_ID, b)
}

/// A camera row: the camera and whether its focal length is a trusted prior.
#[derive(Debug, Clone, PartialEq)]
pub struct DbCamera {
    /// Camera id and model.
    pub record: CameraRecord,
    /// `prior_focal_length` (1 = the focal length comes from EXIF or the user).
    pub prior_focal_length: bool,
}

/// An image row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DbImage {
    /// Image id.
    pub image_id: u32,
    /// Image name (relative path).
    pub name: String,
    /// Camera id.
    pub camera_id: u32,
}

/// A frame row with its data ids (frames have no pose in the database).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DbFrame {
    /// Frame id.
    pub frame_id: u32,
    /// Rig id.
    pub rig_id: u32,
    /// The measurements, sorted.
    pub data_ids: Vec<DataId>,
}

/// A keypoint in COLMAP pixel coordinates with its affine shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keypoint {
    /// Position (upper-left image corner at (0, 0)).
    pub xy: [f32; 2],
    /// Affine shape `a11, a12, a21, a22` (identity for 2-column keypoints; from scale and
    /// orientation for 4-column ones, as COLMAP converts them).
    pub affine: [f32; 4],
}

/// A descriptors row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Descriptors {
    /// `type` (−1 undefined, 0 SIFT, 1 ALIKED_N16ROT, 2 ALIKED_N32; 0 when the column is absent).
    pub extractor_type: i64,
    /// Number of descriptors.
    pub rows: usize,
    /// Bytes per descriptor.
    pub cols: usize,
    /// Row-major `rows × cols` bytes.
    pub data: Vec<u8>,
}

/// Intrinsics a two-view solver estimated for one side (`camera1`/`camera2`, COLMAP ≥ 4.2).
#[derive(Debug, Clone, PartialEq)]
pub struct TwoViewCamera {
    /// Camera id and model.
    pub record: CameraRecord,
    /// Whether the focal length is a prior.
    pub prior_focal_length: bool,
}

/// A verified image pair, oriented as requested: `a` is the first image asked for.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoViewGeometry {
    /// `config` (0 UNDEFINED … 9 CALIBRATED_RIG).
    pub config: i64,
    /// Inlier matches `[index in a, index in b]`.
    pub inliers: Vec<[u32; 2]>,
    /// Fundamental matrix with `x_bᵀ F x_a = 0` (COLMAP pixels), if set.
    pub f: Option<Matrix3<f64>>,
    /// Essential matrix with `x̂_bᵀ E x̂_a = 0` (normalized coordinates), if set.
    pub e: Option<Matrix3<f64>>,
    /// Homography with `x_b ~ H x_a`, if set.
    pub h: Option<Matrix3<f64>>,
    /// Relative pose `b_from_a` (COLMAP's `cam2_from_cam1` for `a < b`), if set.
    pub b_from_a: Option<Rigid3>,
    /// Intrinsics estimated for image `a`, if stored.
    pub camera_a: Option<TwoViewCamera>,
    /// Intrinsics estimated for image `b`, if stored.
    pub camera_b: Option<TwoViewCamera>,
}

/// A pose prior row (COLMAP ≥ 4.0 layout; 3.10–3.13 rows are mapped onto it).
#[derive(Debug, Clone, PartialEq)]
pub struct PosePrior {
    /// `pose_prior_id` (the image id for pre-4.0 rows).
    pub pose_prior_id: i64,
    /// The measurement it belongs to (`CAMERA`, camera id, image id for images).
    pub data_id: DataId,
    /// Sensor centre in world coordinates (or lat°, lon°, alt m for WGS84); `None` if NaN.
    pub position: Option<[f64; 3]>,
    /// 3×3 covariance of the position, column-major; `None` if absent or all NaN.
    pub position_covariance: Option<[f64; 9]>,
    /// Gravity ("down") direction in the sensor frame; `None` if absent or NaN.
    pub gravity: Option<[f64; 3]>,
    /// −1 UNDEFINED, 0 WGS84, 1 CARTESIAN.
    pub coordinate_system: i64,
}

/// Row counts for `crashrig colmap info`. The fields are in alphabetical order: the key order
/// of the command's JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "commands", derive(serde::Serialize))]
pub struct DbCounts {
    /// Rows of `cameras`.
    pub cameras: u64,
    /// Rows of `frames` (0 when the table is absent).
    pub frames: u64,
    /// Rows of `images`.
    pub images: u64,
    /// Images with a `keypoints` row.
    pub keypoints: u64,
    /// `matches` rows with at least one match.
    pub matched_pairs: u64,
    /// Rows of `rigs` (0 when the table is absent).
    pub rigs: u64,
    /// `PRAGMA user_version`.
    pub user_version: i64,
    /// `two_view_geometries` rows with at least one inlier.
    pub verified_pairs: u64,
}

/// A COLMAP database opened read-only.
#[derive(Debug)]
pub struct Database {
    conn: Connection,
    /// The private copy (database + WAL) opened instead of the file, when a WAL exists; kept
    /// alive as long as the connection (declared after it, so it is dropped after it).
    _copy: Option<tempfile::TempDir>,
    path: PathBuf,
    columns: HashMap<String, HashSet<String>>,
    user_version: i64,
}

/// `file:` URI of a path, percent-encoded.
fn file_uri(path: &Path, immutable: bool) -> String {
    let mut uri = String::from("file:");
    for &b in path.as_os_str().as_encoded_bytes() {
        if b.is_ascii_alphanumeric() || b"/-_.~".contains(&b) {
            uri.push(b as char);
        } else {
            uri.push_str(&format!("%{b:02X}"));
        }
    }
    uri.push_str(if immutable {
        "?mode=ro&immutable=1"
    } else {
        "?mode=rw"
    });
    uri
}

fn u32_id(v: i64) -> Option<u32> {
    u32::try_from(v).ok()
}

fn f64s(blob: &[u8]) -> Vec<f64> {
    blob.chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
        .collect()
}

impl Database {
    /// Opens `path` read-only without modifying it (see the module docs).
    ///
    /// # Errors
    /// [`Error::Io`] when the file does not exist, [`Error::Sqlite`] when it is not a
    /// readable SQLite database.
    pub fn open(path: &Path) -> Result<Database> {
        let meta = std::fs::metadata(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        if !meta.is_file() {
            return Err(Error::Io {
                path: path.to_path_buf(),
                source: std::io::Error::other("not a regular file"),
            });
        }
        let mut wal = path.as_os_str().to_owned();
        wal.push("-wal");
        let wal = PathBuf::from(wal);
        let wal_len = std::fs::metadata(&wal).map(|m| m.len()).unwrap_or(0);
        let sql = |source| Error::Sqlite {
            path: path.to_path_buf(),
            source,
        };
        let (conn, copy) = if wal_len == 0 {
            let flags = OpenFlags::SQLITE_OPEN_READ_ONLY
                | OpenFlags::SQLITE_OPEN_URI
                | OpenFlags::SQLITE_OPEN_NO_MUTEX;
            let conn = Connection::open_with_flags(file_uri(path, true), flags).map_err(sql)?;
            (conn, None)
        } else {
            // Copy database + WAL into a private directory and open the copy: SQLite then
            // applies the WAL there and creates its `-shm` there, never beside the user's file.
            let io = |p: &Path| {
                let p = p.to_path_buf();
                move |source| Error::Io { path: p, source }
            };
            let dir = tempfile::Builder::new()
                .prefix("crashrig-db-")
                .tempdir()
                .map_err(io(path))?;
            let db_copy = dir.path().join("database.db");
            std::fs::copy(path, &db_copy).map_err(io(path))?;
            std::fs::copy(&wal, dir.path().join("database.db-wal")).map_err(io(&wal))?;
            let flags = OpenFlags::SQLITE_OPEN_READ_WRITE
                | OpenFlags::SQLITE_OPEN_URI
                | OpenFlags::SQLITE_OPEN_NO_MUTEX;
            let conn =
                Connection::open_with_flags(file_uri(&db_copy, false), flags).map_err(sql)?;
            (conn, Some(dir))
        };
        conn.pragma_update(None, "query_only", true).map_err(sql)?;
        let user_version: i64 = conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .map_err(sql)?;
        let mut columns: HashMap<String, HashSet<String>> = HashMap::new();
        {
            let mut stmt = conn
                .prepare("SELECT name FROM sqlite_master WHERE type = 'table'")
                .map_err(sql)?;
            let tables: Vec<String> = stmt
                .query_map([], |r| r.get(0))
                .map_err(sql)?
                .collect::<std::result::Result<_, _>>()
                .map_err(sql)?;
            for t in tables {
                let mut info = conn
                    .prepare("SELECT name FROM pragma_table_info(?1)")
                    .map_err(sql)?;
                let cols: HashSet<String> = info
                    .query_map([&t], |r| r.get(0))
                    .map_err(sql)?
                    .collect::<std::result::Result<_, _>>()
                    .map_err(sql)?;
                columns.insert(t, cols);
            }
        }
        // COLMAP creates every table on open; a file without the two it has always had is
        // some other SQLite database, not an empty COLMAP one.
        for table in ["cameras", "images"] {
            if !columns.contains_key(table) {
                return Err(Error::NotADatabase {
                    path: path.to_path_buf(),
                    table,
                });
            }
        }
        Ok(Database {
            conn,
            _copy: copy,
            path: path.to_path_buf(),
            columns,
            user_version,
        })
    }

    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `PRAGMA user_version` (3800, 3900, or `major·10⁶ + minor·10⁴ + patch·100 + rev` from 4.0).
    pub fn user_version(&self) -> i64 {
        self.user_version
    }

    fn sql(&self, source: rusqlite::Error) -> Error {
        Error::Sqlite {
            path: self.path.clone(),
            source,
        }
    }

    fn bad(&self, table: &'static str, row: i64, what: &'static str) -> Error {
        Error::BadRow {
            path: self.path.clone(),
            table,
            row,
            what,
        }
    }

    fn has_table(&self, table: &str) -> bool {
        self.columns.contains_key(table)
    }

    fn has_column(&self, table: &str, column: &str) -> bool {
        self.columns.get(table).is_some_and(|c| c.contains(column))
    }

    /// The name of the verified-pairs table (`inlier_matches` in very old databases).
    fn tvg_table(&self) -> Option<&'static str> {
        if self.has_table("two_view_geometries") {
            Some("two_view_geometries")
        } else if self.has_table("inlier_matches") {
            Some("inlier_matches")
        } else {
            None
        }
    }

    fn count(&self, sql: &str) -> Result<u64> {
        let n: i64 = self
            .conn
            .query_row(sql, [], |r| r.get(0))
            .map_err(|e| self.sql(e))?;
        Ok(u64::try_from(n).unwrap_or(0))
    }

    fn count_table(&self, table: &str, filter: &str) -> Result<u64> {
        if self.has_table(table) {
            self.count(&format!("SELECT COUNT(*) FROM {table} {filter}"))
        } else {
            Ok(0)
        }
    }

    /// Row counts for `crashrig colmap info`.
    pub fn counts(&self) -> Result<DbCounts> {
        Ok(DbCounts {
            user_version: self.user_version,
            cameras: self.count_table("cameras", "")?,
            images: self.count_table("images", "")?,
            rigs: self.count_table("rigs", "")?,
            frames: self.count_table("frames", "")?,
            keypoints: self.count_table("keypoints", "")?,
            matched_pairs: self.count_table("matches", "WHERE rows > 0")?,
            verified_pairs: match self.tvg_table() {
                Some(t) => self.count_table(t, "WHERE rows > 0")?,
                None => 0,
            },
        })
    }

    fn rows<T>(
        &self,
        sql: &str,
        params: impl rusqlite::Params,
        mut f: impl FnMut(&Row<'_>) -> Result<T>,
    ) -> Result<Vec<T>> {
        let mut stmt = self.conn.prepare(sql).map_err(|e| self.sql(e))?;
        let mut rows = stmt.query(params).map_err(|e| self.sql(e))?;
        let mut out = Vec::new();
        while let Some(r) = rows.next().map_err(|e| self.sql(e))? {
            out.push(f(r)?);
        }
        Ok(out)
    }

    fn get<T: rusqlite::types::FromSql>(&self, r: &Row<'_>, i: usize) -> Result<T> {
        r.get(i).map_err(|e| self.sql(e))
    }

    /// An optional BLOB column (NULL → `None`); any other type is an error.
    fn blob(
        &self,
        r: &Row<'_>,
        i: usize,
        table: &'static str,
        row: i64,
    ) -> Result<Option<Vec<u8>>> {
        match r.get_ref(i).map_err(|e| self.sql(e))? {
            ValueRef::Null => Ok(None),
            ValueRef::Blob(b) => Ok(Some(b.to_vec())),
            _ => Err(self.bad(table, row, "expected a BLOB")),
        }
    }

    fn camera_from(
        &self,
        id: i64,
        model: i64,
        w: i64,
        h: i64,
        params: Option<Vec<u8>>,
    ) -> Result<CameraRecord> {
        let camera_id =
            u32_id(id).ok_or_else(|| self.bad("cameras", id, "camera id out of range"))?;
        let model = i32::try_from(model)
            .ok()
            .and_then(|m| ModelId::from_id(m).ok())
            .ok_or_else(|| self.bad("cameras", id, "unknown camera model id"))?;
        let width = u64::try_from(w).map_err(|_| self.bad("cameras", id, "negative width"))?;
        let height = u64::try_from(h).map_err(|_| self.bad("cameras", id, "negative height"))?;
        let blob = params.unwrap_or_default();
        if blob.len() != 8 * model.num_params() {
            return Err(self.bad("cameras", id, "params blob size does not match the model"));
        }
        Ok(CameraRecord {
            camera_id,
            camera: Camera {
                model,
                width,
                height,
                params: f64s(&blob),
            },
        })
    }

    /// All cameras, by id.
    pub fn cameras(&self) -> Result<Vec<DbCamera>> {
        let prior = if self.has_column("cameras", "prior_focal_length") {
            "prior_focal_length"
        } else {
            "0"
        };
        let sql = format!(
            "SELECT camera_id, model, width, height, params, {prior} FROM cameras ORDER BY camera_id"
        );
        self.rows(&sql, [], |r| {
            let id: i64 = self.get(r, 0)?;
            let record = self.camera_from(
                id,
                self.get(r, 1)?,
                self.get(r, 2)?,
                self.get(r, 3)?,
                self.blob(r, 4, "cameras", id)?,
            )?;
            let p: i64 = self.get(r, 5)?;
            Ok(DbCamera {
                record,
                prior_focal_length: p != 0,
            })
        })
    }

    fn image_row(&self, r: &Row<'_>) -> Result<DbImage> {
        let id: i64 = self.get(r, 0)?;
        let image_id = u32_id(id).ok_or_else(|| self.bad("images", id, "image id out of range"))?;
        let cam: i64 = self.get(r, 2)?;
        let camera_id =
            u32_id(cam).ok_or_else(|| self.bad("images", id, "camera id out of range"))?;
        Ok(DbImage {
            image_id,
            name: self.get(r, 1)?,
            camera_id,
        })
    }

    /// All images, by id.
    pub fn images(&self) -> Result<Vec<DbImage>> {
        self.rows(
            "SELECT image_id, name, camera_id FROM images ORDER BY image_id",
            [],
            |r| self.image_row(r),
        )
    }

    /// The id of the image with this exact name.
    pub fn image_id_by_name(&self, name: &str) -> Result<Option<u32>> {
        let v = self.rows(
            "SELECT image_id, name, camera_id FROM images WHERE name = ?1",
            [name],
            |r| self.image_row(r),
        )?;
        Ok(v.first().map(|i| i.image_id))
    }

    fn sensor(&self, table: &'static str, row: i64, ty: i64, id: i64) -> Result<SensorId> {
        let sensor_type = i32::try_from(ty)
            .ok()
            .and_then(SensorType::from_code)
            .ok_or_else(|| self.bad(table, row, "unknown sensor type"))?;
        let id = u32_id(id).ok_or_else(|| self.bad(table, row, "sensor id out of range"))?;
        Ok(SensorId { sensor_type, id })
    }

    /// All rigs with their non-reference sensors (empty when the table is absent, i.e. a
    /// pre-3.12 database; COLMAP then uses one trivial rig per camera).
    pub fn rigs(&self) -> Result<Vec<Rig>> {
        if !self.has_table("rigs") {
            return Ok(Vec::new());
        }
        let mut rigs = self.rows(
            "SELECT rig_id, ref_sensor_id, ref_sensor_type FROM rigs ORDER BY rig_id",
            [],
            |r| {
                let id: i64 = self.get(r, 0)?;
                let rig_id =
                    u32_id(id).ok_or_else(|| self.bad("rigs", id, "rig id out of range"))?;
                let reference = self.sensor("rigs", id, self.get(r, 2)?, self.get(r, 1)?)?;
                Ok(Rig {
                    rig_id,
                    ref_sensor: Some(reference),
                    sensors: Vec::new(),
                })
            },
        )?;
        if !self.has_table("rig_sensors") {
            return Ok(rigs);
        }
        let index: HashMap<u32, usize> = rigs
            .iter()
            .enumerate()
            .map(|(i, r)| (r.rig_id, i))
            .collect();
        let sensors = self.rows(
            "SELECT rig_id, sensor_id, sensor_type, sensor_from_rig FROM rig_sensors ORDER BY rig_id, sensor_type, sensor_id",
            [],
            |r| {
                let rid: i64 = self.get(r, 0)?;
                let sensor = self.sensor("rig_sensors", rid, self.get(r, 2)?, self.get(r, 1)?)?;
                let pose = match self.blob(r, 3, "rig_sensors", rid)? {
                    None => None,
                    Some(b) if b.len() == 56 => {
                        let v = f64s(&b);
                        Some(RawPose::from_array([v[0], v[1], v[2], v[3], v[4], v[5], v[6]]))
                    }
                    Some(_) => return Err(self.bad("rig_sensors", rid, "sensor_from_rig blob is not 56 bytes")),
                };
                Ok((rid, sensor, pose))
            },
        )?;
        for (rid, sensor, sensor_from_rig) in sensors {
            let Some(&i) = u32_id(rid).and_then(|id| index.get(&id)) else {
                return Err(self.bad("rig_sensors", rid, "rig sensor names a missing rig"));
            };
            rigs[i].sensors.push(RigSensor {
                sensor,
                sensor_from_rig,
            });
        }
        Ok(rigs)
    }

    /// All frames with their data ids (empty when the table is absent).
    pub fn frames(&self) -> Result<Vec<DbFrame>> {
        if !self.has_table("frames") {
            return Ok(Vec::new());
        }
        let mut frames = self.rows(
            "SELECT frame_id, rig_id FROM frames ORDER BY frame_id",
            [],
            |r| {
                let id: i64 = self.get(r, 0)?;
                let rig: i64 = self.get(r, 1)?;
                Ok(DbFrame {
                    frame_id: u32_id(id)
                        .ok_or_else(|| self.bad("frames", id, "frame id out of range"))?,
                    rig_id: u32_id(rig)
                        .ok_or_else(|| self.bad("frames", id, "rig id out of range"))?,
                    data_ids: Vec::new(),
                })
            },
        )?;
        if !self.has_table("frame_data") {
            return Ok(frames);
        }
        let index: HashMap<u32, usize> = frames
            .iter()
            .enumerate()
            .map(|(i, f)| (f.frame_id, i))
            .collect();
        let data = self.rows(
            "SELECT frame_id, data_id, sensor_id, sensor_type FROM frame_data",
            [],
            |r| {
                let fid: i64 = self.get(r, 0)?;
                let did: i64 = self.get(r, 1)?;
                let sensor = self.sensor("frame_data", fid, self.get(r, 3)?, self.get(r, 2)?)?;
                let id = u64::try_from(did)
                    .map_err(|_| self.bad("frame_data", fid, "negative data id"))?;
                Ok((fid, DataId { sensor, id }))
            },
        )?;
        for (fid, d) in data {
            let Some(&i) = u32_id(fid).and_then(|id| index.get(&id)) else {
                return Err(self.bad("frame_data", fid, "frame data names a missing frame"));
            };
            frames[i].data_ids.push(d);
        }
        for f in &mut frames {
            f.data_ids.sort();
        }
        Ok(frames)
    }

    /// Keypoints of an image (empty when it has no keypoints row). 2, 4 and 6 columns are
    /// accepted, as COLMAP does.
    pub fn keypoints(&self, image_id: u32) -> Result<Vec<Keypoint>> {
        let row = i64::from(image_id);
        let v = self.rows(
            "SELECT rows, cols, data FROM keypoints WHERE image_id = ?1",
            [row],
            |r| {
                let rows: i64 = self.get(r, 0)?;
                let cols: i64 = self.get(r, 1)?;
                let data = self.blob(r, 2, "keypoints", row)?.unwrap_or_default();
                Ok((rows, cols, data))
            },
        )?;
        let Some((rows, cols, data)) = v.into_iter().next() else {
            return Ok(Vec::new());
        };
        let (Ok(rows), Ok(cols)) = (usize::try_from(rows), usize::try_from(cols)) else {
            return Err(self.bad("keypoints", row, "negative rows or cols"));
        };
        if rows == 0 {
            return Ok(Vec::new());
        }
        if ![2, 4, 6].contains(&cols) {
            return Err(self.bad("keypoints", row, "keypoints must have 2, 4 or 6 columns"));
        }
        if rows.checked_mul(cols * 4) != Some(data.len()) {
            return Err(self.bad("keypoints", row, "data blob size is not rows × cols × 4"));
        }
        let vals: Vec<f32> = data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap_or([0; 4])))
            .collect();
        Ok(vals
            .chunks_exact(cols)
            .map(|k| {
                let affine = match cols {
                    2 => [1.0, 0.0, 0.0, 1.0],
                    4 => {
                        let (s, o) = (k[2], k[3]);
                        [s * o.cos(), -s * o.sin(), s * o.sin(), s * o.cos()]
                    }
                    _ => [k[2], k[3], k[4], k[5]],
                };
                Keypoint {
                    xy: [k[0], k[1]],
                    affine,
                }
            })
            .collect())
    }

    /// Descriptors of an image, if it has a row.
    pub fn descriptors(&self, image_id: u32) -> Result<Option<Descriptors>> {
        let row = i64::from(image_id);
        let ty = if self.has_column("descriptors", "type") {
            "type"
        } else {
            "0"
        };
        let v = self.rows(
            &format!("SELECT rows, cols, data, {ty} FROM descriptors WHERE image_id = ?1"),
            [row],
            |r| {
                let rows: i64 = self.get(r, 0)?;
                let cols: i64 = self.get(r, 1)?;
                let data = self.blob(r, 2, "descriptors", row)?.unwrap_or_default();
                let t: i64 = self.get(r, 3)?;
                Ok((rows, cols, data, t))
            },
        )?;
        let Some((rows, cols, data, extractor_type)) = v.into_iter().next() else {
            return Ok(None);
        };
        let (Ok(rows), Ok(cols)) = (usize::try_from(rows), usize::try_from(cols)) else {
            return Err(self.bad("descriptors", row, "negative rows or cols"));
        };
        if rows.checked_mul(cols) != Some(data.len()) {
            return Err(self.bad("descriptors", row, "data blob size is not rows × cols"));
        }
        Ok(Some(Descriptors {
            extractor_type,
            rows,
            cols,
            data,
        }))
    }

    /// Decodes a `rows × 2` u32 match blob, swapping the columns when `swap`.
    fn match_pairs(
        &self,
        table: &'static str,
        pid: i64,
        rows: i64,
        cols: i64,
        data: Option<Vec<u8>>,
        swap: bool,
    ) -> Result<Vec<[u32; 2]>> {
        let rows = usize::try_from(rows).map_err(|_| self.bad(table, pid, "negative rows"))?;
        if rows == 0 {
            return Ok(Vec::new());
        }
        if cols != 2 {
            return Err(self.bad(table, pid, "matches must have 2 columns"));
        }
        let data = data.unwrap_or_default();
        if rows.checked_mul(8) != Some(data.len()) {
            return Err(self.bad(table, pid, "data blob size is not rows × 2 × 4"));
        }
        Ok(data
            .chunks_exact(8)
            .map(|b| {
                let i = u32::from_le_bytes(b[0..4].try_into().unwrap_or([0; 4]));
                let j = u32::from_le_bytes(b[4..8].try_into().unwrap_or([0; 4]));
                if swap { [j, i] } else { [i, j] }
            })
            .collect())
    }

    /// Raw matches between `a` and `b`, `[index in a, index in b]` (empty when none).
    pub fn matches(&self, image_a: u32, image_b: u32) -> Result<Vec<[u32; 2]>> {
        if !self.has_table("matches") {
            return Ok(Vec::new());
        }
        let pid = pair_id(image_a, image_b) as i64;
        let v = self.rows(
            "SELECT rows, cols, data FROM matches WHERE pair_id = ?1",
            [pid],
            |r| {
                Ok((
                    self.get::<i64>(r, 0)?,
                    self.get::<i64>(r, 1)?,
                    self.blob(r, 2, "matches", pid)?,
                ))
            },
        )?;
        match v.into_iter().next() {
            Some((rows, cols, data)) => {
                self.match_pairs("matches", pid, rows, cols, data, image_a > image_b)
            }
            None => Ok(Vec::new()),
        }
    }

    /// All pairs with a `matches` row and at least one match, as `(smaller id, larger id)`.
    pub fn matched_pairs(&self) -> Result<Vec<(u32, u32)>> {
        if !self.has_table("matches") {
            return Ok(Vec::new());
        }
        self.rows(
            "SELECT pair_id FROM matches WHERE rows > 0 ORDER BY pair_id",
            [],
            |r| {
                let pid: i64 = self.get(r, 0)?;
                let (a, b) = image_ids_from_pair_id(u64::try_from(pid).unwrap_or(0));
                match (u32::try_from(a), u32::try_from(b)) {
                    (Ok(a), Ok(b)) => Ok((a, b)),
                    _ => Err(self.bad("matches", pid, "pair id out of range")),
                }
            },
        )
    }

    fn mat3(&self, pid: i64, blob: Option<Vec<u8>>, legacy: bool) -> Result<Option<Matrix3<f64>>> {
        let Some(b) = blob else { return Ok(None) };
        if b.len() != 72 {
            return Err(self.bad("two_view_geometries", pid, "F/E/H blob is not 72 bytes"));
        }
        let m = Matrix3::from_row_slice(&f64s(&b));
        if legacy && m.iter().all(|&v| v == 0.0) {
            return Ok(None);
        }
        Ok(Some(m))
    }

    fn tvg_camera(&self, pid: i64, blob: Option<Vec<u8>>) -> Result<Option<TwoViewCamera>> {
        let Some(b) = blob else { return Ok(None) };
        let bad = |what| self.bad("two_view_geometries", pid, what);
        if b.len() < 33 {
            return Err(bad("camera blob too short"));
        }
        let u = |r: std::ops::Range<usize>| -> [u8; 8] {
            let mut a = [0u8; 8];
            a[..r.len()].copy_from_slice(&b[r]);
            a
        };
        let camera_id = u32::from_le_bytes(b[0..4].try_into().unwrap_or([0; 4]));
        let model_id = i32::from_le_bytes(b[4..8].try_into().unwrap_or([0; 4]));
        let width = u64::from_le_bytes(u(8..16));
        let height = u64::from_le_bytes(u(16..24));
        let prior = b[24] != 0;
        let np = u64::from_le_bytes(u(25..33));
        let model =
            ModelId::from_id(model_id).map_err(|_| bad("camera blob has an unknown model id"))?;
        if np != model.num_params() as u64 || b.len() != 33 + 8 * model.num_params() {
            return Err(bad("camera blob size does not match its model"));
        }
        Ok(Some(TwoViewCamera {
            record: CameraRecord {
                camera_id,
                camera: Camera {
                    model,
                    width,
                    height,
                    params: f64s(&b[33..]),
                },
            },
            prior_focal_length: prior,
        }))
    }

    /// The verified geometry of `a` and `b`, oriented so that `a` comes first (`None` when the
    /// pair has no row).
    pub fn two_view_geometry(&self, image_a: u32, image_b: u32) -> Result<Option<TwoViewGeometry>> {
        let Some(table) = self.tvg_table() else {
            return Ok(None);
        };
        let col = |c: &str| {
            if self.has_column(table, c) {
                c.to_owned()
            } else {
                "NULL".to_owned()
            }
        };
        let sql = format!(
            "SELECT rows, cols, data, {}, {}, {}, {}, {}, {}, {}, {} FROM {table} WHERE pair_id = ?1",
            if self.has_column(table, "config") {
                "config"
            } else {
                "2"
            },
            col("F"),
            col("E"),
            col("H"),
            col("qvec"),
            col("tvec"),
            col("camera1"),
            col("camera2"),
        );
        let pid = pair_id(image_a, image_b) as i64;
        let swap = image_a > image_b;
        let legacy_pose = self.user_version <= 3_130_000;
        let legacy_mat = self.user_version <= 3_140_000;
        let t = "two_view_geometries";
        let v = self.rows(&sql, [pid], |r| {
            let rows: i64 = self.get(r, 0)?;
            let cols: i64 = self.get(r, 1)?;
            let inliers = self.match_pairs(t, pid, rows, cols, self.blob(r, 2, t, pid)?, swap)?;
            let config: i64 = self.get(r, 3)?;
            let mut f = self.mat3(pid, self.blob(r, 4, t, pid)?, legacy_mat)?;
            let mut e = self.mat3(pid, self.blob(r, 5, t, pid)?, legacy_mat)?;
            let mut h = self.mat3(pid, self.blob(r, 6, t, pid)?, legacy_mat)?;
            let qvec = self.blob(r, 7, t, pid)?;
            let tvec = self.blob(r, 8, t, pid)?;
            let pose = match (qvec, tvec) {
                (None, None) => None,
                (Some(q), Some(tv)) if q.len() == 32 && tv.len() == 24 => {
                    let q = f64s(&q);
                    let tv = f64s(&tv);
                    let q = [q[0], q[1], q[2], q[3]];
                    let tv = [tv[0], tv[1], tv[2]];
                    let identity = q == [1.0, 0.0, 0.0, 0.0] && tv == [0.0; 3];
                    let zero = q == [0.0; 4];
                    if legacy_pose && (identity || zero) {
                        None
                    } else {
                        let p = RawPose { qvec: q, tvec: tv }
                            .to_rigid()
                            .ok_or_else(|| self.bad(t, pid, "qvec/tvec is not a valid pose"))?;
                        Some(p)
                    }
                }
                (Some(_), Some(_)) => {
                    return Err(self.bad(t, pid, "qvec must be 32 bytes and tvec 24 bytes"));
                }
                _ => return Err(self.bad(t, pid, "exactly one of qvec and tvec is NULL")),
            };
            let mut camera_a = self.tvg_camera(pid, self.blob(r, 9, t, pid)?)?;
            let mut camera_b = self.tvg_camera(pid, self.blob(r, 10, t, pid)?)?;
            let mut b_from_a = pose;
            if swap {
                f = f.map(|m| m.transpose());
                e = e.map(|m| m.transpose());
                h = match h {
                    Some(m) => Some(
                        m.try_inverse()
                            .ok_or_else(|| self.bad(t, pid, "H is singular"))?,
                    ),
                    None => None,
                };
                b_from_a = b_from_a.map(|p| p.inverse());
                std::mem::swap(&mut camera_a, &mut camera_b);
            }
            Ok(TwoViewGeometry {
                config,
                inliers,
                f,
                e,
                h,
                b_from_a,
                camera_a,
                camera_b,
            })
        })?;
        Ok(v.into_iter().next())
    }

    /// All pose priors, by id (4.0 layout, or 3.10–3.13 rows keyed by image id).
    pub fn pose_priors(&self) -> Result<Vec<PosePrior>> {
        const T: &str = "pose_priors";
        if !self.has_table(T) {
            return Ok(Vec::new());
        }
        let new_layout = self.has_column(T, "corr_data_id");
        let col = |c: &str| {
            if self.has_column(T, c) {
                c.to_owned()
            } else {
                "NULL".to_owned()
            }
        };
        let sql = if new_layout {
            format!(
                "SELECT pose_prior_id, corr_data_id, corr_sensor_id, corr_sensor_type, {}, {}, {}, coordinate_system FROM pose_priors ORDER BY pose_prior_id",
                col("position"),
                col("position_covariance"),
                col("gravity")
            )
        } else {
            format!(
                "SELECT p.image_id, p.image_id, COALESCE(i.camera_id, 0), 0, {}, {}, NULL, {} FROM pose_priors p LEFT JOIN images i ON i.image_id = p.image_id ORDER BY p.image_id",
                col("position"),
                col("position_covariance"),
                if self.has_column(T, "coordinate_system") {
                    "p.coordinate_system"
                } else {
                    "-1"
                }
            )
        };
        self.rows(&sql, [], |r| {
            let id: i64 = self.get(r, 0)?;
            let did: i64 = self.get(r, 1)?;
            let sensor = self.sensor(T, id, self.get(r, 3)?, self.get(r, 2)?)?;
            let data_id = DataId {
                sensor,
                id: u64::try_from(did).map_err(|_| self.bad(T, id, "negative data id"))?,
            };
            let vec = |b: Option<Vec<u8>>, n: usize| -> Result<Option<Vec<f64>>> {
                match b {
                    None => Ok(None),
                    Some(b) if b.len() == 8 * n => {
                        let v = f64s(&b);
                        Ok((!v.iter().all(|x| x.is_nan())).then_some(v))
                    }
                    Some(_) => {
                        Err(self.bad(T, id, "position/covariance/gravity blob has the wrong size"))
                    }
                }
            };
            let position = vec(self.blob(r, 4, T, id)?, 3)?.map(|v| [v[0], v[1], v[2]]);
            let position_covariance = vec(self.blob(r, 5, T, id)?, 9)?.map(|v| {
                let mut a = [0.0; 9];
                a.copy_from_slice(&v);
                a
            });
            let gravity = vec(self.blob(r, 6, T, id)?, 3)?.map(|v| [v[0], v[1], v[2]]);
            Ok(PosePrior {
                pose_prior_id: id,
                data_id,
                position: position.filter(|p| p.iter().all(|x| !x.is_nan())),
                position_covariance,
                gravity: gravity.filter(|g| g.iter().all(|x| !x.is_nan())),
                coordinate_system: self.get(r, 7)?,
            })
        })
    }
}
