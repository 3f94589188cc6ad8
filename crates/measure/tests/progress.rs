//! `crashrig_measure::run` with a [`Monitor`]: reports are monotone and end at the total, a
//! cancelled run returns [`Error::Cancelled`] and writes nothing, and the result has the bits
//! of a run without a monitor.

use crashrig_geometry::Vec3;
use crashrig_measure::{ANoise, Error, MeasureConfig, OutputDir, Settings, input, output, run};
use crashrig_stats::progress::Recorder;
use std::path::{Path, PathBuf};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/measure/sequence")
}

/// The bundled sequence with `samples` replicates (a sync σ needs the frame rate).
fn config(samples: usize, sync_sigma_ms: f64, out: Option<PathBuf>) -> MeasureConfig {
    let f = fixture();
    MeasureConfig {
        model: f.join("model"),
        camera_a: "cam_out/".into(),
        camera_b: "2".into(),
        camera_c: Some("3".into()),
        a_from_b: input::load_link(&f.join("link.json")).unwrap(),
        b_from_c: Some(input::load_link(&f.join("tie.json")).unwrap()),
        observations: f.join("observations.csv"),
        mm_per_unit: 1000.0,
        a_noise: ANoise::Sigmas {
            position_mm: Vec3::repeat(0.5),
            angles_deg: Vec3::repeat(0.01),
        },
        settings: Settings {
            samples,
            seed: 7,
            pixel_sigma_px: 0.1,
            reference_epoch: None,
            frame_rate_hz: (sync_sigma_ms > 0.0).then_some(1000.0),
            frame_times: None,
            threshold_mm: 5.0,
            max_reprojection_px: None,
            cfc: None,
            sync_sigma_ms,
        },
        pixel_sigma_from: Default::default(),
        scale_bars: None,
        out: out.map(|dir| OutputDir { dir, plots: false }),
    }
}

/// The bits of every row's σ (position, displacement, velocity) and nominal position.
fn bits(r: &crashrig_measure::MeasureRun) -> Vec<u64> {
    let v = |x: Option<Vec3>| x.map_or([0; 3], |x| x.map(f64::to_bits).into());
    r.measurement
        .rows
        .iter()
        .flat_map(|row| {
            [
                v(row.position_mm),
                v(row.sigma_mm),
                v(row.displacement_sigma_mm),
                v(row.velocity_sigma_mm_s),
            ]
            .into_iter()
            .flatten()
            .chain(
                row.covariance_mm2
                    .iter()
                    .flat_map(|c| c.iter().map(|x| x.to_bits())),
            )
        })
        .collect()
}

#[test]
fn reports_are_monotone_end_at_the_total_and_change_nothing() {
    // 100 replicates: chunks of 32 → reports 32, 64, 96, 100. With a sync σ the run is made
    // twice (with and without it): 200 units, the second run's reports following the first's.
    for (sync, total, reports) in [(0.0, 100, 4), (0.5, 200, 8)] {
        let recorder = Recorder::new();
        let with = run(&config(100, sync, None), Some(&recorder)).unwrap();
        let without = run(&config(100, sync, None), None).unwrap();
        assert_eq!(bits(&with), bits(&without), "sync {sync}");
        assert_eq!(
            output::trajectories_csv(&with.measurement),
            output::trajectories_csv(&without.measurement)
        );
        assert_eq!(
            with.measurement.sync_share.is_some(),
            sync > 0.0,
            "sync {sync}"
        );
        let seen = recorder.seen();
        assert_eq!(seen.len(), reports, "sync {sync}: {seen:?}");
        assert!(seen.iter().all(|&(_, t)| t == total), "{seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 < w[1].0), "{seen:?}");
        assert_eq!(seen.last(), Some(&(total, total)));
        assert_eq!(seen[0], (32, total));
    }
}

#[test]
fn a_cancelled_run_returns_cancelled_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // Cancelled after the second chunk: the third never starts.
    let recorder = Recorder::cancelling_after(2);
    let e = run(&config(100, 0.0, Some(out.clone())), Some(&recorder)).unwrap_err();
    assert!(matches!(e, Error::Cancelled(_)), "{e}");
    assert_eq!(e.to_string(), "cancelled");
    assert_eq!(recorder.seen(), vec![(32, 100), (64, 100)]);
    assert!(!out.exists());
    // Cancelled after the last chunk: everything is computed, nothing written.
    let recorder = Recorder::cancelling_after(4);
    let e = run(&config(100, 0.0, Some(out.clone())), Some(&recorder)).unwrap_err();
    assert!(matches!(e, Error::Cancelled(_)), "{e}");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
    // Not cancelled: written.
    let recorder = Recorder::new();
    run(&config(100, 0.0, Some(out.clone())), Some(&recorder)).unwrap();
    assert!(out.join("summary.json").is_file());
}
