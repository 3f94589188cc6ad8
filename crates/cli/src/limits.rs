//! Bounds on command-line values that size work or memory, or that turn results into `inf`
//! (`docs/LIMITS.md` lists them with the scenario bounds of `crashrig_mc::limits`). Values are
//! checked while the arguments are parsed, so a bad one is a usage error naming the option.

/// Largest worker-thread count (`--threads`, `RAYON_NUM_THREADS`).
pub const MAX_THREADS: usize = 1024;
/// Largest `bootstrap --iterations`.
pub const MAX_BOOTSTRAP_ITERATIONS: usize = crashrig_bootstrap::MAX_ITERATIONS;
/// Largest `measure --samples` (replicates per row).
pub const MAX_MEASURE_SAMPLES: usize = crashrig_measure::plausible::MAX_SAMPLES;

/// clap value parser of `--shard i/N` (1 ≤ i ≤ N ≤ `crashrig_outdir::shard::MAX_SHARDS`).
pub fn parse_shard(s: &str) -> Result<crashrig_outdir::shard::Shard, String> {
    s.parse::<crashrig_outdir::shard::Shard>()
        .map_err(|e| match e {
            crashrig_outdir::Error::ShardSpec { problem, .. } => problem,
            other => other.to_string(),
        })
}

/// clap value parser of `--mm-per-unit`: every command's rule,
/// [`crashrig_input::options::mm_per_unit_problem`].
pub fn parse_mm_per_unit(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    crashrig_input::options::mm_per_unit_problem(v).map_or(Ok(v), Err)
}

/// clap value parser of `bootstrap --iterations`: 2 ..= [`MAX_BOOTSTRAP_ITERATIONS`].
pub fn parse_iterations(s: &str) -> Result<usize, String> {
    let v: u128 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (2..=MAX_BOOTSTRAP_ITERATIONS as u128).contains(&v) {
        Ok(v as usize)
    } else {
        Err(format!("must be from 2 to {MAX_BOOTSTRAP_ITERATIONS}"))
    }
}

/// clap value parser of `measure --samples`: 2 ..= [`MAX_MEASURE_SAMPLES`].
pub fn parse_measure_samples(s: &str) -> Result<usize, String> {
    let v: u128 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (2..=MAX_MEASURE_SAMPLES as u128).contains(&v) {
        Ok(v as usize)
    } else {
        Err(format!("must be from 2 to {MAX_MEASURE_SAMPLES}"))
    }
}

/// clap value parser of `study --samples`, `paper --samples` and `paper --chain-samples`:
/// 2 ..= [`crashrig_mc::limits::MAX_SAMPLES`].
pub fn parse_samples(s: &str) -> Result<usize, String> {
    let max = crashrig_mc::limits::MAX_SAMPLES;
    let v: u128 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (2..=max as u128).contains(&v) {
        Ok(v as usize)
    } else {
        Err(format!("must be from 2 to {max}"))
    }
}

/// clap value parser of a camera selector (`--camera-a` …): not empty or blank.
pub fn parse_camera(s: &str) -> Result<String, String> {
    if s.trim().is_empty() {
        Err("must name a camera (an image-name prefix such as `cam_in/`, or a camera id)".into())
    } else {
        Ok(s.to_string())
    }
}

/// clap value parser of an image name (`--image-a`, `colmap points --image` …): not empty or
/// blank.
pub fn parse_image_name(s: &str) -> Result<String, String> {
    if s.trim().is_empty() {
        Err("must name an image of the model (e.g. `cam_in/000001.png`)".into())
    } else {
        Ok(s.to_string())
    }
}

/// clap value parser of `--threads`: 1 ..= [`MAX_THREADS`].
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let v: u128 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    if (1..=MAX_THREADS as u128).contains(&v) {
        Ok(v as usize)
    } else {
        Err(format!("must be from 1 to {MAX_THREADS}"))
    }
}

/// Checks `RAYON_NUM_THREADS` (if set) against [`MAX_THREADS`] before any pool exists. rayon
/// reads the variable itself; a value it would ignore (empty, 0, not a number) is left to it,
/// a number above the bound is an error.
pub fn check_rayon_env() -> Result<(), String> {
    let Some(raw) = std::env::var_os("RAYON_NUM_THREADS") else {
        return Ok(());
    };
    let text = raw.to_string_lossy();
    match text.trim().parse::<u128>() {
        Ok(n) if n > MAX_THREADS as u128 => Err(format!(
            "RAYON_NUM_THREADS={n} exceeds the limit of {MAX_THREADS} worker threads"
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_cli_parsers() {
        assert_eq!(parse_mm_per_unit("1000"), Ok(1000.0));
        assert!(parse_mm_per_unit("1e308").is_err());
        assert!(parse_mm_per_unit("-1").is_err());
        assert!(parse_mm_per_unit("nan").is_err());
        assert!(parse_mm_per_unit("inf").is_err());
        assert_eq!(parse_iterations("500"), Ok(500));
        assert!(parse_iterations("1000000000000").is_err());
        assert!(parse_iterations("18446744073709551615").is_err());
        assert!(parse_iterations("99999999999999999999999999999").is_err());
        assert!(parse_iterations("1").is_err());
        assert_eq!(parse_samples("10000000"), Ok(10_000_000));
        assert!(parse_samples("10000001").is_err() && parse_samples("1").is_err());
        assert_eq!(parse_measure_samples("10000000"), Ok(10_000_000));
        assert!(parse_measure_samples("10000001").is_err());
        assert!(parse_measure_samples("1000000000").is_err());
        assert!(parse_camera("").is_err() && parse_camera("  ").is_err());
        assert_eq!(parse_camera("cam_in/"), Ok("cam_in/".to_string()));
        assert!(parse_image_name("").is_err() && parse_image_name(" ").is_err());
        assert_eq!(parse_image_name("a.png"), Ok("a.png".to_string()));
        assert_eq!(parse_threads("1024"), Ok(1024));
        assert!(parse_threads("1025").is_err());
        assert!(parse_threads("0").is_err());
    }
}

/// `--pixel-sigma-px`: a σ (px) or `estimate`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PixelSigmaArg {
    /// A stated σ (px).
    Px(f64),
    /// The pixel σ check's estimate.
    Estimate,
}

impl PixelSigmaArg {
    /// The stated σ: as given, or with `estimate` the default the check compares with.
    pub fn px(self) -> f64 {
        match self {
            PixelSigmaArg::Px(x) => x,
            PixelSigmaArg::Estimate => crashrig_measure::rules::DEFAULT_PIXEL_SIGMA_PX,
        }
    }

    /// Where the Monte Carlo's pixel σ comes from.
    pub fn from(self) -> crashrig_measure::pixel_check::PixelSigmaFrom {
        match self {
            PixelSigmaArg::Px(_) => crashrig_measure::pixel_check::PixelSigmaFrom::Stated,
            PixelSigmaArg::Estimate => crashrig_measure::pixel_check::PixelSigmaFrom::Estimate,
        }
    }
}

impl std::fmt::Display for PixelSigmaArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PixelSigmaArg::Px(x) => write!(f, "{x}"),
            PixelSigmaArg::Estimate => f.write_str("estimate"),
        }
    }
}

/// clap value parser of `--pixel-sigma-px`: `estimate`, or a number (its range is checked by
/// [`crashrig_measure::rules::pixel_sigma_px`] when the run starts).
pub fn parse_pixel_sigma(s: &str) -> Result<PixelSigmaArg, String> {
    match s.trim() {
        "estimate" => Ok(PixelSigmaArg::Estimate),
        t => t
            .parse()
            .map(PixelSigmaArg::Px)
            .map_err(|_| format!("`{s}` is neither a number (px) nor `estimate`")),
    }
}
