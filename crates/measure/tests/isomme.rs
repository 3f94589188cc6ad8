//! ISO-MME export: a Rust round trip (always) and pyisomme reading the files back (where
//! Python with pyisomme is available: `PYISOMME_PYTHON`, else `/work/venv-isomme/bin/python`).

use crashrig_geometry::Mat3;
use crashrig_measure::isomme::{ExportConfig, export};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const KIN_HEADER: &str = crashrig_measure::output::KINEMATICS_HEADER;

/// A measure output with kinematics: markers `head` (frames 10..=15, frame 13 blank) and
/// `knee L` (frames 11..=14), CFC 180, 1000 frames/s.
fn measure_dir(dir: &Path) {
    std::fs::write(
        dir.join("summary.json"),
        r#"{"frame_rate_hz": 1000.0, "kinematics": {"cfc": 180, "standard": "iso6487"}}"#,
    )
    .unwrap();
    let mut csv = format!("{KIN_HEADER}\n");
    for f in 10..=15_u32 {
        let t = f64::from(f) / 1000.0;
        let row = |m: &str, k: f64, blank: bool| {
            let v = |x: f64| if blank { String::new() } else { format!("{x}") };
            let d = [0.1 * k * f64::from(f), -0.37 * k, 1234.5678 + k / 3.0];
            let s = [0.01 * k, 0.02, 0.0301 * k];
            let mut cols = vec![m.to_string(), format!("{t}")];
            cols.extend(d.iter().chain(&s).map(|&x| v(x)));
            cols.extend(std::iter::repeat_n(String::new(), 12));
            format!("{f:04},{}\n", cols.join(","))
        };
        csv.push_str(&row("head", 1.0, f == 13));
        if (11..=14).contains(&f) {
            csv.push_str(&row("\"knee L\"", 2.0, false));
        }
    }
    std::fs::write(dir.join("kinematics.csv"), csv).unwrap();
}

/// A channel file: its header and its values (None for NOVALUE).
fn parse_channel(text: &str) -> (BTreeMap<String, String>, Vec<Option<f64>>) {
    let mut header = BTreeMap::new();
    let mut values = Vec::new();
    for line in text.lines() {
        match line.split_once(':') {
            Some((k, v)) if values.is_empty() => {
                header.insert(k.trim().to_string(), v.to_string());
            }
            _ => values.push(if line == "NOVALUE" {
                None
            } else {
                Some(line.parse::<f64>().unwrap())
            }),
        }
    }
    (header, values)
}

#[test]
fn round_trip_values_codes_and_axes() {
    let dir = tempfile::tempdir().unwrap();
    measure_dir(dir.path());
    // Vehicle axes: x_v = −y_w, y_v = x_w, z_v = z_w (a signed permutation).
    let mut cfg = ExportConfig::new(dir.path(), "T1");
    cfg.vehicle_from_world = Mat3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let e = export(&cfg).unwrap();
    assert!(e.warnings.is_empty());
    assert_eq!((e.source.as_str(), e.filter_class), ("kinematics.csv", 'C'));
    assert_eq!(e.channels.len(), 12);
    let files: BTreeMap<&str, &[u8]> = e
        .files
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    assert!(files.contains_key("T1.mme") && files.contains_key("Channel/T1.chn"));
    let chn = std::str::from_utf8(files["Channel/T1.chn"]).unwrap();
    assert!(chn.starts_with("Number of channels          :12\n"));
    assert!(chn.contains("Name of channel 001         :10VEHC000001DSXC / head displacement X\n"));
    assert!(chn.contains(
        "Name of channel 010         :10VEHC0000021SXC / knee L sigma of displacement X\n"
    ));
    // head X displacement = −(world y) = 0.37 mm → 0.00037 m; frame 13 NOVALUE.
    let (h, v) = parse_channel(std::str::from_utf8(files["Channel/T1.001"]).unwrap());
    assert_eq!(h["Channel code"], "10VEHC000001DSXC");
    assert_eq!(h["Unit"], "m");
    assert_eq!(h["Sampling interval"], "0.001");
    assert_eq!(h["Time of first sample"], "0.01");
    assert_eq!(h["Number of samples"], "6");
    assert_eq!(h["Channel frequency class"], "180");
    let want: Vec<Option<f64>> = (10..=15)
        .map(|f| (f != 13).then_some(0.37 / 1000.0))
        .collect();
    assert_eq!(v, want);
    // head Y displacement = world x = 0.1·f mm, exactly as the CSV's number / 1000.
    let (_, v) = parse_channel(std::str::from_utf8(files["Channel/T1.002"]).unwrap());
    assert_eq!(v[0], Some(0.1 * 10.0 / 1000.0));
    // knee σ Y = world σx = 0.02 mm; its first frame (10) is NOVALUE.
    let (h, v) = parse_channel(std::str::from_utf8(files["Channel/T1.011"]).unwrap());
    assert_eq!(h["Channel code"], "10VEHC0000021SYC");
    assert_eq!(v[0], None);
    assert_eq!(v[1], Some(0.01 * 2.0 / 1000.0));
}

#[test]
fn channel_map_codes_and_bad_maps() {
    let dir = tempfile::tempdir().unwrap();
    measure_dir(dir.path());
    let map = dir.path().join("codes.csv");
    let mut cfg = ExportConfig::new(dir.path(), "T2");
    cfg.channel_map = Some(map.clone());
    std::fs::write(&map, "marker,code\nhead,11HEAD0000H3????\n").unwrap();
    let e = export(&cfg).unwrap();
    assert_eq!(e.channels[0].code, "11HEAD0000H3DSXC");
    assert_eq!(
        e.channels[6].code, "10VEHC000002DSXC",
        "unmapped markers keep the default"
    );
    for (text, needle) in [
        (
            "marker,code\nhead,11HEAD0000H3??\n",
            ":2: code `11HEAD0000H3??` is not 16",
        ),
        (
            "marker,code\nneck,11HEAD0000H3????\n",
            ":2: marker `neck` is not a marker",
        ),
        (
            "marker,code\nhead,11HEAD0000H3????\nhead,11HEAD0000H4????\n",
            ":3: marker `head` already",
        ),
        ("name,code\n", ":1: header"),
    ] {
        std::fs::write(&map, text).unwrap();
        let msg = crashrig_input::message::error_line(&export(&cfg).unwrap_err());
        assert!(msg.contains("codes.csv") && msg.contains(needle), "{msg}");
    }
}

#[test]
fn refuses_a_measure_output_without_a_frame_rate() {
    let dir = tempfile::tempdir().unwrap();
    measure_dir(dir.path());
    std::fs::write(
        dir.path().join("summary.json"),
        r#"{"frame_rate_hz": null}"#,
    )
    .unwrap();
    let msg = crashrig_input::message::error_line(
        &export(&ExportConfig::new(dir.path(), "T3")).unwrap_err(),
    );
    assert!(
        msg.contains("summary.json") && msg.contains("frame_rate_hz"),
        "{msg}"
    );
    let msg = crashrig_input::message::error_line(
        &export(&ExportConfig::new(dir.path(), "../x")).unwrap_err(),
    );
    assert!(msg.contains("--test-number"), "{msg}");
}

/// Every input of the export is read through `crashrig_input::file::read_limited`: a
/// FIFO (reading it would wait for a writer for ever) and a file larger than its kind's limit
/// (a sparse file: nothing is written to disk) are refused with the file named, without
/// blocking and before anything is allocated.
#[test]
fn refuses_fifos_and_oversize_inputs() {
    use crashrig_input::file::{MAX_CSV_BYTES, MAX_JSON_BYTES};
    let dir = tempfile::tempdir().unwrap();
    let oversize = |name: &str, limit: u64| {
        measure_dir(dir.path());
        let path = dir.path().join(name);
        std::fs::File::create(&path)
            .unwrap()
            .set_len(limit + 1)
            .unwrap();
        let msg = crashrig_input::message::error_line(
            &export(&ExportConfig::new(dir.path(), "T4")).unwrap_err(),
        );
        assert!(
            msg.contains(name) && msg.contains("larger than the limit"),
            "{msg}"
        );
    };
    oversize("kinematics.csv", MAX_CSV_BYTES);
    oversize("summary.json", MAX_JSON_BYTES);
    #[cfg(unix)]
    {
        let fifo = |path: &Path| {
            let _ = std::fs::remove_file(path);
            let ok = std::process::Command::new("mkfifo")
                .arg(path)
                .status()
                .unwrap()
                .success();
            assert!(ok, "mkfifo {}", path.display());
        };
        measure_dir(dir.path());
        fifo(&dir.path().join("kinematics.csv"));
        let msg = crashrig_input::message::error_line(
            &export(&ExportConfig::new(dir.path(), "T5")).unwrap_err(),
        );
        assert!(
            msg.contains("kinematics.csv") && msg.contains("not a regular file"),
            "{msg}"
        );
        measure_dir_fresh(dir.path());
        let map = dir.path().join("codes.csv");
        fifo(&map);
        let mut cfg = ExportConfig::new(dir.path(), "T6");
        cfg.channel_map = Some(map);
        let msg = crashrig_input::message::error_line(&export(&cfg).unwrap_err());
        assert!(
            msg.contains("codes.csv") && msg.contains("not a regular file"),
            "{msg}"
        );
    }
}

/// [`measure_dir`] after removing a FIFO left in its place.
#[cfg(unix)]
fn measure_dir_fresh(dir: &Path) {
    let _ = std::fs::remove_file(dir.join("kinematics.csv"));
    measure_dir(dir);
}

fn python() -> Option<PathBuf> {
    let p = std::env::var_os("PYISOMME_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/work/venv-isomme/bin/python"));
    p.exists().then_some(p)
}

#[test]
fn pyisomme_reads_the_files_back() {
    let Some(py) = python() else {
        eprintln!("skipped: no Python with pyisomme (set PYISOMME_PYTHON)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    measure_dir(dir.path());
    let e = export(&ExportConfig::new(dir.path(), "T4")).unwrap();
    let out = dir.path().join("iso");
    for (name, bytes) in &e.files {
        let p = out.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    let script = r#"
import json, sys, math
from pyisomme import Isomme
iso = Isomme().read(sys.argv[1])
out = {"test_number": iso.test_number, "channels": []}
for ch in iso.channels:
    d = ch.data
    out["channels"].append({"code": str(ch.code), "unit": str(ch.unit),
        "t": [float(x) for x in d.index],
        "v": [None if math.isnan(x) else float(x) for x in d.iloc[:, 0]]})
print(json.dumps(out))
"#;
    let res = std::process::Command::new(&py)
        .arg("-c")
        .arg(script)
        .arg(out.join("T4.mme"))
        .output()
        .unwrap();
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&res.stdout).unwrap();
    assert_eq!(doc["test_number"], "T4");
    let chans = doc["channels"].as_array().unwrap();
    assert_eq!(chans.len(), 12);
    let mut checked = 0;
    for (ch, info) in chans.iter().zip(&e.channels) {
        assert_eq!(ch["code"].as_str().unwrap(), info.code);
        let (_, want) = parse_channel(
            std::str::from_utf8(&e.files.iter().find(|(n, _)| *n == info.file).unwrap().1).unwrap(),
        );
        let t: Vec<f64> = ch["t"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert!(
            (t[0] - 0.01).abs() < 1e-12 && (t[1] - t[0] - 0.001).abs() < 1e-12,
            "{t:?}"
        );
        for (got, want) in ch["v"].as_array().unwrap().iter().zip(&want) {
            match want {
                Some(w) => {
                    assert!((got.as_f64().unwrap() - w).abs() < 1e-9, "{got} vs {w}");
                    checked += 1;
                }
                None => assert!(got.is_null()),
            }
        }
    }
    // The values in metres are the measure output's mm / 1000: head X at frame 10.
    assert_eq!(chans[0]["v"][0].as_f64().unwrap(), 0.1 * 10.0 / 1000.0);
    assert!(checked > 50, "{checked}");
}
