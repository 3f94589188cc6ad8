//! Robustness: ≥ 10,000 seeded truncations and bit flips of real model files and of a real
//! database; no panic, and every failure is a typed error naming the damaged file.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use crashrig_colmap::Reconstruction;
use crashrig_colmap::database::Database;

use crate::common::{copy_dir, fixture};

/// Replaces a file by unlinking and recreating it: rewriting in place after a truncation makes
/// ext4 flush each time (`auto_da_alloc`), which turns 10,000 variants into seconds of IO wait.
fn replace(path: &Path, bytes: &[u8]) {
    let _ = std::fs::remove_file(path);
    std::fs::write(path, bytes).expect("write");
}

/// SplitMix64: a tiny seeded generator so the corpus is the same on every run.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One damaged variant of `original`: a truncation, 1–4 bit flips, or (text) a byte replaced by
/// a character that is meaningful to the parser.
fn mutate(rng: &mut SplitMix, original: &[u8], text: bool) -> Vec<u8> {
    let mut b = original.to_vec();
    match rng.below(4) {
        0 => b.truncate(rng.below(b.len())),
        1 if text => {
            let chars = b" \n#-0123456789.eE+xCAMERA";
            for _ in 0..=rng.below(3) {
                let i = rng.below(b.len());
                b[i] = chars[rng.below(chars.len())];
            }
        }
        _ => {
            for _ in 0..=rng.below(4) {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
        }
    }
    b
}

/// Mutates each file of `model` in turn `per_file` times and reads the model; returns how many
/// variants were read.
fn fuzz_model(model: &str, seed: u64, per_file: usize) -> usize {
    let tmp = copy_dir(&fixture(model));
    let mut rng = SplitMix(seed);
    let mut files: Vec<_> = std::fs::read_dir(tmp.path())
        .expect("list")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "bin" || e == "txt"))
        .collect();
    files.sort();
    let mut n = 0;
    for file in &files {
        let original = std::fs::read(file).expect("read");
        let text = file.extension().is_some_and(|e| e == "txt");
        for _ in 0..per_file {
            let variant = mutate(&mut rng, &original, text);
            replace(file, &variant);
            let result = catch_unwind(AssertUnwindSafe(|| {
                Reconstruction::read(tmp.path()).map(|m| {
                    // Exercise the derived data of whatever was accepted.
                    m.images()
                        .iter()
                        .filter(|i| m.image_cam_from_world(i.image_id).is_some())
                        .count()
                        + m.num_observations()
                })
            }));
            match result {
                Err(_) => panic!("panic on a variant of {} (seed {seed})", file.display()),
                Ok(Err(e)) => assert!(
                    e.path() == file.as_path()
                        || e.path().parent() == Some(tmp.path())
                        || e.path() == tmp.path(),
                    "error does not name a model file: {e}"
                ),
                Ok(Ok(_)) => {}
            }
            n += 1;
        }
        std::fs::write(file, &original).expect("restore");
    }
    n
}

fn fuzz_database(seed: u64, count: usize) -> usize {
    let tmp = tempfile::tempdir().expect("tmp");
    let p = tmp.path().join("database.db");
    let original = std::fs::read(fixture("rig_opencv/database.db")).expect("read");
    let mut rng = SplitMix(seed);
    for _ in 0..count {
        let variant = mutate(&mut rng, &original, false);
        replace(&p, &variant);
        let result = catch_unwind(AssertUnwindSafe(|| -> crashrig_colmap::Result<usize> {
            let db = Database::open(&p)?;
            let c = db.counts()?;
            let mut n = db.cameras()?.len() + db.rigs()?.len() + db.frames()?.len();
            n += db.pose_priors()?.len() + c.images as usize;
            for im in db.images()? {
                n += db.keypoints(im.image_id)?.len();
                n += db.descriptors(im.image_id)?.map_or(0, |d| d.rows);
            }
            for (a, b) in [(1, 2), (2, 1), (3, 8)] {
                n += db.matches(a, b)?.len();
                n += db.two_view_geometry(a, b)?.map_or(0, |t| t.inliers.len());
            }
            Ok(n)
        }));
        match result {
            Err(_) => panic!("panic on a database variant (seed {seed})"),
            Ok(Err(e)) => assert_eq!(e.path(), p.as_path(), "{e}"),
            Ok(Ok(_)) => {}
        }
    }
    count
}

#[test]
fn fuzz_nominal_models_and_database() {
    let mut n = 0;
    // 5 binary files × 900 + 5 text files × 500 + 3 text files × 300 + 3 legacy binary × 300.
    n += fuzz_model("simple_radial/bin", 1, 900);
    n += fuzz_model("rig_opencv/txt", 2, 500);
    n += fuzz_model("handwritten_txt", 3, 300);
    n += fuzz_model("rig_opencv/legacy_bin", 4, 300);
    n += fuzz_database(5, 1500);
    assert!(n >= 10_000, "only {n} variants");
}

#[test]
fn fuzz_errors_name_the_file() {
    // Truncating each binary file at every 7th byte: always an error naming that file.
    let tmp = copy_dir(&fixture("all_models/bin"));
    for stem in ["cameras", "images", "points3D", "rigs", "frames"] {
        let file = tmp.path().join(format!("{stem}.bin"));
        let original = std::fs::read(&file).expect("read");
        for len in (0..original.len()).step_by(7) {
            replace(&file, &original[..len]);
            let err = Reconstruction::read(tmp.path()).expect_err("truncated file must fail");
            assert_eq!(err.path(), file.as_path(), "{err}");
        }
        std::fs::write(&file, &original).expect("restore");
    }
}
