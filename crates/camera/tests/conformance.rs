//! Conformance suite run by every camera model: round trips, Jacobians against central
//! differences, parameter validation and rejects. Each check counts what it verified and the
//! suite fails if any model received fewer than 3 examples or a check ran on nothing.

use approx::{assert_abs_diff_eq, assert_relative_eq};
use crashrig_camera::{
    Camera, Error, ModelId, OpenCvCamera, ProjectionReject, UndistortError,
    colmap_from_opencv_pixel,
};
use nalgebra::{Vector2, Vector3};

const W: u64 = 1024;
const H: u64 = 768;
const DEPTHS: [f64; 3] = [0.5, 3.0, 40.0];

/// Three parameter sets per model (mild, moderate, strong distortion), COLMAP convention.
fn examples(m: ModelId) -> Vec<Camera> {
    use ModelId as M;
    let mut out = Vec::new();
    for (l, f, cx, cy) in [
        (0.3, 800.0, 512.3, 380.1),
        (0.7, 1100.0, 500.0, 390.0),
        (1.0, 950.0, 520.0, 370.0),
    ] {
        let fy = f * 1.01;
        let (g, gy) = (0.35 * f, 0.35 * fy);
        let p = match m {
            M::SimplePinhole => vec![f, cx, cy],
            M::Pinhole => vec![f, fy, cx, cy],
            M::SimpleRadial => vec![f, cx, cy, -0.12 * l],
            M::Radial => vec![f, cx, cy, -0.12 * l, 0.03 * l],
            M::OpenCv => vec![f, fy, cx, cy, -0.12 * l, 0.03 * l, 1e-3 * l, -8e-4 * l],
            M::OpenCvFisheye => vec![g, gy, cx, cy, 0.06 * l, -0.015 * l, 4e-3 * l, -8e-4 * l],
            M::FullOpenCv => vec![
                f,
                fy,
                cx,
                cy,
                -0.12 * l,
                0.03 * l,
                1e-3 * l,
                -8e-4 * l,
                0.008 * l,
                0.04 * l,
                -0.015 * l,
                0.004 * l,
            ],
            M::Fov => vec![f, fy, cx, cy, 0.2 + 0.7 * l],
            M::SimpleRadialFisheye => vec![g, cx, cy, 0.06 * l],
            M::RadialFisheye => vec![g, cx, cy, 0.06 * l, -0.015 * l],
            M::ThinPrismFisheye => vec![
                g,
                gy,
                cx,
                cy,
                0.06 * l,
                -0.015 * l,
                1e-3 * l,
                -8e-4 * l,
                4e-3 * l,
                -8e-4 * l,
                1.5e-3 * l,
                -1e-3 * l,
            ],
            M::RadTanThinPrismFisheye => vec![
                g,
                gy,
                cx,
                cy,
                0.06 * l,
                -0.015 * l,
                4e-3 * l,
                -8e-4 * l,
                1.5e-4 * l,
                -4e-5 * l,
                1e-3 * l,
                -8e-4 * l,
                1.5e-3 * l,
                -4e-4 * l,
                -1e-3 * l,
                3e-4 * l,
            ],
            M::SimpleDivision => vec![f, cx, cy, -0.2 * l],
            M::Division => vec![f, fy, cx, cy, -0.2 * l],
            M::SimpleFisheye => vec![g, cx, cy],
            M::Fisheye => vec![g, gy, cx, cy],
            M::Eucm => vec![1.5 * g, 1.5 * gy, cx, cy, 0.3 + 0.5 * l, 0.9 + 0.2 * l],
            M::Equirectangular => vec![(2 * W) as f64 * (0.5 + 0.5 * l), W as f64],
        };
        out.push(Camera::new(m, W, H, p).expect("example parameters are valid"));
    }
    out
}

/// True for models whose field of view extends past ~60° (fisheye class and EUCM).
fn wide(m: ModelId) -> bool {
    m.is_fisheye() || m == ModelId::Eucm
}

/// Camera-frame points in front of the camera: a 5×5 grid of directions at 3 depths
/// (a grid of full-sphere directions for EQUIRECTANGULAR).
fn points(m: ModelId) -> Vec<Vector3<f64>> {
    let t = if wide(m) { 1.2 } else { 0.4 };
    let mut out = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            let (a, b) = (-1.0 + 0.5 * i as f64, -1.0 + 0.5 * j as f64);
            for d in DEPTHS {
                let p = if m == ModelId::Equirectangular {
                    let (th, ph) = (2.9 * a + 0.05, 1.2 * b + 0.03);
                    Vector3::new(ph.cos() * th.sin(), -ph.sin(), ph.cos() * th.cos()) * d
                } else {
                    Vector3::new(t * a * d, t * b * d, d)
                };
                out.push(p);
            }
        }
    }
    out
}

/// Pixels inside the image: a 5×4 grid (inner part for wide models).
fn pixels(m: ModelId) -> Vec<Vector2<f64>> {
    let (lo, hi) = if wide(m) { (0.3, 0.7) } else { (0.1, 0.9) };
    let mut out = Vec::new();
    for i in 0..5 {
        for j in 0..4 {
            let fx = lo + (hi - lo) * i as f64 / 4.0;
            let fy = lo + (hi - lo) * j as f64 / 3.0;
            out.push(Vector2::new(fx * W as f64 + 0.25, fy * H as f64 - 0.125));
        }
    }
    out
}

#[test]
fn conformance_nominal_examples_per_model() {
    for m in ModelId::ALL {
        let ex = examples(m);
        assert!(ex.len() >= 3, "{m}: {} examples", ex.len());
        assert!(
            ex.iter()
                .all(|c| c.model == m && c.params.len() == m.num_params())
        );
    }
}

/// point → pixel → normalized gives back (x/z, y/z) (or the unit ray for EQUIRECTANGULAR).
#[test]
fn conformance_project_unproject() {
    for m in ModelId::ALL {
        let mut n = 0;
        for cam in examples(m) {
            for p in points(m) {
                let px = cam
                    .img_from_cam(&p)
                    .unwrap_or_else(|r| panic!("{m}: {p:?} rejected: {r}"));
                if m == ModelId::Equirectangular {
                    let ray = cam.cam_ray_from_img(&px).expect("every pixel has a ray");
                    // atan2/sin/cos round trip: a few ulps of angles ≤ π.
                    assert_abs_diff_eq!(ray, p.normalize(), epsilon = 1e-14);
                    n += 1;
                    continue;
                }
                let want = Vector2::new(p.x / p.z, p.y / p.z);
                // COLMAP's stopping rule (‖step‖² < 1e-10) leaves an error of order
                // ‖step‖² ≲ 1e-10 after the last quadratic-convergence step.
                let colmap = cam.cam_from_img(&px).expect("converges");
                assert_abs_diff_eq!(colmap.normalized, want, epsilon = 1e-9);
                // Run to ‖step‖ < 1e-12: rounding level, amplified by the pixel → normalized
                // conditioning (|x| ≤ 1.7 rad, 1/f ≈ 1e-3): 1e-11.
                let strict = cam.cam_from_img_with(&px, 1e-24, 100).expect("converges");
                assert_abs_diff_eq!(strict.normalized, want, epsilon = 1e-11);
                assert!(strict.iterations <= 100 && strict.step_norm.is_finite());
                let ray = cam.cam_ray_from_img(&px).expect("ray");
                assert_abs_diff_eq!(ray, p.normalize(), epsilon = 1e-9);
                n += 1;
            }
        }
        assert!(n >= 3 * 75, "{m}: only {n} round trips");
    }
}

/// pixel → normalized → pixel at several depths gives back the pixel.
#[test]
fn conformance_unproject_project() {
    for m in ModelId::ALL {
        let mut n = 0;
        for cam in examples(m) {
            for px in pixels(m) {
                let ray = if m == ModelId::Equirectangular {
                    cam.cam_ray_from_img(&px).expect("ray")
                } else {
                    let u = cam.cam_from_img_with(&px, 1e-24, 100).expect("converges");
                    Vector3::new(u.normalized.x, u.normalized.y, 1.0)
                };
                for d in DEPTHS {
                    let back = cam.img_from_cam(&(ray * d)).expect("in front");
                    // Normalized error ~1e-12 times f ≈ 1000 px: 1e-8 px.
                    assert_abs_diff_eq!(back, px, epsilon = 1e-8);
                    n += 1;
                }
            }
        }
        assert!(n >= 3 * 60, "{m}: only {n} round trips");
    }
}

/// Central difference of `f` along one coordinate.
fn central(f: impl Fn(f64) -> Vector2<f64>, x: f64, h: f64) -> Vector2<f64> {
    (f(x + h) - f(x - h)) / (2.0 * h)
}

/// Central differences with h = 1e-6·scale have truncation error h²/6·|f'''| and rounding
/// error ε·|f|/h ≈ 2e-16·1e3/1e-6 ≈ 2e-7 px per unit; 1e-6 relative (with 1e-5 absolute
/// floor) covers both.
const FD_REL: f64 = 1e-6;
const FD_ABS: f64 = 1e-5;

#[test]
fn conformance_jacobian_point() {
    for m in ModelId::ALL {
        let mut n = 0;
        for cam in examples(m) {
            for p in points(m).into_iter().step_by(7) {
                let jac = cam.dx_img_from_cam_point(&p).expect("in front");
                let h = 1e-6 * p.norm();
                for k in 0..3 {
                    let fd = central(
                        |t| {
                            let mut q = p;
                            q[k] = t;
                            cam.img_from_cam(&q).expect("in front")
                        },
                        p[k],
                        h,
                    );
                    for r in 0..2 {
                        assert_relative_eq!(
                            jac[(r, k)],
                            fd[r],
                            epsilon = FD_ABS,
                            max_relative = FD_REL
                        );
                    }
                }
                n += 1;
            }
        }
        assert!(n >= 3 * 5, "{m}: only {n} point Jacobians");
    }
}

#[test]
fn conformance_jacobian_params() {
    for m in ModelId::ALL {
        let mut n = 0;
        for cam in examples(m) {
            for p in points(m).into_iter().step_by(7) {
                let jac = cam.dx_img_from_params(&p).expect("in front");
                assert_eq!(jac.ncols(), m.num_params());
                for k in 0..m.num_params() {
                    let h = 1e-6 * cam.params[k].abs().max(1.0);
                    let fd = central(
                        |t| {
                            // The examples stay ≥ 1e-6 inside every parameter limit, so the
                            // perturbed camera is still valid.
                            let mut c = cam.clone();
                            c.params[k] = t;
                            c.img_from_cam(&p).expect("in front")
                        },
                        cam.params[k],
                        h,
                    );
                    for r in 0..2 {
                        assert_relative_eq!(
                            jac[(r, k)],
                            fd[r],
                            epsilon = FD_ABS,
                            max_relative = FD_REL
                        );
                    }
                }
                n += 1;
            }
        }
        assert!(n >= 3 * 5, "{m}: only {n} parameter Jacobians");
    }
}

#[test]
fn conformance_invalid_params() {
    for m in ModelId::ALL {
        let mut n = 0;
        for cam in examples(m) {
            let q = cam.params.clone();
            for len in [q.len() - 1, q.len() + 1, 0] {
                let mut bad = q.clone();
                bad.resize(len, 1.0);
                let r = Camera::new(m, W, H, bad);
                assert!(
                    matches!(r, Err(Error::WrongParamCount { expected, found, .. }) if expected == q.len() && found == len),
                    "{m}: {r:?}"
                );
                n += 1;
            }
            for i in 0..q.len() {
                for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                    let mut bad = q.clone();
                    bad[i] = v;
                    let r = Camera::new(m, W, H, bad);
                    assert!(
                        matches!(r, Err(Error::InvalidParam { name, .. }) if name == m.param_names()[i]),
                        "{m}: {r:?}"
                    );
                    n += 1;
                }
            }
            let positive: &[usize] = if m == ModelId::Equirectangular {
                &[0, 1]
            } else {
                m.focal_idxs()
            };
            for &i in positive {
                for v in [0.0, -1.0] {
                    let mut bad = q.clone();
                    bad[i] = v;
                    assert!(matches!(
                        Camera::new(m, W, H, bad),
                        Err(Error::InvalidParam { .. })
                    ));
                    n += 1;
                }
            }
            let extra: &[(usize, f64)] = match m {
                ModelId::Eucm => &[(4, -0.1), (4, 1.1), (5, 0.0), (5, -1.0)],
                ModelId::Fov => &[(4, -0.1), (4, std::f64::consts::PI)],
                _ => &[],
            };
            for &(i, v) in extra {
                let mut bad = q.clone();
                bad[i] = v;
                assert!(matches!(
                    Camera::new(m, W, H, bad),
                    Err(Error::InvalidParam { .. })
                ));
                n += 1;
            }
        }
        assert!(n >= 3 * 6, "{m}: only {n} invalid-parameter checks");
    }
}

#[test]
fn conformance_rejects() {
    use ModelId as M;
    for m in ModelId::ALL {
        for cam in examples(m) {
            let nan = Vector3::new(f64::NAN, 0.0, 1.0);
            assert_eq!(cam.img_from_cam(&nan), Err(ProjectionReject::NotFinite));
            assert!(cam.dx_img_from_cam_point(&nan).is_err());
            assert!(cam.dx_img_from_params(&nan).is_err());
            let px = Vector2::new(f64::NAN, 1.0);
            assert_eq!(cam.cam_from_img(&px), Err(UndistortError::NotFinite));
            assert!(cam.cam_ray_from_img(&px).is_err());
            let behind = Vector3::new(0.1, 0.2, -1.0);
            let on_plane = Vector3::new(0.1, 0.2, 0.0);
            match m {
                // No cheirality check in COLMAP: points behind the camera project.
                M::SimpleDivision | M::Division | M::Equirectangular => {
                    assert!(cam.img_from_cam(&behind).is_ok(), "{m}");
                }
                _ => {
                    assert_eq!(
                        cam.img_from_cam(&behind),
                        Err(ProjectionReject::BehindCamera)
                    );
                    assert_eq!(
                        cam.img_from_cam(&on_plane),
                        Err(ProjectionReject::BehindCamera)
                    );
                }
            }
        }
    }
    // Cameras built with a struct literal bypass validation: every map refuses them.
    for (model, params) in [
        (M::Pinhole, vec![500.0]),
        (M::RadTanThinPrismFisheye, vec![1.0; 20]),
        (
            M::OpenCv,
            vec![f64::NAN, 500.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        ),
        (M::Eucm, vec![500.0, 500.0, 1.0, 1.0, 2.0, 1.0]),
        (M::Equirectangular, vec![0.0, 100.0]),
    ] {
        let bad = Camera {
            model,
            width: W,
            height: H,
            params,
        };
        let p = Vector3::new(0.1, 0.1, 1.0);
        assert_eq!(bad.img_from_cam(&p), Err(ProjectionReject::InvalidParams));
        assert_eq!(
            bad.dx_img_from_cam_point(&p),
            Err(ProjectionReject::InvalidParams)
        );
        assert!(bad.dx_img_from_params(&p).is_err());
        let px = Vector2::new(10.0, 10.0);
        assert_eq!(bad.cam_from_img(&px), Err(UndistortError::InvalidParams));
        assert_eq!(
            bad.cam_ray_from_img(&px),
            Err(UndistortError::InvalidParams)
        );
    }
    let eq = &examples(M::Equirectangular)[0];
    assert_eq!(
        eq.img_from_cam(&Vector3::zeros()),
        Err(ProjectionReject::OutsideDomain)
    );
    // A pixel looking backwards has no normalized coordinates, but has a ray.
    let back = Vector2::new(0.02 * eq.params[0], 0.5 * eq.params[1]);
    assert_eq!(eq.cam_from_img(&back), Err(UndistortError::OutsideDomain));
    assert!(eq.cam_ray_from_img(&back).expect("ray").z < 0.0);
    // Fisheye pixels beyond 90° are rejected, not silently wrong.
    let fe = &examples(M::Fisheye)[0];
    assert_eq!(
        fe.cam_from_img(&Vector2::new(
            fe.params[2] + 3.0 * fe.params[0],
            fe.params[3]
        )),
        Err(UndistortError::OutsideDomain)
    );
    // Division discriminant < 0 (k > 0, far off-axis point).
    let div = Camera::new(M::SimpleDivision, W, H, vec![500.0, 512.0, 384.0, 0.5]).expect("valid");
    assert_eq!(
        div.img_from_cam(&Vector3::new(2.0, 0.0, 1.0)),
        Err(ProjectionReject::OutsideDomain)
    );
    // Strong distortion that folds over: Newton fails loudly instead of returning garbage.
    let fold = Camera::new(M::SimpleRadial, W, H, vec![100.0, 512.0, 384.0, -1.0]).expect("valid");
    assert!(matches!(
        fold.cam_from_img(&Vector2::new(1000.0, 384.0)),
        Err(UndistortError::NotConverged { .. } | UndistortError::Singular { .. })
    ));
}

// ---------------------------------------------------------------- OpenCvCamera

fn opencv_examples() -> Vec<OpenCvCamera> {
    let mut out = Vec::new();
    for (l, tilt) in [
        (0.3, [0.0, 0.0]),
        (0.7, [0.01, -0.015]),
        (1.0, [-0.02, 0.01]),
    ] {
        let mut dist = vec![
            -0.12 * l,
            0.03 * l,
            1e-3 * l,
            -8e-4 * l,
            0.008 * l,
            0.04 * l,
            -0.015 * l,
            0.004 * l,
            1.5e-3 * l,
            -4e-4 * l,
            -1e-3 * l,
            3e-4 * l,
        ];
        dist.extend_from_slice(&tilt);
        out.push(OpenCvCamera::from_dist_coeffs(950.0, 960.0, 511.5, 383.5, &dist).expect("valid"));
    }
    out
}

#[test]
fn opencv_camera_nominal_round_trips() {
    let mut n = 0;
    for cam in opencv_examples() {
        for p in points(ModelId::OpenCv) {
            let px = cam.img_from_cam(&p).expect("in front");
            let u = cam.cam_from_img(&px).expect("converges");
            // Stopping rule ‖step‖ < 1e-12; see conformance_project_unproject.
            assert_abs_diff_eq!(
                u.normalized,
                Vector2::new(p.x / p.z, p.y / p.z),
                epsilon = 1e-11
            );
            assert_abs_diff_eq!(
                cam.cam_ray_from_img(&px).expect("ray"),
                p.normalize(),
                epsilon = 1e-11
            );
            n += 1;
        }
        for px in pixels(ModelId::OpenCv) {
            let u = cam.cam_from_img(&px).expect("converges").normalized;
            for d in DEPTHS {
                let back = cam
                    .img_from_cam(&(Vector3::new(u.x, u.y, 1.0) * d))
                    .expect("in front");
                assert_abs_diff_eq!(back, px, epsilon = 1e-8);
            }
            n += 1;
        }
    }
    assert!(n >= 3 * 95);
}

#[test]
fn opencv_camera_jacobians() {
    for cam in opencv_examples() {
        for p in points(ModelId::OpenCv).into_iter().step_by(7) {
            let jp = cam.dx_img_from_cam_point(&p).expect("in front");
            for k in 0..3 {
                let fd = central(
                    |t| {
                        let mut q = p;
                        q[k] = t;
                        cam.img_from_cam(&q).expect("in front")
                    },
                    p[k],
                    1e-6 * p.norm(),
                );
                for r in 0..2 {
                    assert_relative_eq!(jp[(r, k)], fd[r], epsilon = FD_ABS, max_relative = FD_REL);
                }
            }
            let jq = cam.dx_img_from_params(&p).expect("in front");
            let q0 = cam.params();
            for k in 0..OpenCvCamera::NUM_PARAMS {
                let h = 1e-6 * q0[k].abs().max(1.0);
                let fd = central(
                    |t| {
                        let mut q = q0;
                        q[k] = t;
                        OpenCvCamera::from_params(&q)
                            .expect("valid")
                            .img_from_cam(&p)
                            .expect("in front")
                    },
                    q0[k],
                    h,
                );
                for r in 0..2 {
                    assert_relative_eq!(jq[(r, k)], fd[r], epsilon = FD_ABS, max_relative = FD_REL);
                }
            }
        }
    }
}

#[test]
fn opencv_camera_invalid_params() {
    assert!(matches!(
        OpenCvCamera::from_dist_coeffs(900.0, 900.0, 1.0, 1.0, &[0.1, 0.2, 0.3]),
        Err(Error::WrongOpenCvCoeffCount { found: 3 })
    ));
    let q = opencv_examples()[1].params();
    for i in 0..OpenCvCamera::NUM_PARAMS {
        let mut bad = q;
        bad[i] = f64::NAN;
        assert!(matches!(
            OpenCvCamera::from_params(&bad),
            Err(Error::InvalidOpenCvParam { name, .. }) if name == OpenCvCamera::PARAM_NAMES[i]
        ));
    }
    for (i, v) in [(0, 0.0), (1, -5.0), (16, 1.6), (17, -1.6)] {
        let mut bad = q;
        bad[i] = v;
        assert!(matches!(
            OpenCvCamera::from_params(&bad),
            Err(Error::InvalidOpenCvParam { .. })
        ));
    }
    let cam = opencv_examples()[0];
    assert_eq!(
        cam.img_from_cam(&Vector3::new(0.0, 0.0, -1.0)),
        Err(ProjectionReject::BehindCamera)
    );
}

/// The 0.5-pixel shift: an OpenCV pixel + 0.5 is the COLMAP pixel of the same point.
#[test]
fn opencv_camera_colmap_conversion() {
    use ModelId as M;
    let mut n = 0;
    for m in [
        M::SimplePinhole,
        M::Pinhole,
        M::SimpleRadial,
        M::Radial,
        M::OpenCv,
        M::FullOpenCv,
    ] {
        for cam in examples(m) {
            let cv = OpenCvCamera::from_colmap(&cam).expect("convertible");
            assert_abs_diff_eq!(
                cv.cx,
                cam.params[m.principal_point_idxs()[0]] - 0.5,
                epsilon = 0.0
            );
            for p in points(m).into_iter().step_by(5) {
                let a = cam.img_from_cam(&p).expect("in front");
                let b = colmap_from_opencv_pixel(&cv.img_from_cam(&p).expect("in front"));
                // Same formulas, different operation order: 1e-12 relative of ~1000 px.
                assert_abs_diff_eq!(a, b, epsilon = 1e-9);
                n += 1;
            }
            let back = cv.to_colmap(W, H).expect("no thin prism, no tilt");
            for p in points(m).into_iter().step_by(5) {
                let a = cam.img_from_cam(&p).expect("in front");
                assert_abs_diff_eq!(back.img_from_cam(&p).expect("in front"), a, epsilon = 1e-9);
            }
        }
    }
    assert!(n >= 6 * 3 * 10);
    let full = examples(M::FullOpenCv)[0].clone();
    let cv = OpenCvCamera::from_colmap(&full).expect("convertible");
    let back = cv.to_colmap(W, H).expect("convertible");
    assert_eq!(back.model, M::FullOpenCv);
    for (a, b) in back.params.iter().zip(&full.params) {
        assert_abs_diff_eq!(*a, *b, epsilon = 1e-12);
    }
    assert!(matches!(
        OpenCvCamera::from_colmap(&examples(M::Fov)[0]),
        Err(Error::NoOpenCvEquivalent { model: M::Fov })
    ));
    assert!(matches!(
        opencv_examples()[0].to_colmap(W, H),
        Err(Error::NoColmapEquivalent { name: "s1", .. })
    ));
}
