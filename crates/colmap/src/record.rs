//! Record types that mirror COLMAP's sparse-model files one to one.
//!
//! Poses are kept exactly as stored ([`RawPose`]: the 7 doubles `qw qx qy qz tx ty tz`), so a
//! model read and written again is bit-identical; conversion to normalized
//! [`crashrig_geometry::Rigid3`] happens in [`crate::convert`].

use crashrig_camera::Camera;

/// A COLMAP pose `b_from_a` exactly as stored on disk: quaternion `w, x, y, z` (not
/// necessarily normalized, sign not canonical) and translation, in model units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawPose {
    /// Quaternion `qw, qx, qy, qz` (Hamilton convention).
    pub qvec: [f64; 4],
    /// Translation `tx, ty, tz`.
    pub tvec: [f64; 3],
}

impl RawPose {
    /// The identity pose `(1, 0, 0, 0), (0, 0, 0)`.
    pub const IDENTITY: RawPose = RawPose {
        qvec: [1.0, 0.0, 0.0, 0.0],
        tvec: [0.0, 0.0, 0.0],
    };

    /// The 7 stored doubles in file order.
    pub fn to_array(&self) -> [f64; 7] {
        let [qw, qx, qy, qz] = self.qvec;
        let [tx, ty, tz] = self.tvec;
        [qw, qx, qy, qz, tx, ty, tz]
    }

    /// Builds a pose from the 7 doubles in file order.
    pub fn from_array(v: [f64; 7]) -> RawPose {
        RawPose {
            qvec: [v[0], v[1], v[2], v[3]],
            tvec: [v[4], v[5], v[6]],
        }
    }
}

/// COLMAP's sensor type (`-1 INVALID`, `0 CAMERA`, `1 IMU`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SensorType {
    /// `-1`, `INVALID`.
    Invalid,
    /// `0`, `CAMERA`: the sensor id is the camera id.
    Camera,
    /// `1`, `IMU`.
    Imu,
}

impl SensorType {
    /// From the binary code (`-1`, `0`, `1`).
    pub fn from_code(code: i32) -> Option<SensorType> {
        match code {
            -1 => Some(SensorType::Invalid),
            0 => Some(SensorType::Camera),
            1 => Some(SensorType::Imu),
            _ => None,
        }
    }

    /// The binary code.
    pub fn code(self) -> i32 {
        match self {
            SensorType::Invalid => -1,
            SensorType::Camera => 0,
            SensorType::Imu => 1,
        }
    }

    /// From the text name (`INVALID`, `CAMERA`, `IMU`).
    pub fn from_name(name: &str) -> Option<SensorType> {
        match name {
            "INVALID" => Some(SensorType::Invalid),
            "CAMERA" => Some(SensorType::Camera),
            "IMU" => Some(SensorType::Imu),
            _ => None,
        }
    }

    /// The text name.
    pub fn name(self) -> &'static str {
        match self {
            SensorType::Invalid => "INVALID",
            SensorType::Camera => "CAMERA",
            SensorType::Imu => "IMU",
        }
    }
}

/// A sensor: its type and id (for a camera, the id is the camera id).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SensorId {
    /// Sensor type.
    pub sensor_type: SensorType,
    /// Sensor id (camera id for cameras).
    pub id: u32,
}

impl SensorId {
    /// The camera sensor of `camera_id`.
    pub fn camera(camera_id: u32) -> SensorId {
        SensorId {
            sensor_type: SensorType::Camera,
            id: camera_id,
        }
    }
}

/// One measurement of a frame: the sensor and the data id (the image id for cameras).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DataId {
    /// The sensor that produced the data.
    pub sensor: SensorId,
    /// The data id (image id for a camera).
    pub id: u64,
}

/// A camera record of `cameras.{bin,txt}`.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraRecord {
    /// COLMAP camera id.
    pub camera_id: u32,
    /// Model, size and parameters exactly as stored (not validated: COLMAP accepts bogus
    /// parameters too; call [`Camera::validate`] when you need them sane).
    pub camera: Camera,
}

/// A non-reference sensor of a rig, with its optional `sensor_from_rig` pose.
#[derive(Debug, Clone, PartialEq)]
pub struct RigSensor {
    /// The sensor.
    pub sensor: SensorId,
    /// `sensor_from_rig` as stored, or `None` when unknown.
    pub sensor_from_rig: Option<RawPose>,
}

/// A rig of `rigs.{bin,txt}`: the reference sensor defines the rig frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// COLMAP rig id.
    pub rig_id: u32,
    /// The reference sensor (its `sensor_from_rig` is the identity); `None` for an empty rig.
    pub ref_sensor: Option<SensorId>,
    /// The other sensors, in file order.
    pub sensors: Vec<RigSensor>,
}

impl Rig {
    /// `Some(None)` for the reference sensor (identity), `Some(pose)` for a non-reference
    /// sensor, `None` when the rig does not contain `sensor`.
    pub fn sensor_from_rig(&self, sensor: SensorId) -> Option<Option<RawPose>> {
        if self.ref_sensor == Some(sensor) {
            return Some(Some(RawPose::IDENTITY));
        }
        self.sensors
            .iter()
            .find(|s| s.sensor == sensor)
            .map(|s| s.sensor_from_rig)
    }

    /// Total number of sensors, the reference included (the count stored in the file).
    pub fn num_sensors(&self) -> usize {
        self.sensors.len() + usize::from(self.ref_sensor.is_some())
    }
}

/// A frame of `frames.{bin,txt}`: one exposure of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// COLMAP frame id.
    pub frame_id: u32,
    /// The rig this frame is an exposure of.
    pub rig_id: u32,
    /// `rig_from_world` as stored.
    pub rig_from_world: RawPose,
    /// The measurements, in file order.
    pub data_ids: Vec<DataId>,
}

/// A 2-D observation of an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point2D {
    /// Pixel coordinates (COLMAP convention: upper-left corner at (0, 0)).
    pub xy: [f64; 2],
    /// The 3-D point it observes, if any.
    pub point3d_id: Option<u64>,
}

/// An image record of `images.{bin,txt}`.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// COLMAP image id.
    pub image_id: u32,
    /// `cam_from_world` as stored in the images file. When rigs and frames exist COLMAP
    /// ignores it and composes the pose from them; use
    /// [`crate::Reconstruction::image_cam_from_world`].
    pub stored_cam_from_world: RawPose,
    /// The camera that took the image.
    pub camera_id: u32,
    /// Image name (relative path), full even with spaces (binary).
    pub name: String,
    /// The 2-D points, indexed by `point2D_idx`.
    pub points2d: Vec<Point2D>,
}

impl Image {
    /// The data id of this image (`CAMERA`, camera id, image id).
    pub fn data_id(&self) -> DataId {
        DataId {
            sensor: SensorId::camera(self.camera_id),
            id: u64::from(self.image_id),
        }
    }

    /// Number of 2-D points that observe a 3-D point.
    pub fn num_points3d(&self) -> usize {
        self.points2d
            .iter()
            .filter(|p| p.point3d_id.is_some())
            .count()
    }
}

/// One element of a 3-D point's track.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrackElement {
    /// The observing image.
    pub image_id: u32,
    /// Index into that image's 2-D points.
    pub point2d_idx: u32,
}

/// A 3-D point of `points3D.{bin,txt}`.
#[derive(Debug, Clone, PartialEq)]
pub struct Point3D {
    /// COLMAP point id.
    pub point3d_id: u64,
    /// Position in world coordinates (model units).
    pub xyz: [f64; 3],
    /// Colour.
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels (`-1` = not computed).
    pub error: f64,
    /// The observations.
    pub track: Vec<TrackElement>,
}
