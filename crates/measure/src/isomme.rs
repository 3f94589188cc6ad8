//! A `crashrig measure` output as an ISO/TS 13499 (ISO-MME, RED 1.6) test: the library entry of
//! `crashrig export iso-mme` ([`export`]).
//!
//! # What is written
//! - `T.mme`: the test (data format edition 1.6, test reference `T`, one test object);
//! - `Channel/T.chn`: the channel list (`Name of channel NNN : <code> / <name>`);
//! - `Channel/T.001`, `T.002`, …: per marker, in marker order, the displacement channels X, Y, Z
//!   (physical dimension `DS`, unit `m`) and then their σ channels X, Y, Z (dimension `1S`,
//!   unit `m`).
//!
//! Every channel has an implicit time axis: `Sampling interval = 1/frame rate` (s),
//! `Time of first sample` = the first measured epoch's time (frame number / frame rate), one
//! sample per frame from the first to the last measured frame; a frame where the marker has
//! no value is `NOVALUE`. Numbers are written with Rust's shortest round-trip formatting, so
//! a reader recovers the metres of the measure output exactly. Lines end with LF (as the
//! reference implementation pyisomme writes them).
//!
//! # The data
//! The displacement comes from `kinematics.csv` when the measure run filtered it
//! (`--cfc`; its filtered nominal series and σ over the replicates), else from
//! `displacements.csv` (raw displacements from the reference epoch). A measure output without
//! a frame rate (`summary.json` → `frame_rate_hz` null) has no time axis and is refused.
//!
//! # Axes: `vehicle_from_world`
//! ISO-MME directions X, Y, Z are SAE J211 vehicle axes: x forward, y to the right, z down.
//! [`ExportConfig::vehicle_from_world`] is the rotation `R` with `x_vehicle = R · x_world`
//! (identity: the model's world frame already is the vehicle frame; the CLI takes it as
//! ω φ κ in degrees, `R = Rx(ω)·Ry(φ)·Rz(κ)`). Displacements are differences of positions, so
//! the translation of the frame change cancels and only `R` is needed. The σ of a vehicle axis
//! is `sqrt(Σⱼ R_ij² σ_j²)`: exact when `R` permutes and flips axes (the usual case: a lab
//! frame aligned with the vehicle), otherwise it neglects the correlation between the world
//! axes that the per-axis σ of the measure output does not carry — [`Export::warnings`] says
//! so.
//!
//! # Channel codes
//! A code is 16 characters: test object, seat position, main location (4), fine locations
//! 1–3 (2 each), physical dimension (2), direction, filter class. The default of the marker
//! with (1-based) number `NNNN` in marker order is `10VEHC00NNNN` + dimension + direction +
//! class: vehicle 1, position undefined, main location *Vehicle*, fine location 1 undefined,
//! fine locations 2 and 3 = the marker number. A channel map (`--channel-map`, CSV with the
//! header `marker,code`) gives a marker its own code; crashrig replaces the code's last four
//! characters (dimension, direction, filter class), so a map may write them as `????`.
//!
//! # Filter class letter and the σ dimension
//! - Displacements measured from film that were not filtered carry `V` (*data from film
//!   (video) analysis*). Filtered with `--cfc`, they carry the letter of the class
//!   (`A` = CFC 1000, `B` = 600, `C` = 180, `D` = 60) and `Channel frequency class` in the
//!   header; the film origin is then in the channel's `Comments` and `Transducer type`.
//! - The code list has no dimension for an uncertainty. The σ channels use the
//!   **laboratory-specific** dimension `1S` (codes `1?` are reserved for laboratory-specific
//!   dimensions): a reader that does not know it sees a non-standard channel instead of
//!   mistaking a σ for a displacement (as `DS` with a comment would let happen), and the
//!   direction letter still pairs each σ with its displacement channel.
//!
//! # Example
//! ```
//! use crashrig_measure::isomme::{export, ExportConfig};
//! let dir = tempfile::tempdir()?;
//! std::fs::write(dir.path().join("summary.json"), r#"{"frame_rate_hz": 1000.0}"#)?;
//! std::fs::write(
//!     dir.path().join("displacements.csv"),
//!     "epoch,marker,time_s,dx_mm,dy_mm,dz_mm,sigma_dx_mm,sigma_dy_mm,sigma_dz_mm\n\
//!      0010,head,0.01,0,0,0,0,0,0\n\
//!      0011,head,0.011,1.5,0,-2,0.25,0.25,0.5\n",
//! )?;
//! let e = export(&ExportConfig::new(dir.path(), "T42"))?;
//! assert_eq!(e.channels.len(), 6);
//! assert_eq!(e.channels[0].code, "10VEHC000001DSXV");
//! let (_, x) = e.files.iter().find(|(n, _)| n == "Channel/T42.001").unwrap();
//! let text = String::from_utf8(x.clone())?;
//! assert!(text.contains("Time of first sample        :0.01\n"));
//! assert!(text.ends_with("\n0\n0.0015\n"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::Error;
use crate::input::{read_json, read_text};
use crashrig_geometry::{Mat3, Vec3};
use crashrig_input::file as input_file;
use serde_json::Value;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The most samples one channel may have (frames from the first to the last measured epoch).
pub const MAX_SAMPLES: usize = 10_000_000;
/// The most channels a test may have (the channel files are numbered with three digits).
pub const MAX_CHANNELS: usize = 999;

/// What to export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportConfig {
    /// A `crashrig measure` output directory.
    pub measure_dir: PathBuf,
    /// The test number `T` (file names `T.mme`, `Channel/T.chn`, …): letters, digits, `-`, `_`.
    pub test_number: String,
    /// CSV `marker,code` of channel codes, if any.
    pub channel_map: Option<PathBuf>,
    /// `R_vehicle_from_world` (module docs).
    pub vehicle_from_world: Mat3,
}

impl ExportConfig {
    /// Export of `measure_dir` as test `test_number`, default codes, identity axes.
    pub fn new(measure_dir: impl Into<PathBuf>, test_number: impl Into<String>) -> ExportConfig {
        ExportConfig {
            measure_dir: measure_dir.into(),
            test_number: test_number.into(),
            channel_map: None,
            vehicle_from_world: Mat3::identity(),
        }
    }
}

/// One written channel.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelInfo {
    /// Its file name (`Channel/T.NNN`).
    pub file: String,
    /// The 16-character code.
    pub code: String,
    /// The marker.
    pub marker: String,
    /// Number of samples.
    pub samples: usize,
}

/// The files of an ISO-MME test (paths relative to the output directory) and what they hold.
#[derive(Debug, Clone, PartialEq)]
pub struct Export {
    /// `(relative path, bytes)`, `T.mme` first.
    pub files: Vec<(String, Vec<u8>)>,
    /// The channels in file order.
    pub channels: Vec<ChannelInfo>,
    /// The source file of the displacements (`kinematics.csv` or `displacements.csv`).
    pub source: String,
    /// The filter class letter of the displacement channels.
    pub filter_class: char,
    /// Things the user should know (one line each, without the `warning: ` prefix).
    pub warnings: Vec<String>,
}

/// One marker's displacement (m) and σ (m) per sample, in vehicle axes.
struct Series {
    d: Vec<Option<Vec3>>,
    s: Vec<Option<Vec3>>,
}

/// Reads a measure output and forms the ISO-MME files (nothing is written: the caller writes
/// [`Export::files`] as one unit).
///
/// # Errors
/// [`Error::Setting`] for a bad test number; [`Error::Json`] for a `summary.json` without a
/// frame rate; [`Error::Csv`] naming file and line for a bad displacement row or channel-map
/// row (a code that is not 16 characters of letters, digits or `?`, an unknown or repeated
/// marker); [`Error::Io`] for a missing file; [`Error::Input`] when the sizes exceed
/// [`MAX_SAMPLES`] or [`MAX_CHANNELS`] or two markers get one code.
pub fn export(cfg: &ExportConfig) -> Result<Export, Error> {
    check_test_number(&cfg.test_number)?;
    let dir = &cfg.measure_dir;
    let summary_path = dir.join("summary.json");
    let summary: Value = read_json(&summary_path)?;
    let hz = summary
        .get("frame_rate_hz")
        .and_then(Value::as_f64)
        .filter(|h| h.is_finite() && *h > 0.0)
        .ok_or_else(|| Error::Json {
            path: summary_path.clone(),
            key: "frame_rate_hz".into(),
            problem: "no frame rate: the measure run had no --frame-rate-hz, so its displacements have no time axis for ISO-MME (run measure with --frame-rate-hz)".into(),
        })?;
    let cfc = summary
        .get("kinematics")
        .and_then(|k| k.get("cfc"))
        .and_then(Value::as_u64);
    let standard = summary
        .get("kinematics")
        .and_then(|k| k.get("standard"))
        .and_then(Value::as_str)
        .map(str::to_string);
    let kin = dir.join("kinematics.csv");
    // Any entry of that name is the source (a FIFO or device there is refused by the reader,
    // not silently passed over for the raw displacements).
    let (source, csv_path) = if kin.exists() {
        ("kinematics.csv", kin)
    } else {
        ("displacements.csv", dir.join("displacements.csv"))
    };
    // With frame times (`measure --frame-times`): the axis starts at the file's first frame
    // and steps by its mean interval; every row must sit on that axis.
    let axis = summary.get("frame_times").and_then(|f| {
        Some((
            f.get("first_time_s")?.as_f64()?,
            f.get("mean_interval_s")?.as_f64()?,
        ))
    });
    let rows = read_rows(&csv_path, hz, axis)?;
    let filter_class = match cfc {
        Some(1000) => 'A',
        Some(600) => 'B',
        Some(180) => 'C',
        Some(60) => 'D',
        _ => 'V',
    };

    // Markers in order of first appearance; frames.
    let mut markers: Vec<String> = Vec::new();
    for r in &rows {
        if !markers.contains(&r.marker) {
            markers.push(r.marker.clone());
        }
    }
    let Some(first) = rows.iter().map(|r| r.frame).min() else {
        return Err(Error::Input(format!(
            "{}: no rows to export",
            csv_path.display()
        )));
    };
    let last = rows.iter().map(|r| r.frame).max().unwrap_or(first);
    let span = usize::try_from(last - first)
        .ok()
        .and_then(|s| s.checked_add(1))
        .filter(|&s| s <= MAX_SAMPLES)
        .ok_or_else(|| {
            Error::Input(format!(
                "{}: the epochs span frames {first} to {last}, more than {MAX_SAMPLES} samples per channel",
                csv_path.display()
            ))
        })?;
    if 6 * markers.len() > MAX_CHANNELS {
        return Err(Error::Input(format!(
            "{}: {} markers need {} channels; ISO-MME numbers at most {MAX_CHANNELS}",
            csv_path.display(),
            markers.len(),
            6 * markers.len()
        )));
    }
    let codes = channel_codes(cfg.channel_map.as_deref(), &markers)?;

    // Series in vehicle axes (m).
    let r = cfg.vehicle_from_world;
    let r2 = r.map(|v| v * v);
    let mut warnings = Vec::new();
    if !is_signed_permutation(&r) {
        warnings.push(
            "vehicle_from_world is not an axis permutation: the σ channels assume uncorrelated world axes (the measure output carries per-axis σ only)".into(),
        );
    }
    let mut series: Vec<Series> = markers
        .iter()
        .map(|_| Series {
            d: vec![None; span],
            s: vec![None; span],
        })
        .collect();
    for row in &rows {
        let k = markers.iter().position(|m| m == &row.marker).unwrap_or(0);
        let i = usize::try_from(row.frame - first).unwrap_or(0);
        series[k].d[i] = row.d_mm.map(|d| r * d / 1000.0);
        series[k].s[i] = row
            .s_mm
            .map(|s| (r2 * s.component_mul(&s)).map(f64::sqrt) / 1000.0);
    }

    let filtered = cfc.map(|c| {
        format!(
            "CFC {c} ({})",
            standard.as_deref().unwrap_or("j211").to_uppercase()
        )
    });
    let (files, channels) = test_files(&Test {
        t: &cfg.test_number,
        source,
        hz,
        first_time: match axis {
            Some((t0, dt)) => t0 + first as f64 * dt,
            None => first as f64 / hz,
        },
        cfc,
        filtered: filtered.as_deref(),
        filter_class,
        markers: &markers,
        codes: &codes,
        series: &series,
        span,
    });
    Ok(Export {
        files,
        channels,
        source: source.into(),
        filter_class,
        warnings,
    })
}

/// What [`test_files`] writes.
struct Test<'a> {
    t: &'a str,
    source: &'a str,
    hz: f64,
    first_time: f64,
    cfc: Option<u64>,
    filtered: Option<&'a str>,
    filter_class: char,
    markers: &'a [String],
    codes: &'a [String],
    series: &'a [Series],
    span: usize,
}

/// `T.mme`, `Channel/T.chn` and the channel files, with the channels' descriptions.
fn test_files(x: &Test<'_>) -> (Vec<(String, Vec<u8>)>, Vec<ChannelInfo>) {
    let Test {
        t,
        source,
        hz,
        first_time,
        cfc,
        filtered,
        filter_class,
        markers,
        codes,
        series,
        span,
    } = *x;
    let mut files = vec![(format!("{t}.mme"), mme_file(t, source).into_bytes())];
    let mut channels = Vec::new();
    let mut chn = String::new();
    header(
        &mut chn,
        "Number of channels",
        &(6 * markers.len()).to_string(),
    );
    for (k, marker) in markers.iter().enumerate() {
        for (dim, what) in [("DS", "displacement"), ("1S", "sigma of displacement")] {
            for (axis, dir) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                let n = channels.len() + 1;
                let code = format!("{}{dim}{dir}{filter_class}", &codes[k][..12]);
                let name = format!("{marker} {what} {dir}");
                header(
                    &mut chn,
                    &format!("Name of channel {n:03}"),
                    &format!("{code} / {name}"),
                );
                let values: Vec<Option<f64>> = if dim == "DS" {
                    series[k].d.iter().map(|v| v.map(|v| v[axis])).collect()
                } else {
                    series[k].s.iter().map(|v| v.map(|v| v[axis])).collect()
                };
                let file = format!("Channel/{t}.{n:03}");
                let text = channel_file(&ChannelText {
                    name: &name,
                    code: &code,
                    hz,
                    first_time,
                    cfc,
                    filtered,
                    sigma: dim == "1S",
                    values: &values,
                });
                files.push((file.clone(), text.into_bytes()));
                channels.push(ChannelInfo {
                    file,
                    code,
                    marker: marker.clone(),
                    samples: span,
                });
            }
        }
    }
    files.insert(1, (format!("Channel/{t}.chn"), chn.into_bytes()));
    (files, channels)
}

fn check_test_number(t: &str) -> Result<(), Error> {
    let ok = !t.is_empty()
        && t.len() <= 64
        && t.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(())
    } else {
        Err(Error::Setting {
            name: "--test-number",
            problem: format!(
                "`{t}` must be 1 to 64 letters, digits, `-` or `_` (it names the files)"
            ),
        })
    }
}

fn is_signed_permutation(r: &Mat3) -> bool {
    r.row_iter()
        .all(|row| row.iter().filter(|v| v.abs() > 1e-12).count() == 1)
}

/// One displacement row of the measure output.
struct Row {
    marker: String,
    frame: u64,
    d_mm: Option<Vec3>,
    s_mm: Option<Vec3>,
}

/// The displacement rows of `path`; each row's frame is `time_s · hz`, or with `axis`
/// (`(first_time_s, interval_s)` of the frame times) `(time_s − first) / interval`, which must
/// be a whole frame to within [`crate::input::MAX_INTERVAL_DEVIATION`] of an interval.
fn read_rows(path: &Path, hz: f64, axis: Option<(f64, f64)>) -> Result<Vec<Row>, Error> {
    let text = read_text(path, input_file::MAX_CSV_BYTES)?;
    let bad = |line: u64, problem: String| Error::Csv {
        path: path.to_path_buf(),
        line,
        problem,
    };
    let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| bad(1, e.to_string()))?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| bad(1, format!("no column `{name}`")))
    };
    let names = [
        "marker",
        "time_s",
        "dx_mm",
        "dy_mm",
        "dz_mm",
        "sigma_dx_mm",
        "sigma_dy_mm",
        "sigma_dz_mm",
    ];
    let idx: Vec<usize> = names.iter().map(|n| col(n)).collect::<Result<_, _>>()?;
    let mut rows = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let line = i as u64 + 2;
        let rec = rec.map_err(|e| bad(line, e.to_string()))?;
        let field = |k: usize| rec.get(idx[k]).unwrap_or("").trim();
        let num = |k: usize| -> Result<Option<f64>, Error> {
            let f = field(k);
            if f.is_empty() {
                return Ok(None);
            }
            match f.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(bad(line, format!("{}: `{f}` is not a number", names[k]))),
            }
        };
        let time = num(1)?.ok_or_else(|| bad(line, "time_s is empty".into()))?;
        let frame = match axis {
            Some((t0, dt)) => {
                let f = ((time - t0) / dt).round();
                let off = (time - (t0 + f * dt)).abs() / dt;
                if off > crate::input::MAX_INTERVAL_DEVIATION {
                    return Err(bad(
                        line,
                        format!(
                            "time_s {time} lies {:.1} % of an interval off the frame axis {t0} s + k · {dt} s of the measure run's frame times: an ISO-MME channel has one sampling interval",
                            100.0 * off
                        ),
                    ));
                }
                f
            }
            None => (time * hz).round(),
        };
        if !(0.0..=9.0e15).contains(&frame) {
            return Err(bad(line, format!("time_s {time} is not a frame time ≥ 0")));
        }
        let v3 = |a: usize| -> Result<Option<Vec3>, Error> {
            Ok(match (num(a)?, num(a + 1)?, num(a + 2)?) {
                (Some(x), Some(y), Some(z)) => Some(Vec3::new(x, y, z)),
                _ => None,
            })
        };
        rows.push(Row {
            marker: field(0).to_string(),
            frame: frame as u64,
            d_mm: v3(2)?,
            s_mm: v3(5)?,
        });
    }
    Ok(rows)
}

/// The 16-character code of each marker (the last four characters are replaced later).
fn channel_codes(map: Option<&Path>, markers: &[String]) -> Result<Vec<String>, Error> {
    let mut codes: Vec<String> = (1..=markers.len())
        .map(|n| format!("10VEHC00{n:04}????"))
        .collect();
    if let Some(path) = map {
        let text = read_text(path, input_file::MAX_CSV_BYTES)?;
        let bad = |line: u64, problem: String| Error::Csv {
            path: path.to_path_buf(),
            line,
            problem,
        };
        let mut lines = text.lines();
        let head = lines.next().unwrap_or("").trim();
        if head != "marker,code" {
            return Err(bad(1, format!("header `{head}`, expected `marker,code`")));
        }
        let mut seen: BTreeMap<String, u64> = BTreeMap::new();
        for (i, l) in lines.enumerate() {
            let line = i as u64 + 2;
            if l.trim().is_empty() {
                continue;
            }
            let (marker, code) = l
                .rsplit_once(',')
                .ok_or_else(|| bad(line, "expected `marker,code`".into()))?;
            let (marker, code) = (marker.trim().trim_matches('"'), code.trim());
            if code.chars().count() != 16
                || !code.chars().all(|c| c.is_ascii_alphanumeric() || c == '?')
            {
                return Err(bad(
                    line,
                    format!(
                        "code `{code}` is not 16 characters of letters, digits or `?` ({} characters)",
                        code.chars().count()
                    ),
                ));
            }
            let Some(k) = markers.iter().position(|m| m == marker) else {
                return Err(bad(
                    line,
                    format!("marker `{marker}` is not a marker of the measure output"),
                ));
            };
            if let Some(prev) = seen.insert(marker.to_string(), line) {
                return Err(bad(
                    line,
                    format!("marker `{marker}` already has a code on line {prev}"),
                ));
            }
            codes[k] = code.to_string();
        }
    }
    for (i, a) in codes.iter().enumerate() {
        if let Some(j) = codes[..i].iter().position(|b| b[..12] == a[..12]) {
            return Err(Error::Input(format!(
                "markers `{}` and `{}` have the same channel code {}…",
                markers[j],
                markers[i],
                &a[..12]
            )));
        }
    }
    Ok(codes)
}

/// `Name                        :value` (the name padded to 28 characters).
fn header(s: &mut String, name: &str, value: &str) {
    let _ = writeln!(s, "{name:<28}:{value}");
}

fn mme_file(t: &str, source: &str) -> String {
    let mut s = String::new();
    header(&mut s, "Data format edition number", "1.6");
    header(&mut s, "Laboratory name", "NOVALUE");
    header(&mut s, "Customer name", "NOVALUE");
    header(
        &mut s,
        "Title",
        &format!("crashrig film analysis ({source})"),
    );
    header(&mut s, "Medium No./number of media", "1/1");
    header(&mut s, "Laboratory test ref. number", t);
    header(&mut s, "Number of test objects", "1");
    header(&mut s, "Name of test object 1", "Vehicle 1");
    header(&mut s, "Comments", "written by crashrig export iso-mme");
    s
}

struct ChannelText<'a> {
    name: &'a str,
    code: &'a str,
    hz: f64,
    first_time: f64,
    cfc: Option<u64>,
    filtered: Option<&'a str>,
    sigma: bool,
    values: &'a [Option<f64>],
}

fn channel_file(c: &ChannelText<'_>) -> String {
    let mut s = String::with_capacity(64 * 24 + c.values.len() * 24);
    header(&mut s, "Name of the channel", c.name);
    header(&mut s, "Laboratory channel code", "NOVALUE");
    header(&mut s, "Customer channel code", "NOVALUE");
    header(&mut s, "Channel code", c.code);
    header(&mut s, "Unit", "m");
    header(
        &mut s,
        "Reference system",
        "SAE J211 vehicle axes (crashrig vehicle_from_world)",
    );
    header(
        &mut s,
        "Transducer type",
        "film analysis (crashrig measure)",
    );
    header(&mut s, "Sampling interval", &format!("{}", 1.0 / c.hz));
    header(&mut s, "Time of first sample", &format!("{}", c.first_time));
    header(&mut s, "Number of samples", &c.values.len().to_string());
    header(&mut s, "Reference channel", "implicit");
    header(
        &mut s,
        "Channel frequency class",
        &c.cfc.map_or("NOVALUE".into(), |v| v.to_string()),
    );
    let mut comment = match c.filtered {
        Some(f) => format!("film analysis, filtered {f} in every Monte Carlo replicate"),
        None => "film analysis, unfiltered".into(),
    };
    if c.sigma {
        comment.push_str(
            "; laboratory-specific dimension 1S: standard deviation (1 sigma, Monte Carlo) of the displacement channel with the same direction",
        );
    }
    header(&mut s, "Comments", &comment);
    for v in c.values {
        match v {
            Some(v) => {
                let _ = writeln!(s, "{v}");
            }
            None => s.push_str("NOVALUE\n"),
        }
    }
    s
}
