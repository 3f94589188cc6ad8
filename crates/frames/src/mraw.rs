//! Photron recordings: a `.cih` (text) or `.cihx` (XML) header and the `.mraw` of the same
//! name beside it, frames stored one after another without gaps (grey, 8-bit, packed 12-bit
//! or 16-bit little-endian).

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use crate::bytes::{read_at, unpack};
use crate::error::io_err;
use crate::{
    FramesError, GreyFrame, Opened, PixelLayout, Result, SequenceInfo, Source, SourceKind,
    TimeSource, index_epochs,
};

/// The largest header read (bytes); real ones are a few tens of kB.
const MAX_HEADER_BYTES: u64 = 16 << 20;
/// Largest width or height accepted (px).
const MAX_SIDE: u32 = 1 << 16;

#[derive(Debug)]
pub(crate) struct MrawSource {
    file: File,
    path: PathBuf,
    layout: PixelLayout,
    frame_bytes: u64,
}

/// The header fields this reader uses, whichever of the two header formats stated them.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Header {
    pub width: u32,
    pub height: u32,
    pub total_frames: u64,
    pub color_bit: u32,
    pub effective_depth: Option<u32>,
    pub effective_side_higher: bool,
    pub record_rate_hz: Option<f64>,
    pub exposure_s: Option<f64>,
    pub start_frame: i64,
    pub trigger_frame: i64,
    pub save_step: u32,
    pub camera: Option<String>,
}

fn header_err(path: &Path, field: &'static str, problem: impl Into<String>) -> FramesError {
    FramesError::Header {
        path: path.to_path_buf(),
        field,
        problem: problem.into(),
    }
}

/// Looks up fields by name in a parsed header and converts them, with errors naming the field.
struct Fields<'a> {
    path: &'a Path,
    map: BTreeMap<String, String>,
}

impl Fields<'_> {
    fn text(&self, key: &'static str) -> Option<&str> {
        self.map
            .get(key)
            .map(|s| s.trim())
            .filter(|s| !s.is_empty())
    }
    fn required(&self, key: &'static str) -> Result<&str> {
        self.text(key)
            .ok_or_else(|| header_err(self.path, key, "missing"))
    }
    fn int<T: std::str::FromStr>(&self, key: &'static str) -> Result<Option<T>> {
        match self.text(key) {
            None => Ok(None),
            Some(v) => v
                .parse::<T>()
                .map(Some)
                .map_err(|_| header_err(self.path, key, format!("`{v}` is not an integer"))),
        }
    }
    fn required_int<T: std::str::FromStr>(&self, key: &'static str) -> Result<T> {
        self.int(key)?
            .ok_or_else(|| header_err(self.path, key, "missing"))
    }
    fn float(&self, key: &'static str) -> Result<Option<f64>> {
        match self.text(key) {
            None => Ok(None),
            Some(v) => parse_number(v)
                .map(Some)
                .ok_or_else(|| header_err(self.path, key, format!("`{v}` is not a number"))),
        }
    }
}

/// A positive finite number, or a fraction `a/b` of two (the `.cih` writes `1/800000`).
fn parse_number(v: &str) -> Option<f64> {
    let x = match v.split_once('/') {
        Some((a, b)) => a.trim().parse::<f64>().ok()? / b.trim().parse::<f64>().ok()?,
        None => v.parse::<f64>().ok()?,
    };
    x.is_finite().then_some(x)
}

/// `Key : Value` lines of a `.cih` (keys trimmed; the first occurrence of a key wins).
fn cih_fields(text: &str) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    for line in text.lines() {
        if let Some((k, v)) = line.split_once(':') {
            map.entry(k.trim().to_string())
                .or_insert_with(|| v.trim().to_string());
        }
    }
    map
}

/// Leaf texts of the `<cih>` element of a `.cihx` keyed by their path below it
/// (`frameInfo/totalFrame`); the first occurrence of a path wins.
fn cihx_fields(path: &Path, bytes: &[u8]) -> Result<BTreeMap<String, String>> {
    let find = |needle: &[u8]| bytes.windows(needle.len()).position(|w| w == needle);
    let (Some(start), Some(end)) = (find(b"<cih>"), find(b"</cih>")) else {
        return Err(header_err(
            path,
            "cih",
            "no <cih> … </cih> element in the file",
        ));
    };
    if end < start {
        return Err(header_err(path, "cih", "</cih> before <cih>"));
    }
    let xml = std::str::from_utf8(&bytes[start..end + b"</cih>".len()])
        .map_err(|e| header_err(path, "cih", format!("the XML is not UTF-8 ({e})")))?;
    let mut reader = quick_xml::Reader::from_str(xml);
    reader.config_mut().trim_text(true);
    let mut stack: Vec<String> = Vec::new();
    let mut map = BTreeMap::new();
    loop {
        use quick_xml::events::Event;
        let event = reader.read_event().map_err(|e| {
            header_err(
                path,
                "cih",
                format!(
                    "malformed XML at byte {}: {e}",
                    start as u64 + reader.error_position()
                ),
            )
        })?;
        match event {
            Event::Start(e) => {
                if stack.len() > 64 {
                    return Err(header_err(path, "cih", "elements nested more than 64 deep"));
                }
                stack.push(e.name().into_inner().to_string());
            }
            Event::End(_) => {
                stack.pop();
            }
            Event::Text(t) => {
                if stack.len() >= 2 {
                    let key = stack[1..].join("/");
                    map.entry(key)
                        .or_insert_with(|| t.xml10_content().trim().to_string());
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    Ok(map)
}

/// Reads the header file into the fields used, checking what this reader supports.
pub(crate) fn parse_header(path: &Path, bytes: &[u8], xml: bool) -> Result<Header> {
    let map = if xml {
        cihx_fields(path, bytes)?
    } else {
        cih_fields(&String::from_utf8_lossy(bytes))
    };
    let f = Fields { path, map };
    // (name in .cih, path in .cihx)
    let k = |cih: &'static str, cihx: &'static str| if xml { cihx } else { cih };
    let format = f.required(k("File Format", "imageFileInfo/fileFormat"))?;
    if !format.eq_ignore_ascii_case("mraw") {
        return Err(FramesError::Unsupported {
            path: path.to_path_buf(),
            what: format!("File Format `{format}` (MRaw is read)"),
        });
    }
    let colour = f.required(k("Color Type", "imageDataInfo/colorInfo/type"))?;
    // `Raw` is the sensor's values as stored (a monochrome camera's grey; a colour camera's
    // mosaic, which is read as it is, without demosaicing).
    if !colour.eq_ignore_ascii_case("mono") && !colour.eq_ignore_ascii_case("raw") {
        return Err(FramesError::Unsupported {
            path: path.to_path_buf(),
            what: format!("Color Type `{colour}` (Mono and Raw are read)"),
        });
    }
    let width_key = k("Image Width", "imageDataInfo/resolution/width");
    let height_key = k("Image Height", "imageDataInfo/resolution/height");
    let width: u32 = f.required_int(width_key)?;
    let height: u32 = f.required_int(height_key)?;
    for (key, v) in [(width_key, width), (height_key, height)] {
        if !(1..=MAX_SIDE).contains(&v) {
            return Err(header_err(
                path,
                key,
                format!("{v} is not in 1..={MAX_SIDE}"),
            ));
        }
    }
    let total_frames: u64 = f.required_int(k("Total Frame", "frameInfo/totalFrame"))?;
    if total_frames == 0 {
        return Err(header_err(
            path,
            k("Total Frame", "frameInfo/totalFrame"),
            "the recording holds no frame",
        ));
    }
    let color_bit: u32 = f.required_int(k("Color Bit", "imageDataInfo/colorInfo/bit"))?;
    let effective_depth: Option<u32> =
        f.int(k("EffectiveBit Depth", "imageDataInfo/effectiveBit/depth"))?;
    let side = f.text(k("EffectiveBit Side", "imageDataInfo/effectiveBit/side"));
    let effective_side_higher = side.is_some_and(|s| s.eq_ignore_ascii_case("higher"));
    let record_rate_hz = f
        .float(k("Record Rate(fps)", "recordInfo/recordRate"))?
        .filter(|r| *r > 0.0);
    // Exposure: the nanosecond field where present, else the shutter speed (1/s in .cihx,
    // a fraction of a second in .cih).
    let exposure_s = if xml {
        match f.float("recordInfo/shutterSpeedNsec")? {
            Some(ns) if ns > 0.0 => Some(ns * 1e-9),
            _ => f
                .float("recordInfo/shutterSpeed")?
                .filter(|s| *s > 0.0)
                .map(|s| 1.0 / s),
        }
    } else {
        match f.float("Shutter Type2(nsec)")? {
            Some(ns) if ns > 0.0 => Some(ns * 1e-9),
            _ => f.float("Shutter Speed(s)")?.filter(|s| *s > 0.0),
        }
    };
    let start_frame: i64 = f
        .int(k("Start Frame", "frameInfo/startFrame"))?
        .unwrap_or(0);
    let trigger_frame: i64 = f
        .int(k("Correct Trigger Frame", "frameInfo/correctTriggerFrame"))?
        .unwrap_or(0);
    let save_step: u32 = if xml {
        1
    } else {
        f.int("Save Step")?.unwrap_or(1)
    };
    if save_step == 0 {
        return Err(header_err(path, "Save Step", "0 (at least 1)"));
    }
    let camera = f
        .text(k("Camera Type", "deviceInfo/deviceName"))
        .map(str::to_string);
    Ok(Header {
        width,
        height,
        total_frames,
        color_bit,
        effective_depth,
        effective_side_higher,
        record_rate_hz,
        exposure_s,
        start_frame,
        trigger_frame,
        save_step,
        camera,
    })
}

pub(crate) fn open(path: &Path) -> Result<Opened> {
    let xml = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("cihx"));
    let file = File::open(path).map_err(io_err(path, "cannot open"))?;
    let len = file.metadata().map_err(io_err(path, "cannot open"))?.len();
    if len > MAX_HEADER_BYTES {
        return Err(header_err(
            path,
            "cih",
            format!("{len} bytes; a header file is at most {MAX_HEADER_BYTES}"),
        ));
    }
    let bytes = std::fs::read(path).map_err(io_err(path, "cannot read"))?;
    let h = parse_header(path, &bytes, xml)?;

    let (layout, bits) = match h.color_bit {
        8 => (PixelLayout::U8, 8),
        12 => (PixelLayout::Packed12, 12),
        16 => {
            // Effective bits stored in the low bits span 0..2^depth; in the high bits the
            // values as stored span all 16.
            let bits = match h.effective_depth {
                Some(d @ 9..=16) if !h.effective_side_higher => d as u8,
                _ => 16,
            };
            (PixelLayout::U16Le, bits)
        }
        b => {
            return Err(FramesError::Unsupported {
                path: path.to_path_buf(),
                what: format!("Color Bit {b} (8, 12 and 16 are read)"),
            });
        }
    };
    let pixels = u64::from(h.width) * u64::from(h.height);
    let Some(frame_bytes) = layout.bytes_for(pixels) else {
        return Err(FramesError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{} with {}x{} pixels (not a whole number of bytes per frame)",
                layout.name(),
                h.width,
                h.height
            ),
        });
    };

    let mraw_path = path.with_extension("mraw");
    let mraw = match File::open(&mraw_path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(FramesError::MissingMraw {
                header: path.to_path_buf(),
                mraw: mraw_path,
            });
        }
        Err(e) => return Err(io_err(&mraw_path, "cannot open")(e)),
    };
    let mraw_len = mraw
        .metadata()
        .map_err(io_err(&mraw_path, "cannot open"))?
        .len();
    let whole = mraw_len / frame_bytes;
    if whole < h.total_frames {
        return Err(FramesError::Truncated {
            path: mraw_path,
            part: format!("frame {whole}"),
            needed: (whole + 1) * frame_bytes,
            len: mraw_len,
        });
    }
    let n = usize::try_from(h.total_frames)
        .map_err(|_| header_err(path, "Total Frame", format!("{} frames", h.total_frames)))?;
    let times_s = h.record_rate_hz.map(|rate| {
        (0..n)
            .map(|i| {
                let number = h.start_frame + i as i64 * i64::from(h.save_step);
                (number - h.trigger_frame) as f64 / rate
            })
            .collect()
    });
    let info = SequenceInfo {
        path: path.to_path_buf(),
        kind: SourceKind::Mraw,
        frames: n,
        width: h.width,
        height: h.height,
        bits,
        layout,
        frame_rate_hz: h.record_rate_hz,
        exposure_s: h.exposure_s,
        trigger_utc: None,
        trigger_frame: Some(h.trigger_frame),
        first_image_number: Some(h.start_frame),
        frame_step: Some(h.save_step),
        camera: h.camera.clone(),
        time_source: if times_s.is_some() {
            TimeSource::FrameRate
        } else {
            TimeSource::None
        },
    };
    Ok(Opened {
        info,
        epochs: index_epochs(n),
        times_s,
        source: Source::Mraw(MrawSource {
            file: mraw,
            path: mraw_path,
            layout,
            frame_bytes,
        }),
    })
}

impl MrawSource {
    pub(crate) fn read(
        &self,
        index: usize,
        info: &SequenceInfo,
        into: &mut GreyFrame,
    ) -> Result<()> {
        let mut raw = vec![0u8; self.frame_bytes as usize];
        let at = index as u64 * self.frame_bytes;
        read_at(&self.file, &self.path, at, &mut raw).map_err(|e| match e {
            FramesError::Io { source, .. }
                if source.kind() == std::io::ErrorKind::UnexpectedEof =>
            {
                FramesError::Truncated {
                    path: self.path.clone(),
                    part: format!("frame {index}"),
                    needed: at + self.frame_bytes,
                    len: self.file.metadata().map(|m| m.len()).unwrap_or(0),
                }
            }
            e => e,
        })?;
        let out = into.reshape(info.width, info.height, info.bits);
        unpack(self.layout, &raw, out);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_number_nominal() {
        assert_eq!(parse_number("60000"), Some(60000.0));
        assert_eq!(parse_number("1/800000"), Some(1.0 / 800000.0));
        assert_eq!(parse_number("1/0"), None);
        assert_eq!(parse_number("x"), None);
    }

    #[test]
    fn cih_fields_first_wins_and_trims() {
        let m = cih_fields(
            "#Camera Information Header\nRecord Rate(fps) : 60000\nPartition Number: 1\nA : 1\nA : 2\n",
        );
        assert_eq!(m["Record Rate(fps)"], "60000");
        assert_eq!(m["Partition Number"], "1");
        assert_eq!(m["A"], "1");
    }
}
