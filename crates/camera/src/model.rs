//! The COLMAP camera-model table (ids 0–17) and the validated [`Camera`].

use crate::Error;

/// A COLMAP camera model. The discriminant order is COLMAP's model id (0..=17).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ModelId {
    /// 0: `f, cx, cy`.
    SimplePinhole,
    /// 1: `fx, fy, cx, cy`.
    Pinhole,
    /// 2: `f, cx, cy, k`.
    SimpleRadial,
    /// 3: `f, cx, cy, k1, k2`.
    Radial,
    /// 4: `fx, fy, cx, cy, k1, k2, p1, p2`.
    OpenCv,
    /// 5: `fx, fy, cx, cy, k1, k2, k3, k4` (equidistant fisheye, OpenCV `cv::fisheye`).
    OpenCvFisheye,
    /// 6: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6` (OpenCV rational model).
    FullOpenCv,
    /// 7: `fx, fy, cx, cy, omega` (field-of-view model).
    Fov,
    /// 8: `f, cx, cy, k`.
    SimpleRadialFisheye,
    /// 9: `f, cx, cy, k1, k2`.
    RadialFisheye,
    /// 10: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1`.
    ThinPrismFisheye,
    /// 11: `fx, fy, cx, cy, k0..k5, p0, p1, s0..s3` (Aria "Fisheye624").
    RadTanThinPrismFisheye,
    /// 12: `f, cx, cy, k`.
    SimpleDivision,
    /// 13: `fx, fy, cx, cy, k`.
    Division,
    /// 14: `f, cx, cy`.
    SimpleFisheye,
    /// 15: `fx, fy, cx, cy`.
    Fisheye,
    /// 16: `fx, fy, cx, cy, alpha, beta` (enhanced unified camera model).
    Eucm,
    /// 17: `w, h` (image size as doubles).
    Equirectangular,
}

/// Per-model static data: (id, COLMAP name, parameter names).
const TABLE: [(ModelId, &str, &[&str]); 18] = [
    (ModelId::SimplePinhole, "SIMPLE_PINHOLE", &["f", "cx", "cy"]),
    (ModelId::Pinhole, "PINHOLE", &["fx", "fy", "cx", "cy"]),
    (
        ModelId::SimpleRadial,
        "SIMPLE_RADIAL",
        &["f", "cx", "cy", "k"],
    ),
    (ModelId::Radial, "RADIAL", &["f", "cx", "cy", "k1", "k2"]),
    (
        ModelId::OpenCv,
        "OPENCV",
        &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
    ),
    (
        ModelId::OpenCvFisheye,
        "OPENCV_FISHEYE",
        &["fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"],
    ),
    (
        ModelId::FullOpenCv,
        "FULL_OPENCV",
        &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
        ],
    ),
    (ModelId::Fov, "FOV", &["fx", "fy", "cx", "cy", "omega"]),
    (
        ModelId::SimpleRadialFisheye,
        "SIMPLE_RADIAL_FISHEYE",
        &["f", "cx", "cy", "k"],
    ),
    (
        ModelId::RadialFisheye,
        "RADIAL_FISHEYE",
        &["f", "cx", "cy", "k1", "k2"],
    ),
    (
        ModelId::ThinPrismFisheye,
        "THIN_PRISM_FISHEYE",
        &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1",
        ],
    ),
    (
        ModelId::RadTanThinPrismFisheye,
        "RAD_TAN_THIN_PRISM_FISHEYE",
        &[
            "fx", "fy", "cx", "cy", "k0", "k1", "k2", "k3", "k4", "k5", "p0", "p1", "s0", "s1",
            "s2", "s3",
        ],
    ),
    (
        ModelId::SimpleDivision,
        "SIMPLE_DIVISION",
        &["f", "cx", "cy", "k"],
    ),
    (
        ModelId::Division,
        "DIVISION",
        &["fx", "fy", "cx", "cy", "k"],
    ),
    (ModelId::SimpleFisheye, "SIMPLE_FISHEYE", &["f", "cx", "cy"]),
    (ModelId::Fisheye, "FISHEYE", &["fx", "fy", "cx", "cy"]),
    (
        ModelId::Eucm,
        "EUCM",
        &["fx", "fy", "cx", "cy", "alpha", "beta"],
    ),
    (ModelId::Equirectangular, "EQUIRECTANGULAR", &["w", "h"]),
];

impl ModelId {
    /// All 18 models in COLMAP id order.
    pub const ALL: [ModelId; 18] = [
        ModelId::SimplePinhole,
        ModelId::Pinhole,
        ModelId::SimpleRadial,
        ModelId::Radial,
        ModelId::OpenCv,
        ModelId::OpenCvFisheye,
        ModelId::FullOpenCv,
        ModelId::Fov,
        ModelId::SimpleRadialFisheye,
        ModelId::RadialFisheye,
        ModelId::ThinPrismFisheye,
        ModelId::RadTanThinPrismFisheye,
        ModelId::SimpleDivision,
        ModelId::Division,
        ModelId::SimpleFisheye,
        ModelId::Fisheye,
        ModelId::Eucm,
        ModelId::Equirectangular,
    ];

    /// The model with COLMAP id `id` (0..=17).
    pub fn from_id(id: i32) -> Result<ModelId, Error> {
        usize::try_from(id)
            .ok()
            .and_then(|i| Self::ALL.get(i).copied())
            .ok_or(Error::UnknownModelId { id })
    }

    /// COLMAP's numeric model id.
    pub fn id(self) -> i32 {
        self as i32
    }

    /// The model with COLMAP name `name` (exact, upper case, e.g. `"OPENCV"`).
    pub fn from_name(name: &str) -> Result<ModelId, Error> {
        TABLE
            .iter()
            .find(|(_, n, _)| *n == name)
            .map(|(m, _, _)| *m)
            .ok_or_else(|| Error::UnknownModelName {
                name: name.to_owned(),
            })
    }

    /// COLMAP's model name (e.g. `"SIMPLE_RADIAL"`).
    pub fn name(self) -> &'static str {
        TABLE[self as usize].1
    }

    /// Number of parameters of the model.
    pub fn num_params(self) -> usize {
        TABLE[self as usize].2.len()
    }

    /// Parameter names in COLMAP's order.
    pub fn param_names(self) -> &'static [&'static str] {
        TABLE[self as usize].2
    }

    /// Indices of the focal length(s) in the parameter vector (`[0]` or `[0, 1]`; empty for
    /// EQUIRECTANGULAR).
    pub fn focal_idxs(self) -> &'static [usize] {
        match self {
            ModelId::SimplePinhole
            | ModelId::SimpleRadial
            | ModelId::Radial
            | ModelId::SimpleRadialFisheye
            | ModelId::RadialFisheye
            | ModelId::SimpleDivision
            | ModelId::SimpleFisheye => &[0],
            ModelId::Equirectangular => &[],
            _ => &[0, 1],
        }
    }

    /// Indices of the principal point `(cx, cy)` (empty for EQUIRECTANGULAR).
    pub fn principal_point_idxs(self) -> &'static [usize] {
        match self.focal_idxs().len() {
            1 => &[1, 2],
            2 => &[2, 3],
            _ => &[],
        }
    }

    /// True for the fisheye class (distortion acts on the incidence angle θ).
    pub fn is_fisheye(self) -> bool {
        matches!(
            self,
            ModelId::OpenCvFisheye
                | ModelId::SimpleRadialFisheye
                | ModelId::RadialFisheye
                | ModelId::ThinPrismFisheye
                | ModelId::RadTanThinPrismFisheye
                | ModelId::SimpleFisheye
                | ModelId::Fisheye
        )
    }
}

impl std::fmt::Display for ModelId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for ModelId {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ModelId::from_name(s)
    }
}

/// A camera in COLMAP's conventions: model, image size in pixels and parameters in COLMAP's
/// order, pixel coordinates with the centre of the upper-left pixel at (0.5, 0.5).
///
/// Fields are public for reading; build it with [`Camera::new`] so the parameters are checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// The COLMAP model.
    pub model: ModelId,
    /// Image width in pixels.
    pub width: u64,
    /// Image height in pixels.
    pub height: u64,
    /// Parameters in COLMAP's order ([`ModelId::param_names`]); focal lengths and principal
    /// point in pixels.
    pub params: Vec<f64>,
}

impl Camera {
    /// A validated camera: the parameter count must match the model, every parameter must be
    /// finite, focal lengths must be > 0, and model-specific limits hold (FOV 0 ≤ ω < π,
    /// EUCM α ∈ [0, 1] and β > 0, EQUIRECTANGULAR w, h > 0).
    pub fn new(model: ModelId, width: u64, height: u64, params: Vec<f64>) -> Result<Camera, Error> {
        validate_params(model, &params)?;
        Ok(Camera {
            model,
            width,
            height,
            params,
        })
    }

    /// Checks the invariants of [`Camera::new`] again (the fields are public).
    pub fn validate(&self) -> Result<(), Error> {
        validate_params(self.model, &self.params)
    }
}

/// Parameter checks shared by [`Camera::new`] and [`Camera::validate`].
pub(crate) fn validate_params(model: ModelId, params: &[f64]) -> Result<(), Error> {
    let names = model.param_names();
    if params.len() != names.len() {
        return Err(Error::WrongParamCount {
            model,
            expected: names.len(),
            found: params.len(),
        });
    }
    let bad = |i: usize| Error::InvalidParam {
        model,
        name: names[i],
        value: params[i],
    };
    if let Some(i) = params.iter().position(|p| !p.is_finite()) {
        return Err(bad(i));
    }
    for &i in model.focal_idxs() {
        if params[i] <= 0.0 {
            return Err(bad(i));
        }
    }
    let bad_idx = match model {
        ModelId::Fov if !(0.0..std::f64::consts::PI).contains(&params[4]) => Some(4),
        ModelId::Eucm if !(0.0..=1.0).contains(&params[4]) => Some(4),
        ModelId::Eucm if params[5] <= 0.0 => Some(5),
        ModelId::Equirectangular => params.iter().position(|&v| v <= 0.0),
        _ => None,
    };
    if let Some(i) = bad_idx {
        return Err(bad(i));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_id_nominal() {
        for (i, m) in ModelId::ALL.iter().enumerate() {
            assert_eq!(m.id(), i as i32);
            assert_eq!(ModelId::from_id(i as i32), Ok(*m));
            assert_eq!(ModelId::from_name(m.name()), Ok(*m));
        }
        assert_eq!(ModelId::OpenCv.num_params(), 8);
        assert_eq!(ModelId::RadTanThinPrismFisheye.num_params(), 16);
    }

    #[test]
    fn model_id_unknown() {
        assert_eq!(ModelId::from_id(18), Err(Error::UnknownModelId { id: 18 }));
        assert_eq!(ModelId::from_id(-1), Err(Error::UnknownModelId { id: -1 }));
        assert!(matches!(
            ModelId::from_name("opencv"),
            Err(Error::UnknownModelName { .. })
        ));
    }

    #[test]
    fn camera_new_invalid() {
        assert!(matches!(
            Camera::new(ModelId::Pinhole, 10, 10, vec![1.0, 2.0, 3.0]),
            Err(Error::WrongParamCount {
                expected: 4,
                found: 3,
                ..
            })
        ));
        assert!(matches!(
            Camera::new(ModelId::SimplePinhole, 10, 10, vec![0.0, 2.0, 3.0]),
            Err(Error::InvalidParam { name: "f", .. })
        ));
        assert!(matches!(
            Camera::new(ModelId::Eucm, 10, 10, vec![1.0, 1.0, 3.0, 3.0, 1.5, 1.0]),
            Err(Error::InvalidParam { name: "alpha", .. })
        ));
    }
}
