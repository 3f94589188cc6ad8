//! The committed camera files (real ones shortened, synthetic ones) against the goldens of
//! `fixtures/gen/frames_reference.py`: every frame's pixels (SHA-256) and samples as pims,
//! pyMRAW, Pillow and tifffile decode them, every frame's time, and the header fields.

use std::path::{Path, PathBuf};

use crashrig_frames::{GreyFrame, Sequence, SourceKind, TimeSource};
use serde_json::Value;
use sha2::{Digest, Sha256};

pub fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/frames")
}

fn expected() -> Value {
    let text = std::fs::read_to_string(fixtures().join("expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// The source path of a golden: the directory itself, else the header/cine file.
fn open(g: &Value) -> Sequence {
    let path = fixtures().join(g["path"].as_str().unwrap());
    Sequence::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn sha_of(frame: &GreyFrame) -> String {
    let mut h = Sha256::new();
    for v in &frame.pixels {
        h.update(v.to_le_bytes());
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn check_pixels(g: &Value, seq: &Sequence) {
    let name = g["path"].as_str().unwrap();
    assert_eq!(seq.len() as u64, g["frames"].as_u64().unwrap(), "{name}");
    assert_eq!(
        u64::from(seq.width()),
        g["width"].as_u64().unwrap(),
        "{name}"
    );
    assert_eq!(
        u64::from(seq.height()),
        g["height"].as_u64().unwrap(),
        "{name}"
    );
    let shas = g["frames_sha256"].as_array().unwrap();
    let mut frames = Vec::new();
    for (i, sha) in shas.iter().enumerate() {
        let mut f = GreyFrame::default();
        seq.read(i, &mut f).unwrap();
        assert_eq!(
            sha_of(&f),
            sha.as_str().unwrap(),
            "{name} frame {i}: pixels differ"
        );
        frames.push(f);
    }
    for s in g["samples"].as_array().unwrap() {
        let s: Vec<u64> = s
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect();
        let got = frames[s[0] as usize].get(s[1] as u32, s[2] as u32);
        assert_eq!(
            got,
            Some(s[3] as u16),
            "{name} frame {} at ({}, {})",
            s[0],
            s[1],
            s[2]
        );
    }
}

fn times(g: &Value, key: &str) -> Vec<f64> {
    g[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect()
}

fn golden(path: &str) -> Value {
    expected()["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["path"] == path)
        .unwrap_or_else(|| panic!("no golden for {path}"))
        .clone()
}

#[test]
fn goldens_every_file_decodes_as_the_references() {
    let doc = expected();
    let files = doc["files"].as_array().unwrap();
    assert!(files.len() >= 13, "{} goldens", files.len());
    for g in files {
        let seq = open(g);
        check_pixels(g, &seq);
        let kind = match g["kind"].as_str().unwrap() {
            "cine" => SourceKind::Cine,
            "mraw" => SourceKind::Mraw,
            _ => SourceKind::Directory,
        };
        assert_eq!(seq.kind(), kind);
        if let Some(bits) = g["bits"].as_u64() {
            assert_eq!(u64::from(seq.bits()), bits, "{}", g["path"]);
        }
        if let Some(epochs) = g["epochs"].as_array() {
            let got: Vec<&str> = (0..seq.len()).map(|i| seq.epoch(i)).collect();
            let want: Vec<&str> = epochs.iter().map(|e| e.as_str().unwrap()).collect();
            assert_eq!(got, want);
        }
        if kind != SourceKind::Directory {
            assert_eq!(seq.epoch(0), "000000");
            // Times the generator formed exactly (integers subtracted before one rounding):
            // equal to within a few ulps of values below 1 s.
            for (i, t) in times(g, "times_s").iter().enumerate() {
                let got = seq.time_s(i).unwrap();
                approx::assert_abs_diff_eq!(got, *t, epsilon = 1e-12);
            }
        } else {
            assert_eq!(seq.time_s(0), None);
        }
    }
}

#[test]
fn goldens_real_cine_times_match_pims() {
    for path in ["real/cine_781_first4.cine", "real/cine_legacy_first12.cine"] {
        let g = golden(path);
        let seq = open(&g);
        assert_eq!(seq.info().time_source, TimeSource::Timestamps);
        // pims adds the ~1.5e9 s epoch time to the fraction in float64 before subtracting the
        // trigger: each of the two sums is rounded to 2^-23 s (half an ulp of 2^-22 s at
        // 2^30..2^31 s), so its differences are off by at most 2^-22 s = 2.4e-7 s.
        for (i, t) in times(&g, "times_s_pims").iter().enumerate() {
            approx::assert_abs_diff_eq!(seq.time_s(i).unwrap(), *t, epsilon = 2.4e-7);
        }
        let info = seq.info();
        assert_eq!(info.frame_rate_hz, g["frame_rate_hz"].as_f64());
        assert_eq!(info.first_image_number, g["first_image_number"].as_i64());
        assert_eq!(u64::from(info.bits), g["real_bpp"].as_u64().unwrap());
        assert_eq!(info.trigger_utc.as_deref(), g["trigger_utc"].as_str());
        approx::assert_relative_eq!(
            info.exposure_s.unwrap(),
            g["exposure_s"].as_f64().unwrap(),
            max_relative = 1e-15
        );
    }
}

#[test]
fn goldens_real_mraw_header_fields() {
    let g = golden("real/ball_12bit_first3.cihx");
    let seq = open(&g);
    let info = seq.info();
    assert_eq!(info.frame_rate_hz, Some(30000.0));
    assert_eq!(info.first_image_number, Some(52));
    assert_eq!(info.trigger_frame, Some(0));
    assert_eq!(info.layout, crashrig_frames::PixelLayout::Packed12);
    assert_eq!(info.bits, 12);
    // shutterSpeedNsec 20000
    approx::assert_relative_eq!(info.exposure_s.unwrap(), 20e-6, max_relative = 1e-15);
    assert_eq!(
        info.camera.as_deref(),
        Some("FASTCAM Nova S16 type 1100K-M-64GB 10GbE model")
    );
    let g = golden("real/beam_first2.cihx");
    let seq = open(&g);
    assert_eq!(seq.info().layout, crashrig_frames::PixelLayout::U16Le);
    assert_eq!(
        seq.bits(),
        12,
        "16-bit container, 12 effective bits on the low side"
    );
}
