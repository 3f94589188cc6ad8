//! Malformed files: every prefix and seeded byte-garbled copies of real and synthetic camera
//! files are opened and read; each gives frames or an error naming the file, never a panic, a
//! hang or an allocation larger than the file.

use std::path::Path;

use crashrig_frames::{FramesError, GreyFrame, Sequence};

use crate::goldens::fixtures;

/// A small deterministic generator (SplitMix64), so the garbling needs no dependency.
struct Mix(u64);
impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// Opens `path` and reads every frame; returns the first error, if any. An error must name
/// the file it is about.
fn open_and_read(path: &Path) -> Option<FramesError> {
    let seq = match Sequence::open(path) {
        Ok(s) => s,
        Err(e) => return Some(e),
    };
    let mut f = GreyFrame::default();
    for i in 0..seq.len() {
        if let Err(e) = seq.read(i, &mut f) {
            return Some(e);
        }
        assert_eq!(f.pixels.len(), seq.width() as usize * seq.height() as usize);
    }
    None
}

fn names_a_file(e: &FramesError, names: &[&str]) {
    let msg = e.to_string();
    assert!(
        names.iter().any(|n| msg.contains(n)),
        "the error names no file: {msg}"
    );
}

#[test]
fn robust_cine_every_prefix() {
    let d = tempfile::tempdir().unwrap();
    for name in [
        "synth/packed10.cine",
        "synth/grey8.cine",
        "synth/grey16_no_time_block.cine",
    ] {
        let raw = std::fs::read(fixtures().join(name)).unwrap();
        let p = d.path().join("x.cine");
        // Every prefix through the headers, around the SETUP fields read (SETUP starts at 84)
        // and from the end of SETUP (84 + 10 412: tagged blocks, offsets, images) on; every 7th
        // in the unused SETUP bytes between.
        let dense = |n: usize| n < 200 || (800..1700).contains(&n) || n >= 10_400;
        for n in (0..raw.len()).filter(|&n| dense(n) || n % 7 == 0) {
            std::fs::write(&p, &raw[..n]).unwrap();
            let e =
                open_and_read(&p).unwrap_or_else(|| panic!("{name} cut at {n} read without error"));
            names_a_file(&e, &["x.cine"]);
        }
    }
}

#[test]
fn robust_cine_truncated_names_the_frame() {
    let raw = std::fs::read(fixtures().join("real/cine_781_first4.cine")).unwrap();
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("c.cine");
    // Frame k (of 131 080 bytes with its annotation) ends at 10 940 + (k + 1) · 131 080.
    for (cut, frame) in [
        (raw.len() - 1, 3),
        (10_940 + 2 * 131_080 + 5, 2),
        (10_940 + 100, 0),
    ] {
        std::fs::write(&p, &raw[..cut]).unwrap();
        match Sequence::open(&p) {
            Err(FramesError::Truncated { part, .. }) => {
                assert_eq!(part, format!("frame {frame}"), "cut at {cut}")
            }
            other => panic!("cut at {cut}: {other:?}"),
        }
    }
}

#[test]
fn robust_cine_garbled_headers() {
    let raw = std::fs::read(fixtures().join("real/cine_legacy_first12.cine")).unwrap();
    let header_end = 9292 + 8; // the first image's pixels start here
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("g.cine");
    let mut rng = Mix(43);
    let mut failed = 0;
    for _ in 0..3000 {
        let mut g = raw.clone();
        for _ in 0..1 + rng.next() % 4 {
            let at = (rng.next() % header_end as u64) as usize;
            g[at] = rng.next() as u8;
        }
        std::fs::write(&p, &g).unwrap();
        if let Some(e) = open_and_read(&p) {
            names_a_file(&e, &["g.cine"]);
            failed += 1;
        }
    }
    // Most single-byte changes hit unused SETUP bytes; some must have been caught.
    assert!(failed > 10, "{failed} of 3000 garbled copies refused");
}

#[test]
fn robust_mraw_headers_garbled_and_cut() {
    let d = tempfile::tempdir().unwrap();
    let mut rng = Mix(7);
    for (header, ext) in [
        ("synth/grey16.cihx", "cihx"),
        ("synth/packed12.cih", "cih"),
        ("real/ball_12bit_first3.cihx", "cihx"),
    ] {
        let text = std::fs::read(fixtures().join(header)).unwrap();
        let mraw = std::fs::read(fixtures().join(header).with_extension("mraw")).unwrap();
        let h = d.path().join(format!("h.{ext}"));
        std::fs::write(d.path().join("h.mraw"), &mraw).unwrap();
        // Every prefix of small headers, a sample of prefixes of the large one.
        let step = (text.len() / 400).max(1);
        for n in (0..text.len()).step_by(step) {
            std::fs::write(&h, &text[..n]).unwrap();
            if let Some(e) = open_and_read(&h) {
                names_a_file(&e, &["h.cih", "h.mraw"]);
            }
        }
        for _ in 0..500 {
            let mut g = text.clone();
            for _ in 0..1 + rng.next() % 3 {
                let at = (rng.next() % g.len() as u64) as usize;
                g[at] = rng.next() as u8;
            }
            std::fs::write(&h, &g).unwrap();
            if let Some(e) = open_and_read(&h) {
                names_a_file(&e, &["h.cih", "h.mraw"]);
            }
        }
        // Every prefix of the .mraw: an error naming the first frame it does not hold.
        std::fs::write(&h, &text).unwrap();
        let seq = Sequence::open(&h).unwrap();
        let frame_bytes = mraw.len() / seq.len();
        for n in (0..mraw.len()).step_by((mraw.len() / 300).max(1)) {
            std::fs::write(d.path().join("h.mraw"), &mraw[..n]).unwrap();
            match Sequence::open(&h) {
                Err(FramesError::Truncated { path, part, .. }) => {
                    assert!(path.ends_with("h.mraw"));
                    assert_eq!(
                        part,
                        format!("frame {}", n / frame_bytes),
                        "{header} cut at {n}"
                    );
                }
                other => panic!("{header} with its .mraw cut at {n}: {other:?}"),
            }
        }
    }
}

#[test]
fn robust_huge_counts_are_refused_before_allocating() {
    let d = tempfile::tempdir().unwrap();
    // A cine claiming 2^32 − 1 images: the offset table would be 32 GiB.
    let mut raw = std::fs::read(fixtures().join("synth/grey8.cine")).unwrap();
    raw[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
    let p = d.path().join("big.cine");
    std::fs::write(&p, &raw).unwrap();
    assert!(
        matches!(Sequence::open(&p), Err(FramesError::Truncated { part, .. }) if part == "the image offsets")
    );
    // An mraw header claiming 65 536 × 65 536 pixels and 10^15 frames.
    let cih = std::fs::read_to_string(fixtures().join("synth/grey8.cih")).unwrap();
    let big = cih
        .replace("Image Width : 5", "Image Width : 65536")
        .replace("Image Height : 4", "Image Height : 65536")
        .replace("Total Frame : 3", "Total Frame : 1000000000000000");
    std::fs::write(d.path().join("big.cih"), big).unwrap();
    std::fs::copy(
        fixtures().join("synth/grey8.mraw"),
        d.path().join("big.mraw"),
    )
    .unwrap();
    assert!(
        matches!(Sequence::open(&d.path().join("big.cih")), Err(FramesError::Truncated { part, .. }) if part == "frame 0")
    );
}
