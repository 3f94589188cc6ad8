//! Text sparse-model files (`*.txt`): COLMAP's parser rules and its byte-exact writer.
//!
//! Reading: every record line is trimmed; empty lines and lines starting with `#` are skipped.
//! In `images.txt` the line after an image line is always its POINTS2D line, even when it is
//! empty (a comment there means no points, as in COLMAP). Unlike COLMAP, an image line that is
//! the last line of the file keeps the image (with no points) instead of dropping it, and the
//! image name is the rest of the line (COLMAP keeps only its first word).

use std::path::Path;
use std::str::SplitAsciiWhitespace;

use crashrig_camera::{Camera, ModelId};

use crate::error::{Error, Result};
use crate::fmt::push_g17;
use crate::record::{
    CameraRecord, DataId, Frame, Image, Point2D, Point3D, RawPose, Rig, RigSensor, SensorId,
    SensorType, TrackElement,
};

/// Decodes a text file, reporting the line of the first invalid UTF-8 byte.
pub(crate) fn decode<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count(),
        what: "invalid UTF-8",
    })
}

/// Tokens of one line, with the file and line for error messages.
struct Tokens<'a> {
    path: &'a Path,
    line: usize,
    it: SplitAsciiWhitespace<'a>,
}

impl<'a> Tokens<'a> {
    fn new(path: &'a Path, line: usize, text: &'a str) -> Self {
        Tokens {
            path,
            line,
            it: text.split_ascii_whitespace(),
        }
    }

    fn err(&self, what: &'static str) -> Error {
        Error::Parse {
            path: self.path.to_path_buf(),
            line: self.line,
            what,
        }
    }

    fn next_tok(&mut self, what: &'static str) -> Result<&'a str> {
        self.it.next().ok_or_else(|| self.err(what))
    }

    fn parse<T: std::str::FromStr>(&mut self, what: &'static str) -> Result<T> {
        let t = self.next_tok(what)?;
        t.parse().map_err(|_| self.err(what))
    }

    fn f64(&mut self, what: &'static str) -> Result<f64> {
        self.parse::<f64>(what)
    }

    fn pose(&mut self, what: &'static str) -> Result<RawPose> {
        let mut v = [0.0; 7];
        for x in &mut v {
            *x = self.f64(what)?;
        }
        Ok(RawPose::from_array(v))
    }

    fn sensor_type(&mut self) -> Result<SensorType> {
        let t = self.next_tok("missing sensor type")?;
        SensorType::from_name(t).ok_or_else(|| self.err("unknown sensor type"))
    }

    fn end(&mut self) -> Result<()> {
        match self.it.next() {
            None => Ok(()),
            Some(_) => Err(self.err("unexpected extra values at the end of the line")),
        }
    }
}

/// Record lines of a file: (1-based line number, trimmed text), comments and blanks skipped.
fn records(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// 1-based line of record `record` (0-based) of a text file: the record-th data line, or in
/// `images.txt` the record-th image line (each followed by its POINTS2D line).
pub(crate) fn record_line(text: &str, is_images: bool, record: usize) -> Option<usize> {
    if !is_images {
        return records(text).nth(record).map(|(line, _)| line);
    }
    let mut lines = text.split('\n').enumerate().map(|(i, l)| (i + 1, l.trim()));
    let mut n = 0;
    while let Some((line, l)) = lines.next() {
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        if n == record {
            return Some(line);
        }
        n += 1;
        lines.next(); // its POINTS2D line, whatever it holds
    }
    None
}

/// Adds the line number to an invariant error found in a text model (the record index is
/// all the consistency checks know).
pub(crate) fn with_line(e: Error) -> Error {
    match e {
        Error::Invariant {
            path,
            record,
            line: None,
            what,
            id,
        } => {
            let is_images = path.file_name().is_some_and(|n| n == "images.txt");
            let line = std::fs::read_to_string(&path)
                .ok()
                .and_then(|t| record_line(&t, is_images, record));
            Error::Invariant {
                path,
                record,
                line,
                what,
                id,
            }
        }
        other => other,
    }
}

/// Reads `cameras.txt`.
pub(crate) fn read_cameras(path: &Path, text: &str) -> Result<Vec<CameraRecord>> {
    let mut out = Vec::new();
    for (line, l) in records(text) {
        let mut t = Tokens::new(path, line, l);
        let camera_id = t.parse::<u32>("bad CAMERA_ID")?;
        let name = t.next_tok("missing MODEL")?;
        let model = ModelId::from_name(name).map_err(|_| Error::UnknownModelName {
            path: path.to_path_buf(),
            line,
            name: name.to_owned(),
        })?;
        let width = t.parse::<u64>("bad WIDTH")?;
        let height = t.parse::<u64>("bad HEIGHT")?;
        let mut params = Vec::with_capacity(model.num_params());
        for tok in t.it.by_ref() {
            params.push(tok.parse::<f64>().map_err(|_| Error::Parse {
                path: path.to_path_buf(),
                line,
                what: "bad camera parameter",
            })?);
        }
        if params.len() != model.num_params() {
            return Err(Error::WrongParamCount {
                path: path.to_path_buf(),
                line,
                model: model.name(),
                expected: model.num_params(),
                found: params.len(),
            });
        }
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
    Ok(out)
}

/// Reads `rigs.txt`.
pub(crate) fn read_rigs(path: &Path, text: &str) -> Result<Vec<Rig>> {
    let mut out = Vec::new();
    for (line, l) in records(text) {
        let mut t = Tokens::new(path, line, l);
        let rig_id = t.parse::<u32>("bad RIG_ID")?;
        let n = t.parse::<u32>("bad NUM_SENSORS")?;
        let mut rig = Rig {
            rig_id,
            ref_sensor: None,
            sensors: Vec::new(),
        };
        if n > 0 {
            let sensor_type = t.sensor_type()?;
            let id = t.parse::<u32>("bad REF_SENSOR_ID")?;
            rig.ref_sensor = Some(SensorId { sensor_type, id });
            for _ in 1..n {
                let sensor_type = t.sensor_type()?;
                let id = t.parse::<u32>("bad SENSOR_ID")?;
                let sensor_from_rig = match t.parse::<i64>("bad HAS_POSE")? {
                    0 => None,
                    1 => Some(t.pose("bad sensor_from_rig value")?),
                    _ => return Err(t.err("HAS_POSE is neither 0 nor 1")),
                };
                rig.sensors.push(RigSensor {
                    sensor: SensorId { sensor_type, id },
                    sensor_from_rig,
                });
            }
        }
        t.end()?;
        out.push(rig);
    }
    Ok(out)
}

/// Reads `frames.txt`.
pub(crate) fn read_frames(path: &Path, text: &str) -> Result<Vec<Frame>> {
    let mut out = Vec::new();
    for (line, l) in records(text) {
        let mut t = Tokens::new(path, line, l);
        let frame_id = t.parse::<u32>("bad FRAME_ID")?;
        let rig_id = t.parse::<u32>("bad RIG_ID")?;
        let rig_from_world = t.pose("bad RIG_FROM_WORLD value")?;
        let n = t.parse::<u32>("bad NUM_DATA_IDS")?;
        let mut data_ids = Vec::new();
        for _ in 0..n {
            let sensor_type = t.sensor_type()?;
            let sid = t.parse::<u32>("bad SENSOR_ID")?;
            let id = t.parse::<u64>("bad DATA_ID")?;
            data_ids.push(DataId {
                sensor: SensorId {
                    sensor_type,
                    id: sid,
                },
                id,
            });
        }
        t.end()?;
        out.push(Frame {
            frame_id,
            rig_id,
            rig_from_world,
            data_ids,
        });
    }
    Ok(out)
}

/// Splits off the first `n` whitespace-separated tokens; returns them and the trimmed rest.
fn split_tokens(l: &str, n: usize) -> (Vec<&str>, &str) {
    let mut toks = Vec::with_capacity(n);
    let mut rest = l;
    while toks.len() < n {
        rest = rest.trim_start_matches(|c: char| c.is_ascii_whitespace());
        if rest.is_empty() {
            break;
        }
        let end = rest
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(rest.len());
        toks.push(&rest[..end]);
        rest = &rest[end..];
    }
    (toks, rest.trim())
}

/// Reads `images.txt` (two lines per image, paired positionally).
pub(crate) fn read_images(path: &Path, text: &str) -> Result<Vec<Image>> {
    let mut out = Vec::new();
    let mut lines = text.split('\n').enumerate().map(|(i, l)| (i + 1, l.trim()));
    while let Some((line, l)) = lines.next() {
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let (toks, name) = split_tokens(l, 9);
        let err = |what| Error::Parse {
            path: path.to_path_buf(),
            line,
            what,
        };
        if toks.len() < 9 {
            return Err(err(
                "an image line needs IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME",
            ));
        }
        if name.is_empty() {
            return Err(err("missing NAME"));
        }
        let image_id = toks[0].parse::<u32>().map_err(|_| err("bad IMAGE_ID"))?;
        let mut v = [0.0; 7];
        for (x, tok) in v.iter_mut().zip(&toks[1..8]) {
            *x = tok.parse::<f64>().map_err(|_| err("bad pose value"))?;
        }
        let camera_id = toks[8].parse::<u32>().map_err(|_| err("bad CAMERA_ID"))?;
        let mut points2d = Vec::new();
        if let Some((pline, p)) = lines.next().filter(|(_, p)| !p.starts_with('#')) {
            let mut t = Tokens::new(path, pline, p);
            while let Some(xs) = t.it.next() {
                let x = xs.parse::<f64>().map_err(|_| t.err("bad POINTS2D X"))?;
                let y = t.f64("bad or missing POINTS2D Y")?;
                let id = t.parse::<i64>("bad or missing POINT3D_ID")?;
                let point3d_id = match id {
                    -1 => None,
                    id if id >= 0 => Some(id as u64),
                    _ => return Err(t.err("POINT3D_ID must be -1 or non-negative")),
                };
                points2d.push(Point2D {
                    xy: [x, y],
                    point3d_id,
                });
            }
        }
        out.push(Image {
            image_id,
            stored_cam_from_world: RawPose::from_array(v),
            camera_id,
            name: name.to_owned(),
            points2d,
        });
    }
    Ok(out)
}

/// Reads `points3D.txt`.
pub(crate) fn read_points3d(path: &Path, text: &str) -> Result<Vec<Point3D>> {
    let mut out = Vec::new();
    for (line, l) in records(text) {
        let mut t = Tokens::new(path, line, l);
        let point3d_id = t.parse::<u64>("bad POINT3D_ID")?;
        let xyz = [t.f64("bad X")?, t.f64("bad Y")?, t.f64("bad Z")?];
        let mut rgb = [0u8; 3];
        for c in &mut rgb {
            *c = t.parse::<u8>("colour must be an integer 0-255")?;
        }
        let error = t.f64("bad ERROR")?;
        let mut track = Vec::new();
        while let Some(tok) = t.it.next() {
            let image_id = tok
                .parse::<u32>()
                .map_err(|_| t.err("bad track IMAGE_ID"))?;
            let point2d_idx = t.parse::<u32>("bad or missing track POINT2D_IDX")?;
            track.push(TrackElement {
                image_id,
                point2d_idx,
            });
        }
        out.push(Point3D {
            point3d_id,
            xyz,
            rgb,
            error,
            track,
        });
    }
    Ok(out)
}

fn push_u(out: &mut String, v: impl std::fmt::Display) {
    use std::fmt::Write;
    let _ = write!(out, "{v}");
}

fn push_pose(out: &mut String, p: &RawPose) {
    for (i, v) in p.to_array().into_iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        push_g17(out, v);
    }
}

/// Serialises `cameras.txt` like COLMAP 4.2.
pub(crate) fn write_cameras(cams: &[CameraRecord]) -> String {
    let mut s = String::from(
        "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n# Number of cameras: ",
    );
    push_u(&mut s, cams.len());
    s.push('\n');
    for c in cams {
        push_u(&mut s, c.camera_id);
        s.push(' ');
        s.push_str(c.camera.model.name());
        s.push(' ');
        push_u(&mut s, c.camera.width);
        s.push(' ');
        push_u(&mut s, c.camera.height);
        for p in &c.camera.params {
            s.push(' ');
            push_g17(&mut s, *p);
        }
        s.push('\n');
    }
    s
}

/// Serialises `rigs.txt` like COLMAP 4.2.
pub(crate) fn write_rigs(rigs: &[Rig]) -> String {
    let mut s = String::from(
        "# Rig calib list with one line of data per calib:\n#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as (SENSOR_TYPE, SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])\n# Number of rigs: ",
    );
    push_u(&mut s, rigs.len());
    s.push('\n');
    for r in rigs {
        push_u(&mut s, r.rig_id);
        s.push(' ');
        push_u(&mut s, r.num_sensors());
        if let Some(reference) = r.ref_sensor {
            s.push(' ');
            s.push_str(reference.sensor_type.name());
            s.push(' ');
            push_u(&mut s, reference.id);
            for sensor in &r.sensors {
                s.push(' ');
                s.push_str(sensor.sensor.sensor_type.name());
                s.push(' ');
                push_u(&mut s, sensor.sensor.id);
                match &sensor.sensor_from_rig {
                    Some(p) => {
                        s.push_str(" 1 ");
                        push_pose(&mut s, p);
                    }
                    None => s.push_str(" 0"),
                }
            }
        }
        s.push('\n');
    }
    s
}

/// Serialises `frames.txt` like COLMAP 4.2.
pub(crate) fn write_frames(frames: &[Frame]) -> String {
    let mut s = String::from(
        "# Frame list with one line of data per frame:\n#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)\n# Number of frames: ",
    );
    push_u(&mut s, frames.len());
    s.push('\n');
    for f in frames {
        push_u(&mut s, f.frame_id);
        s.push(' ');
        push_u(&mut s, f.rig_id);
        s.push(' ');
        push_pose(&mut s, &f.rig_from_world);
        s.push(' ');
        push_u(&mut s, f.data_ids.len());
        for d in &f.data_ids {
            s.push(' ');
            s.push_str(d.sensor.sensor_type.name());
            s.push(' ');
            push_u(&mut s, d.sensor.id);
            s.push(' ');
            push_u(&mut s, d.id);
        }
        s.push('\n');
    }
    s
}

/// Serialises `images.txt` like COLMAP 4.2 (trailing space on non-empty POINTS2D lines).
pub(crate) fn write_images(images: &[Image], mean_observations: f64) -> String {
    let mut s = String::from(
        "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n# Number of images: ",
    );
    push_u(&mut s, images.len());
    s.push_str(", mean observations per image: ");
    push_g17(&mut s, mean_observations);
    s.push('\n');
    for im in images {
        push_u(&mut s, im.image_id);
        s.push(' ');
        push_pose(&mut s, &im.stored_cam_from_world);
        s.push(' ');
        push_u(&mut s, im.camera_id);
        s.push(' ');
        s.push_str(&im.name);
        s.push('\n');
        for p in &im.points2d {
            push_g17(&mut s, p.xy[0]);
            s.push(' ');
            push_g17(&mut s, p.xy[1]);
            s.push(' ');
            match p.point3d_id {
                Some(id) => push_u(&mut s, id),
                None => s.push_str("-1"),
            }
            s.push(' ');
        }
        s.push('\n');
    }
    s
}

/// Serialises `points3D.txt` like COLMAP 4.2.
pub(crate) fn write_points3d(points: &[Point3D], mean_track_length: f64) -> String {
    let mut s = String::from(
        "# 3D point list with one line of data per point:\n#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n# Number of points: ",
    );
    push_u(&mut s, points.len());
    s.push_str(", mean track length: ");
    push_g17(&mut s, mean_track_length);
    s.push('\n');
    for p in points {
        push_u(&mut s, p.point3d_id);
        for v in p.xyz {
            s.push(' ');
            push_g17(&mut s, v);
        }
        for c in p.rgb {
            s.push(' ');
            push_u(&mut s, c);
        }
        s.push(' ');
        push_g17(&mut s, p.error);
        if p.track.is_empty() {
            s.push(' ');
        }
        for t in &p.track {
            s.push(' ');
            push_u(&mut s, t.image_id);
            s.push(' ');
            push_u(&mut s, t.point2d_idx);
        }
        s.push('\n');
    }
    s
}
