//! The Python-rendered sequences of `fixtures/track/` (fixtures/gen/render_targets.py: planar
//! targets through an OpenCV lens, exact anti-aliasing by supersampling, motion blur by
//! sub-exposures, gain changes, noise, an occluder, markers leaving the image) tracked by the
//! whole command, against their truth and against OpenCV's cornerSubPix on the same frames.

use crate::fit_stats::whitened;
use crashrig_track::{MarkerKind, TrackConfig, TrackRun};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn case_dir(case: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fixtures/track")
        .join(case)
}

/// `epoch,marker → row` of a CSV with the named columns.
fn read_table(path: &Path) -> Vec<BTreeMap<String, String>> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let headers = rdr.headers().unwrap().clone();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            headers
                .iter()
                .zip(r.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

#[derive(Debug, Clone, Copy)]
struct Truth {
    u: f64,
    v: f64,
    visible: i32,
}

fn truth(case: &str) -> BTreeMap<(String, String), Truth> {
    read_table(&case_dir(case).join("truth.csv"))
        .into_iter()
        .map(|r| {
            (
                (r["epoch"].clone(), r["marker"].clone()),
                Truth {
                    u: r["u_px"].parse().unwrap(),
                    v: r["v_px"].parse().unwrap(),
                    visible: r["visible"].parse().unwrap(),
                },
            )
        })
        .collect()
}

fn track(case: &str, kind: MarkerKind, threads: usize) -> (TrackRun, tempfile::TempDir) {
    let out = tempfile::tempdir().unwrap();
    let config = TrackConfig {
        frames: case_dir(case).join("frames"),
        seeds: case_dir(case).join("seeds.csv"),
        camera: "B".into(),
        out: out.path().join("out"),
        kind,
        first: None,
        last: None,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let run = pool.install(|| crashrig_track::run(&config, None)).unwrap();
    (run, out)
}

/// What one case reached.
#[derive(Debug)]
struct Reached {
    rows: usize,
    rms_px: f64,
    max_px: f64,
    /// Share of fully visible (epoch, marker) with a row.
    recall: f64,
    within_2: f64,
    rms_z: f64,
    /// Rows whose nearest truth in that epoch is another marker.
    swaps: usize,
    /// Rows where the truth says the marker is not visible at all.
    ghosts: usize,
    /// Our RMS and OpenCV's on the rows both have (fully visible rows).
    vs_opencv: Option<(f64, f64, usize)>,
}

fn reached(case: &str, run: &TrackRun) -> Reached {
    let t = truth(case);
    let epoch_of = |k: usize| format!("{k:04}");
    let mut ours = BTreeMap::new();
    let (mut se, mut max, mut zin, mut zs, mut comps, mut swaps, mut ghosts) =
        (0.0f64, 0.0f64, 0usize, 0.0f64, 0usize, 0usize, 0usize);
    for o in &run.observations {
        let name = &run.markers[o.marker];
        let e = epoch_of(o.frame);
        let tr = t[&(e.clone(), name.clone())];
        let c = &o.centre;
        let (du, dv) = (c.u_px - tr.u, c.v_px - tr.v);
        if tr.visible < 0 {
            ghosts += 1;
        }
        se += du * du + dv * dv;
        max = max.max(du.hypot(dv));
        for z in whitened(du, dv, c.sigma_u_px, c.sigma_v_px, c.rho_uv) {
            comps += 1;
            zs += z * z;
            zin += usize::from(z.abs() <= 2.0);
        }
        // Identity: the nearest truth in this epoch must be this marker's.
        let nearest = t
            .iter()
            .filter(|((te, _), _)| *te == e)
            .min_by(|a, b| {
                let da = (a.1.u - c.u_px).hypot(a.1.v - c.v_px);
                let db = (b.1.u - c.u_px).hypot(b.1.v - c.v_px);
                da.total_cmp(&db)
            })
            .unwrap();
        if nearest.0.1 != *name {
            swaps += 1;
        }
        ours.insert((e, name.clone()), (c.u_px, c.v_px));
    }
    let visible: Vec<_> = t.iter().filter(|(_, v)| v.visible == 1).collect();
    let recall = visible
        .iter()
        .filter(|(k, _)| ours.contains_key(*k))
        .count() as f64
        / visible.len() as f64;
    let cv_path = case_dir(case).join("opencv.csv");
    let vs_opencv = cv_path.exists().then(|| {
        let (mut a, mut b, mut n) = (0.0, 0.0, 0);
        for r in read_table(&cv_path) {
            let key = (r["epoch"].clone(), r["marker"].clone());
            let tr = t[&key];
            let Some(&(u, v)) = ours.get(&key) else {
                continue;
            };
            let (cu, cv): (f64, f64) = (r["u_px"].parse().unwrap(), r["v_px"].parse().unwrap());
            a += (u - tr.u).powi(2) + (v - tr.v).powi(2);
            b += (cu - tr.u).powi(2) + (cv - tr.v).powi(2);
            n += 1;
        }
        ((a / n as f64).sqrt(), (b / n as f64).sqrt(), n)
    });
    let n = run.observations.len();
    Reached {
        rows: n,
        rms_px: (se / n as f64).sqrt(),
        max_px: max,
        recall,
        within_2: zin as f64 / comps as f64,
        rms_z: (zs / comps as f64).sqrt(),
        swaps,
        ghosts,
        vs_opencv,
    }
}

/// The contract's common figures: no row > 1 px, no swap, no row where the marker is hidden,
/// recall ≥ 99 % where fully visible, σ honest.
fn common(r: &Reached) {
    // A case with no row would pass every bound below vacuously.
    assert!(r.rows > 0, "{r:?}");
    assert!(r.max_px <= 1.0, "{r:?}");
    assert_eq!(r.swaps, 0, "{r:?}");
    assert_eq!(r.ghosts, 0, "{r:?}");
    assert!(r.recall >= 0.99, "{r:?}");
}

/// σ honest: |z| ≤ 2 for ≥ 90 % of the components, RMS z in [0.7, 1.4].
fn honest(r: &Reached) {
    assert!(r.within_2 >= 0.9, "{r:?}");
    assert!((0.7..=1.4).contains(&r.rms_z), "{r:?}");
}

/// Open gap (issue 43): on the lens-rendered sharp and blurred sequences σ is too small
/// (measured: sharp RMS z 1.63, 89 % within 2; blur RMS z 2.36, 67 % within 2).
#[test]
#[ignore = "open: σ too small on the sharp and blurred rendered sequences (RMS z 1.6 and 2.4)"]
fn open_sigma_honest_on_sharp_and_blurred_sequences() {
    for case in ["sharp", "blur"] {
        let (run, _d) = track(case, MarkerKind::Quadrant, 2);
        honest(&reached(case, &run));
    }
}

#[test]
fn sharp_quadrants_beat_opencv() {
    let (run, _d) = track("sharp", MarkerKind::Quadrant, 2);
    let r = reached("sharp", &run);
    eprintln!("sharp: {r:?}");
    common(&r);
    assert!(r.rms_px <= 0.05, "{r:?}");
    let (ours, cv, n) = r.vs_opencv.unwrap();
    assert!(n >= 50, "{r:?}");
    assert!(ours <= cv, "ours {ours} vs OpenCV {cv}");
}

#[test]
fn blurred_quadrants_mid_exposure() {
    let (run, _d) = track("blur", MarkerKind::Quadrant, 2);
    let r = reached("blur", &run);
    eprintln!("blur: {r:?}");
    common(&r);
    assert!(r.rms_px <= 0.15, "{r:?}");
    let (ours, cv, _) = r.vs_opencv.unwrap();
    assert!(ours <= cv, "ours {ours} vs OpenCV {cv}");
}

#[test]
fn occluded_markers_left_out_and_reacquired() {
    let (run, _d) = track("occlusion", MarkerKind::Quadrant, 2);
    let r = reached("occlusion", &run);
    eprintln!("occlusion: {r:?}");
    common(&r);
    honest(&r);
    // Every marker the bar passed over is found again once clear of it: its last fully
    // visible epoch has a row.
    let t = truth("occlusion");
    for name in &run.markers {
        let summary = run
            .summary
            .markers
            .iter()
            .find(|m| &m.name == name)
            .unwrap();
        let last_visible = t
            .iter()
            .filter(|((_, m), v)| m == name && v.visible == 1)
            .map(|((e, _), _)| e.clone())
            .max()
            .unwrap();
        let frame: usize = last_visible.parse().unwrap();
        assert!(
            run.observations
                .iter()
                .any(|o| &run.markers[o.marker] == name && o.frame == frame),
            "{name}: not re-acquired by {last_visible}: {summary:?}"
        );
    }
    assert!(
        run.summary
            .markers
            .iter()
            .any(|m| !m.lost_epochs.is_empty())
    );
}

/// Open gap (issue 43): the dot's centre is the imaged ellipse's, 0.25 px RMS from the image
/// of the disc's centre on this wide-angle sequence (docs/TRACK.md, "Dot").
#[test]
#[ignore = "open: dot centre is the ellipse centre (0.25 px RMS from the disc centre here)"]
fn open_dots_centred() {
    let (run, _d) = track("dots", MarkerKind::Dot, 2);
    let r = reached("dots", &run);
    eprintln!("dots: {r:?}");
    common(&r);
    honest(&r);
    assert!(r.rms_px <= 0.05, "{r:?}");
}

#[test]
fn output_is_bit_identical_for_any_thread_count() {
    let (_, a) = track("occlusion", MarkerKind::Quadrant, 1);
    let (_, b) = track("occlusion", MarkerKind::Quadrant, 2);
    for f in ["observations.csv", "frames.csv"] {
        assert_eq!(
            std::fs::read(a.path().join("out").join(f)).unwrap(),
            std::fs::read(b.path().join("out").join(f)).unwrap(),
            "{f}"
        );
    }
    // summary.json too, but for its two wall-clock fields.
    let summary = |d: &tempfile::TempDir| {
        let text = std::fs::read_to_string(d.path().join("out/summary.json")).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let o = v.as_object_mut().unwrap();
        for k in ["elapsed_s", "observations_per_second"] {
            assert!(o.remove(k).is_some_and(|x| x.is_number()), "{k}");
        }
        v
    };
    assert_eq!(summary(&a), summary(&b));
}
