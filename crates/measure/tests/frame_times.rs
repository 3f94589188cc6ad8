//! `--frame-times` (each frame's time from the camera's clock): the epochs' times, velocities on
//! irregular times against their known answer, the CFC filter on equally spaced times equal to
//! `--frame-rate-hz`, and the refusals.

use crashrig_camera::{Camera, ModelId};
use crashrig_geometry::{Rigid3, UncertainPose, Vec3};
use crashrig_input::options::Spelling;
use crashrig_measure::MeasureOptions;
use crashrig_measure::engine::{Epoch, Measurement, Rig, Settings, measure};
use crashrig_measure::filter::{CfcSpec, Standard};
use crashrig_measure::input::{self, FrameTimes, Inward, Observation};
use nalgebra::Vector2;
use std::path::PathBuf;

const EPOCHS: usize = 20;
/// The marker accelerates along x: `x(t) = 100 + A·t²` mm.
const A_MM_S2: f64 = 1.0e5;

fn pinhole() -> Camera {
    Camera::new(
        ModelId::Pinhole,
        2000,
        2000,
        vec![1500.0, 1500.0, 1000.0, 1000.0],
    )
    .unwrap()
}

fn rig() -> Rig {
    Rig {
        a_from_b: UncertainPose::from_sigmas(Rigid3::identity(), Vec3::repeat(0.1), Vec3::zeros()),
        camera_b: pinhole(),
        c: Some((
            UncertainPose::from_sigmas(
                Rigid3::translation(500.0, 0.0, 0.0),
                Vec3::repeat(0.1),
                Vec3::zeros(),
            ),
            pinhole(),
        )),
    }
}

fn name(i: usize) -> String {
    format!("{i:06}")
}

/// The epochs (A exact at the origin) and the exact pixels of the marker at `times`.
fn scene(times: &[f64]) -> (Vec<Epoch>, Vec<Observation>) {
    let epochs = (0..times.len())
        .map(|i| Epoch {
            key: format!("{}.png", name(i)),
            name: name(i),
            world_from_a: UncertainPose::certain(Rigid3::identity()),
        })
        .collect();
    let mut obs = Vec::new();
    for (i, t) in times.iter().enumerate() {
        let x = Vec3::new(100.0 + A_MM_S2 * t * t, 50.0, 2000.0);
        for (camera, cx) in [(Inward::B, 0.0), (Inward::C, 500.0)] {
            obs.push(Observation {
                epoch: name(i),
                camera,
                marker: "head".into(),
                pixel: Vector2::new(
                    1000.0 + 1500.0 * (x.x - cx) / x.z,
                    1000.0 + 1500.0 * x.y / x.z,
                ),
                sigma: None,
                line: obs.len() as u64 + 2,
            });
        }
    }
    (epochs, obs)
}

fn frame_times(times: &[f64]) -> FrameTimes {
    FrameTimes::new(
        PathBuf::from("frames.csv"),
        times
            .iter()
            .enumerate()
            .map(|(i, &t)| (name(i), t))
            .collect(),
    )
    .unwrap()
}

fn settings(hz: f64, times: Option<FrameTimes>, cfc: bool) -> Settings {
    Settings {
        samples: 200,
        seed: 9,
        pixel_sigma_px: 0.05,
        reference_epoch: None,
        frame_rate_hz: Some(hz),
        frame_times: times,
        threshold_mm: 5.0,
        max_reprojection_px: None,
        cfc: cfc.then_some(CfcSpec {
            class: 60,
            standard: Standard::J211,
        }),
        sync_sigma_ms: 0.0,
    }
}

fn run(times: &[f64], s: &Settings) -> Result<Measurement, String> {
    let (epochs, obs) = scene(times);
    measure(&epochs, None, &rig(), &obs, None, s).map_err(|e| e.to_string())
}

/// Irregular times (a camera whose intervals alternate 0.8 and 1.2 ms, starting before the
/// trigger): each epoch's time is the file's, and the nominal velocity is the difference
/// quotient on those times — for `x = 100 + A·t²` the central one is exactly `A·(t₊ + t₋)`.
#[test]
fn velocities_use_the_frame_times() {
    let times: Vec<f64> = (0..EPOCHS)
        .map(|i| -0.004 + 0.001 * i as f64 + if i % 2 == 1 { -0.0002 } else { 0.0 })
        .collect();
    let ft = frame_times(&times);
    let hz = 1.0 / ft.mean_interval_s().unwrap();
    let m = run(&times, &settings(hz, Some(ft), false)).unwrap();
    for (e, t) in m.epochs.iter().zip(&times) {
        assert_eq!(e.time_s, Some(*t));
    }
    for row in &m.rows {
        let e = row.epoch;
        let v = row.velocity_mm_s.unwrap().x;
        let want = if e == 0 {
            A_MM_S2 * (times[1] + times[0])
        } else if e == EPOCHS - 1 {
            A_MM_S2 * (times[e] + times[e - 1])
        } else {
            A_MM_S2 * (times[e + 1] + times[e - 1])
        };
        assert!(
            (v - want).abs() < 1e-6 * want.abs().max(1.0),
            "epoch {e}: {v} vs {want}"
        );
        assert!(row.velocity_sigma_mm_s.is_some());
    }
}

/// Equally spaced frame times (1 kHz, first frame 5 ms before the trigger): the filtered
/// kinematics equal `--frame-rate-hz 1000`'s (the same draws; the times differ only by the
/// offset, which no difference sees), to rounding.
#[test]
fn cfc_on_equal_frame_times_is_the_frame_rates() {
    let times: Vec<f64> = (0..EPOCHS).map(|i| -0.005 + i as f64 / 1000.0).collect();
    let with_times = run(&times, &settings(1000.0, Some(frame_times(&times)), true)).unwrap();
    let rate_times: Vec<f64> = (0..EPOCHS).map(|i| i as f64 / 1000.0).collect();
    // The same pixels: the marker at the frame-times' times, named by frame number.
    let (epochs, obs) = scene(&times);
    let with_rate = measure(
        &epochs,
        None,
        &rig(),
        &obs,
        None,
        &settings(1000.0, None, true),
    )
    .unwrap();
    for (e, t) in with_rate.epochs.iter().zip(&rate_times) {
        assert!((e.time_s.unwrap() - t).abs() < 1e-15);
    }
    let (a, b) = (
        with_times.kinematics.as_ref().unwrap(),
        with_rate.kinematics.as_ref().unwrap(),
    );
    assert_eq!(a.rows_with_kinematics, EPOCHS);
    for (x, y) in a.rows.iter().zip(&b.rows) {
        let close = |p: Option<Vec3>, q: Option<Vec3>| {
            let (p, q) = (p.unwrap(), q.unwrap());
            (p - q).norm() <= 1e-9 * q.norm().max(1e-9)
        };
        assert!(close(x.velocity_m_s, y.velocity_m_s));
        assert!(close(x.velocity_sigma_m_s, y.velocity_sigma_m_s));
        assert!(close(x.acceleration_m_s2, y.acceleration_m_s2));
    }
}

/// Irregular spacing and a CFC filter: refused with the reason; a measured epoch missing from
/// the file and frame times that go back are errors naming the epoch.
#[test]
fn refusals_name_the_reason() {
    let times: Vec<f64> = (0..EPOCHS)
        .map(|i| 0.001 * i as f64 + if i == 7 { 0.0003 } else { 0.0 })
        .collect();
    let ft = frame_times(&times);
    let e = run(&times, &settings(1000.0, Some(ft), true)).unwrap_err();
    assert!(
        e.contains("frames.csv: the frame interval from epoch `00000")
            && e.contains("30.0 % off the mean interval of 1.000000 ms")
            && e.contains("defined only for equally spaced samples"),
        "{e}"
    );
    // Without the filter the same times are fine.
    assert!(run(&times, &settings(1000.0, Some(frame_times(&times)), false)).is_ok());
    let short = frame_times(&times[..EPOCHS - 1]);
    let e = run(&times, &settings(1000.0, Some(short), false)).unwrap_err();
    assert!(
        e.contains("epoch `000019` has no time in frames.csv (--frame-times)"),
        "{e}"
    );
}

fn read(text: &str) -> Result<FrameTimes, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frames.csv");
    std::fs::write(&path, text).unwrap();
    input::read_frame_times(&path).map_err(|e| e.to_string())
}

#[test]
fn the_frame_times_file_is_checked_line_by_line() {
    let ok = read("time_s,epoch\n-0.001,000000\n0,000001\n0.001,000002\n").unwrap();
    assert_eq!(ok.lookup(&["000001"]), Some((1, 0.0)));
    assert_eq!(ok.mean_interval_s(), Some(0.001));
    let cases = [
        (
            "epoch,time_s\n000000,0\n000001,0\n",
            ":3: time_s 0 s of epoch `000001` does not increase (line 2 has 0 s): frame times must increase along the sequence",
        ),
        (
            "epoch,time_s\n000000,\n",
            ":2: time_s of epoch `000000` is empty (frames without a clock: give --frame-rate-hz instead)",
        ),
        (
            "epoch,time_s\n000000,1ms\n",
            ":2: time_s `1ms` is not a number (s)",
        ),
        (
            "epoch,time_s\n000000,inf\n",
            ":2: time_s is inf: times must be finite (s)",
        ),
        (
            "epoch,time_s\n000000,0\n000000,1\n",
            ":3: epoch `000000` again (first on line 2)",
        ),
        ("epoch,time_s\n,0\n", ":2: empty epoch"),
        (
            "epoch,t\n000000,0\n",
            ":1: unknown column `t` (the columns are epoch,time_s)",
        ),
        ("epoch,time_s\n", ":1: no frame times"),
    ];
    for (text, want) in cases {
        let e = read(text).unwrap_err();
        assert!(
            e.contains("frames.csv") && e.ends_with(want),
            "{e} ≠ …{want}"
        );
    }
}

#[test]
fn frame_times_and_frame_rate_exclude_each_other() {
    let o = MeasureOptions {
        frame_times: Some("frames.csv".into()),
        frame_rate_hz: Some(1000.0),
        mm_per_unit: Some(1.0),
        ..MeasureOptions::new("m", "cam_out/", "2", "link.json", "obs.csv")
    };
    let e = o.config(Spelling::Flag).unwrap_err().to_string();
    assert_eq!(
        e,
        "--frame-times (frames.csv) and --frame-rate-hz exclude each other: the frame times are the time axis"
    );
}
