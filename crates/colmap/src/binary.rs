//! Binary sparse-model files (`*.bin`): little-endian, no header, counts guarded.

use std::path::Path;

use crashrig_camera::{Camera, ModelId};

use crate::error::{Error, Result};
use crate::record::{
    CameraRecord, DataId, Frame, Image, Point2D, Point3D, RawPose, Rig, RigSensor, SensorId,
    SensorType, TrackElement,
};

/// A bounds-checked little-endian reader over a whole file.
struct Cursor<'a> {
    path: &'a Path,
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn new(path: &'a Path, buf: &'a [u8]) -> Self {
        Cursor { path, buf, pos: 0 }
    }

    fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    fn truncated(&self, needed: usize) -> Error {
        Error::Truncated {
            path: self.path.to_path_buf(),
            offset: self.pos as u64,
            needed: (needed - self.remaining().min(needed)) as u64,
        }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len());
        match end {
            Some(end) => {
                let s = &self.buf[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            None => Err(self.truncated(n)),
        }
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N]> {
        let s = self.take(N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    fn u8(&mut self) -> Result<u8> {
        Ok(self.array::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn i32(&mut self) -> Result<i32> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    fn f64s<const N: usize>(&mut self) -> Result<[f64; N]> {
        let mut a = [0.0; N];
        for v in &mut a {
            *v = self.f64()?;
        }
        Ok(a)
    }

    fn pose(&mut self) -> Result<RawPose> {
        Ok(RawPose::from_array(self.f64s::<7>()?))
    }

    /// A count of records, each at least `min_size` bytes: a count the remaining bytes cannot
    /// hold is a truncation, not an allocation.
    fn count(&mut self, wide: bool, min_size: usize) -> Result<usize> {
        let n = if wide {
            self.u64()?
        } else {
            u64::from(self.u32()?)
        };
        let need = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(min_size));
        match need {
            Some(need) if need <= self.remaining() => Ok(n as usize),
            Some(need) => Err(self.truncated(need)),
            None => Err(Error::Truncated {
                path: self.path.to_path_buf(),
                offset: self.pos as u64,
                needed: u64::MAX,
            }),
        }
    }

    fn bad(&self, record: usize, offset: usize, what: &'static str) -> Error {
        Error::BadValue {
            path: self.path.to_path_buf(),
            record,
            offset: offset as u64,
            what,
        }
    }

    fn sensor(&mut self, record: usize) -> Result<SensorId> {
        let at = self.pos;
        let code = self.i32()?;
        let sensor_type = SensorType::from_code(code)
            .ok_or_else(|| self.bad(record, at, "unknown sensor type"))?;
        let id = self.u32()?;
        Ok(SensorId { sensor_type, id })
    }

    fn finish(&self) -> Result<()> {
        if self.remaining() == 0 {
            Ok(())
        } else {
            Err(Error::TrailingBytes {
                path: self.path.to_path_buf(),
                offset: self.pos as u64,
                extra: self.remaining() as u64,
            })
        }
    }
}

/// Reads `cameras.bin`.
pub(crate) fn read_cameras(path: &Path, buf: &[u8]) -> Result<Vec<CameraRecord>> {
    let mut c = Cursor::new(path, buf);
    let n = c.count(true, 24)?;
    let mut out = Vec::with_capacity(n);
    for record in 0..n {
        let camera_id = c.u32()?;
        let id = c.i32()?;
        let model = ModelId::from_id(id).map_err(|_| Error::UnknownModelId {
            path: path.to_path_buf(),
            record,
            id: i64::from(id),
        })?;
        let width = c.u64()?;
        let height = c.u64()?;
        let np = model.num_params();
        let raw = c.take(np * 8)?;
        let params = raw
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
            .collect();
        out.push(CameraRecord {
            camera_id,
            camera: Camera {
                model,
                width,
                height,
                params,
            },
        });
    }
    c.finish()?;
    Ok(out)
}

/// Reads `rigs.bin`.
pub(crate) fn read_rigs(path: &Path, buf: &[u8]) -> Result<Vec<Rig>> {
    let mut c = Cursor::new(path, buf);
    let n = c.count(true, 8)?;
    let mut out = Vec::with_capacity(n);
    for record in 0..n {
        let rig_id = c.u32()?;
        let num_sensors = c.count(false, 8)?;
        let mut rig = Rig {
            rig_id,
            ref_sensor: None,
            sensors: Vec::with_capacity(num_sensors.saturating_sub(1)),
        };
        if num_sensors > 0 {
            rig.ref_sensor = Some(c.sensor(record)?);
            for _ in 1..num_sensors {
                let sensor = c.sensor(record)?;
                let at = c.pos;
                let sensor_from_rig = match c.u8()? {
                    0 => None,
                    1 => Some(c.pose()?),
                    _ => return Err(c.bad(record, at, "has_pose flag is neither 0 nor 1")),
                };
                rig.sensors.push(RigSensor {
                    sensor,
                    sensor_from_rig,
                });
            }
        }
        out.push(rig);
    }
    c.finish()?;
    Ok(out)
}

/// Reads `frames.bin`.
pub(crate) fn read_frames(path: &Path, buf: &[u8]) -> Result<Vec<Frame>> {
    let mut c = Cursor::new(path, buf);
    let n = c.count(true, 68)?;
    let mut out = Vec::with_capacity(n);
    for record in 0..n {
        let frame_id = c.u32()?;
        let rig_id = c.u32()?;
        let rig_from_world = c.pose()?;
        let nd = c.count(false, 16)?;
        let mut data_ids = Vec::with_capacity(nd);
        for _ in 0..nd {
            let sensor = c.sensor(record)?;
            let id = c.u64()?;
            data_ids.push(DataId { sensor, id });
        }
        out.push(Frame {
            frame_id,
            rig_id,
            rig_from_world,
            data_ids,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Reads `images.bin`.
pub(crate) fn read_images(path: &Path, buf: &[u8]) -> Result<Vec<Image>> {
    let mut c = Cursor::new(path, buf);
    let n = c.count(true, 73)?;
    let mut out = Vec::with_capacity(n);
    for record in 0..n {
        let image_id = c.u32()?;
        let stored_cam_from_world = c.pose()?;
        let camera_id = c.u32()?;
        let at = c.pos;
        let rest = &c.buf[c.pos..];
        let len = rest
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(|| c.truncated(rest.len() + 1))?;
        let name = std::str::from_utf8(&rest[..len])
            .map_err(|_| c.bad(record, at, "image name is not UTF-8"))?
            .to_owned();
        c.pos += len + 1;
        let np = c.count(true, 24)?;
        let raw = c.take(np * 24)?;
        let points2d = raw
            .chunks_exact(24)
            .map(|b| {
                let x = f64::from_le_bytes(b[0..8].try_into().unwrap_or([0; 8]));
                let y = f64::from_le_bytes(b[8..16].try_into().unwrap_or([0; 8]));
                let id = u64::from_le_bytes(b[16..24].try_into().unwrap_or([0; 8]));
                Point2D {
                    xy: [x, y],
                    point3d_id: (id != u64::MAX).then_some(id),
                }
            })
            .collect();
        out.push(Image {
            image_id,
            stored_cam_from_world,
            camera_id,
            name,
            points2d,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Reads `points3D.bin`.
pub(crate) fn read_points3d(path: &Path, buf: &[u8]) -> Result<Vec<Point3D>> {
    let mut c = Cursor::new(path, buf);
    let n = c.count(true, 51)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let point3d_id = c.u64()?;
        let xyz = c.f64s::<3>()?;
        let rgb = c.array::<3>()?;
        let error = c.f64()?;
        let nt = c.count(true, 8)?;
        let raw = c.take(nt * 8)?;
        let track = raw
            .chunks_exact(8)
            .map(|b| TrackElement {
                image_id: u32::from_le_bytes(b[0..4].try_into().unwrap_or([0; 4])),
                point2d_idx: u32::from_le_bytes(b[4..8].try_into().unwrap_or([0; 4])),
            })
            .collect();
        out.push(Point3D {
            point3d_id,
            xyz,
            rgb,
            error,
            track,
        });
    }
    c.finish()?;
    Ok(out)
}

fn put_pose(out: &mut Vec<u8>, p: &RawPose) {
    for v in p.to_array() {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

fn put_sensor(out: &mut Vec<u8>, s: SensorId) {
    out.extend_from_slice(&s.sensor_type.code().to_le_bytes());
    out.extend_from_slice(&s.id.to_le_bytes());
}

/// Serialises `cameras.bin`.
pub(crate) fn write_cameras(cams: &[CameraRecord]) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + cams.len() * 120);
    out.extend_from_slice(&(cams.len() as u64).to_le_bytes());
    for c in cams {
        out.extend_from_slice(&c.camera_id.to_le_bytes());
        out.extend_from_slice(&c.camera.model.id().to_le_bytes());
        out.extend_from_slice(&c.camera.width.to_le_bytes());
        out.extend_from_slice(&c.camera.height.to_le_bytes());
        for p in &c.camera.params {
            out.extend_from_slice(&p.to_le_bytes());
        }
    }
    out
}

/// Serialises `rigs.bin`.
pub(crate) fn write_rigs(rigs: &[Rig]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(rigs.len() as u64).to_le_bytes());
    for r in rigs {
        out.extend_from_slice(&r.rig_id.to_le_bytes());
        out.extend_from_slice(&(r.num_sensors() as u32).to_le_bytes());
        if let Some(reference) = r.ref_sensor {
            put_sensor(&mut out, reference);
            for s in &r.sensors {
                put_sensor(&mut out, s.sensor);
                match &s.sensor_from_rig {
                    Some(p) => {
                        out.push(1);
                        put_pose(&mut out, p);
                    }
                    None => out.push(0),
                }
            }
        }
    }
    out
}

/// Serialises `frames.bin`.
pub(crate) fn write_frames(frames: &[Frame]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&(frames.len() as u64).to_le_bytes());
    for f in frames {
        out.extend_from_slice(&f.frame_id.to_le_bytes());
        out.extend_from_slice(&f.rig_id.to_le_bytes());
        put_pose(&mut out, &f.rig_from_world);
        out.extend_from_slice(&(f.data_ids.len() as u32).to_le_bytes());
        for d in &f.data_ids {
            put_sensor(&mut out, d.sensor);
            out.extend_from_slice(&d.id.to_le_bytes());
        }
    }
    out
}

/// Serialises `images.bin`.
pub(crate) fn write_images(images: &[Image]) -> Vec<u8> {
    let size: usize = images
        .iter()
        .map(|i| 73 + i.name.len() + 24 * i.points2d.len())
        .sum();
    let mut out = Vec::with_capacity(8 + size);
    out.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for im in images {
        out.extend_from_slice(&im.image_id.to_le_bytes());
        put_pose(&mut out, &im.stored_cam_from_world);
        out.extend_from_slice(&im.camera_id.to_le_bytes());
        out.extend_from_slice(im.name.as_bytes());
        out.push(0);
        out.extend_from_slice(&(im.points2d.len() as u64).to_le_bytes());
        for p in &im.points2d {
            out.extend_from_slice(&p.xy[0].to_le_bytes());
            out.extend_from_slice(&p.xy[1].to_le_bytes());
            out.extend_from_slice(&p.point3d_id.unwrap_or(u64::MAX).to_le_bytes());
        }
    }
    out
}

/// Serialises `points3D.bin`.
pub(crate) fn write_points3d(points: &[Point3D]) -> Vec<u8> {
    let size: usize = points.iter().map(|p| 51 + 8 * p.track.len()).sum();
    let mut out = Vec::with_capacity(8 + size);
    out.extend_from_slice(&(points.len() as u64).to_le_bytes());
    for p in points {
        out.extend_from_slice(&p.point3d_id.to_le_bytes());
        for v in p.xyz {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&p.rgb);
        out.extend_from_slice(&p.error.to_le_bytes());
        out.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for t in &p.track {
            out.extend_from_slice(&t.image_id.to_le_bytes());
            out.extend_from_slice(&t.point2d_idx.to_le_bytes());
        }
    }
    out
}
