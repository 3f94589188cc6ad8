//! Which kind of result document a link was read from (without the `json` feature, so that
//! the types naming a link's origin need no JSON reader).

/// Which kind of document a link was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResultKind {
    /// `crashrig calibrate --json`: the link's covariance is `sem_covariance_tangent`.
    Calibrate,
    /// `crashrig bootstrap --json`: the link's covariance is `covariance_tangent`.
    Bootstrap,
    /// Neither marker: a link written by hand (`base_mm`, `angles_deg` and a covariance).
    Link,
}

impl ResultKind {
    /// `"calibrate"`, `"bootstrap"` or `"link"`.
    pub fn command(self) -> &'static str {
        match self {
            ResultKind::Calibrate => "calibrate",
            ResultKind::Bootstrap => "bootstrap",
            ResultKind::Link => "link",
        }
    }
}
