//! Named numerical tolerances used by the geometry routines (no bare epsilons elsewhere).

/// Below this rotation angle (rad) the SO(3) series are evaluated by Taylor expansion.
///
/// The closed forms of `(θ − sin θ)/θ³` and `1/θ² − cot(θ/2)/(2θ)` lose about `ε/θ²` relative
/// precision to cancellation (they multiply `[w]×²`, of size θ², so the matrix error stays ~ε);
/// below 0.1 rad the truncated series (five terms) are exact to a few ulps.
pub const SO3_SERIES_ANGLE: f64 = 1e-1;

/// Below this angle (rad) `sin θ / θ` is replaced by `1 − θ²/6` (exact in f64 there).
pub const SO3_SINC_ANGLE: f64 = 1e-6;

/// |cos φ| below this value is treated as gimbal lock for ω-φ-κ.
///
/// At φ = ±90° exactly, f64 gives |cos φ| ≈ 6e-17; the threshold leaves a margin for rounding
/// while only biasing R by ~1e-9 when a near-lock rotation is folded into ω.
pub const GIMBAL_LOCK_COS_PHI: f64 = 1e-9;

/// Smallest quaternion norm accepted for normalisation.
pub const MIN_QUATERNION_NORM: f64 = 1e-12;

/// Smallest direction length (mm) accepted for a look-at.
pub const MIN_DIRECTION_NORM: f64 = 1e-12;

/// Smallest |d̂ × e_z| for a look-at (a camera looking straight up or down has no defined roll).
pub const MIN_LOOK_AT_HORIZONTAL: f64 = 1e-9;

/// Largest accepted condition number of the DLT design matrix (ratio of extreme singular values).
///
/// Exactly parallel rays give a computed condition of ~1e8 (√(1/ε) through the normal
/// equations), so the limit has to be well below that.
pub const DLT_MAX_CONDITION: f64 = 1e6;

/// Smallest |w| of the homogeneous DLT solution relative to its unit norm (points at infinity).
pub const DLT_MIN_HOMOGENEOUS_W: f64 = 1e-12;

/// Smallest mean resultant length for which a circular mean is defined.
pub const MIN_MEAN_RESULTANT: f64 = 1e-9;

/// Smallest ratio of the second to the first singular value of ΣR for a chordal mean.
pub const CHORDAL_MIN_SINGULAR_RATIO: f64 = 1e-9;

/// Smallest ratio of the second to the first singular value of the Umeyama cross-covariance
/// (collinear or coincident points fall below it).
pub const UMEYAMA_MIN_SINGULAR_RATIO: f64 = 1e-9;
