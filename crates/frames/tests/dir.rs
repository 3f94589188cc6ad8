//! Directories of PNG and TIFF frames: bit depths, colour to grey, order, sizes, bad files.

use std::path::Path;

use crashrig_frames::{FramesError, GreyFrame, Sequence, SourceKind};

/// Writes a PNG of `samples` (per pixel `channels` values, 8 or 16 bits).
pub fn write_png(
    path: &Path,
    w: u32,
    h: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    samples: &[u16],
) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(color);
    enc.set_depth(depth);
    let bytes: Vec<u8> = match depth {
        png::BitDepth::Sixteen => samples.iter().flat_map(|v| v.to_be_bytes()).collect(),
        _ => samples.iter().map(|&v| v as u8).collect(),
    };
    enc.write_header()
        .unwrap()
        .write_image_data(&bytes)
        .unwrap();
}

fn read(seq: &Sequence, i: usize) -> GreyFrame {
    let mut f = GreyFrame::default();
    seq.read(i, &mut f).unwrap();
    f
}

#[test]
fn dir_png_grey16_nominal() {
    let d = tempfile::tempdir().unwrap();
    let vals: Vec<u16> = vec![0, 1, 4095, 65535, 300, 40000];
    write_png(
        &d.path().join("b.png"),
        3,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &vals,
    );
    write_png(
        &d.path().join("a.png"),
        3,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &[7; 6],
    );
    let seq = Sequence::open(d.path()).unwrap();
    assert_eq!(seq.kind(), SourceKind::Directory);
    assert_eq!(
        (seq.len(), seq.width(), seq.height(), seq.bits()),
        (2, 3, 2, 16)
    );
    assert_eq!(seq.epoch(0), "a");
    assert_eq!(seq.epoch(1), "b");
    assert_eq!(seq.frame_rate_hz(), None);
    let f = read(&seq, 1);
    assert_eq!(f.pixels, vals, "16-bit values kept unscaled");
    assert_eq!(f.bits, 16);
}

#[test]
fn dir_png_colour_to_grey() {
    let d = tempfile::tempdir().unwrap();
    // RGB 8-bit: (10, 20, 30) → 18.15 → 18; (255, 0, 0) → 76.245 → 76; (1, 1, 2) → 1.114 → 1.
    write_png(
        &d.path().join("0.png"),
        3,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[10, 20, 30, 255, 0, 0, 1, 1, 2],
    );
    let seq = Sequence::open(d.path()).unwrap();
    assert_eq!(read(&seq, 0).pixels, [18, 76, 1]);
    // RGBA 16-bit, alpha ignored: (1000, 2000, 3000) → 1815; (0, 65535, 0) → 38469.045 → 38469.
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("0.png"),
        2,
        1,
        png::ColorType::Rgba,
        png::BitDepth::Sixteen,
        &[1000, 2000, 3000, 0, 0, 65535, 0, 65535],
    );
    let seq = Sequence::open(d.path()).unwrap();
    assert_eq!(seq.bits(), 16);
    assert_eq!(read(&seq, 0).pixels, [1815, 38469]);
    // Grey + alpha 8-bit: the grey sample.
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("0.png"),
        2,
        1,
        png::ColorType::GrayscaleAlpha,
        png::BitDepth::Eight,
        &[9, 0, 200, 255],
    );
    assert_eq!(read(&Sequence::open(d.path()).unwrap(), 0).pixels, [9, 200]);
}

#[test]
fn dir_order_is_bytewise() {
    let d = tempfile::tempdir().unwrap();
    for name in ["10", "9", "B", "a", "_"] {
        write_png(
            &d.path().join(format!("{name}.png")),
            1,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[1],
        );
    }
    // Not images: ignored.
    std::fs::write(d.path().join("notes.txt"), "x").unwrap();
    std::fs::create_dir(d.path().join("sub.png")).unwrap();
    let seq = Sequence::open(d.path()).unwrap();
    let epochs: Vec<&str> = (0..seq.len()).map(|i| seq.epoch(i)).collect();
    assert_eq!(epochs, ["10", "9", "B", "_", "a"]);
    assert_eq!(seq.index_of("B"), Some(2));
}

#[test]
fn dir_tiff_grey16_and_rgb8() {
    use tiff::encoder::{TiffEncoder, colortype};
    let d = tempfile::tempdir().unwrap();
    let vals: Vec<u16> = vec![0, 4095, 65535, 12];
    let mut f = std::fs::File::create(d.path().join("f1.tif")).unwrap();
    TiffEncoder::new(&mut f)
        .unwrap()
        .write_image::<colortype::Gray16>(2, 2, &vals)
        .unwrap();
    let seq = Sequence::open(d.path()).unwrap();
    assert_eq!(seq.bits(), 16);
    assert_eq!(read(&seq, 0).pixels, vals);

    let d = tempfile::tempdir().unwrap();
    let mut f = std::fs::File::create(d.path().join("f1.tiff")).unwrap();
    TiffEncoder::new(&mut f)
        .unwrap()
        .write_image::<colortype::RGB8>(2, 1, &[10, 20, 30, 0, 0, 100])
        .unwrap();
    let seq = Sequence::open(d.path()).unwrap();
    assert_eq!(seq.bits(), 8);
    assert_eq!(read(&seq, 0).pixels, [18, 11]);
}

#[test]
fn dir_size_mismatch_names_the_file() {
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("a.png"),
        2,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0; 4],
    );
    write_png(
        &d.path().join("b.png"),
        3,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0; 6],
    );
    let e = Sequence::open(d.path()).unwrap_err();
    assert!(
        matches!(&e, FramesError::Mismatch { path, width: 3, .. } if path.ends_with("b.png")),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("b.png") && msg.contains("a.png"), "{msg}");
}

#[test]
fn dir_bit_depth_mismatch_is_an_error() {
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("a.png"),
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0],
    );
    write_png(
        &d.path().join("b.png"),
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &[0],
    );
    let e = Sequence::open(d.path()).unwrap_err();
    assert!(
        matches!(&e, FramesError::Mismatch { path, bits: 16, first_bits: 8, .. } if path.ends_with("b.png")),
        "{e}"
    );
}

#[test]
fn dir_broken_png_names_the_file() {
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("a.png"),
        4,
        4,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[5; 16],
    );
    let good = std::fs::read(d.path().join("a.png")).unwrap();
    // A PNG cut inside its image data: the header reads, the pixels do not.
    std::fs::write(d.path().join("b.png"), &good[..good.len() - 20]).unwrap();
    let seq = Sequence::open(d.path()).unwrap();
    let mut f = GreyFrame::default();
    let e = seq.read(1, &mut f).unwrap_err();
    assert!(
        matches!(&e, FramesError::Decode { path, .. } if path.ends_with("b.png")),
        "{e}"
    );
    // Garbage: the header does not read, so opening fails.
    std::fs::write(d.path().join("c.png"), b"not a png at all").unwrap();
    let e = Sequence::open(d.path()).unwrap_err();
    assert!(
        matches!(&e, FramesError::Decode { path, .. } if path.ends_with("c.png")),
        "{e}"
    );
    // Every prefix of a good file: an error or a frame, never a panic.
    for n in 0..good.len() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("x.png"), &good[..n]).unwrap();
        if let Ok(seq) = Sequence::open(d.path()) {
            let _ = seq.read(0, &mut f);
        }
    }
}

#[test]
fn dir_low_bit_depth_png_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let file = std::fs::File::create(d.path().join("a.png")).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 8, 1);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Four);
    enc.write_header()
        .unwrap()
        .write_image_data(&[0x12, 0x34, 0x56, 0x78])
        .unwrap();
    let e = Sequence::open(d.path()).unwrap_err();
    assert!(
        matches!(&e, FramesError::Unsupported { what, .. } if what.contains("4-bit")),
        "{e}"
    );
}

#[test]
fn dir_empty_and_duplicate_stems() {
    let d = tempfile::tempdir().unwrap();
    assert!(matches!(
        Sequence::open(d.path()),
        Err(FramesError::NoFrames { .. })
    ));
    write_png(
        &d.path().join("a.png"),
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0],
    );
    let mut f = std::fs::File::create(d.path().join("a.tif")).unwrap();
    tiff::encoder::TiffEncoder::new(&mut f)
        .unwrap()
        .write_image::<tiff::encoder::colortype::Gray8>(1, 1, &[0])
        .unwrap();
    let e = Sequence::open(d.path()).unwrap_err();
    assert!(e.to_string().contains("second frame named `a`"), "{e}");
}

#[test]
fn dir_read_past_end_is_an_error() {
    let d = tempfile::tempdir().unwrap();
    write_png(
        &d.path().join("a.png"),
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0],
    );
    let seq = Sequence::open(d.path()).unwrap();
    let mut f = GreyFrame::default();
    assert!(matches!(
        seq.read(1, &mut f),
        Err(FramesError::NoSuchFrame {
            index: 1,
            len: 1,
            ..
        })
    ));
}
