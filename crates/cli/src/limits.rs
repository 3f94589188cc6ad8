//! Bounds on command-line values that size work or memory, or that turn results into `inf`
//! (`docs/LIMITS.md` lists them with the scenario bounds of `crashrig_mc::limits`). Values are
//! checked while the arguments are parsed, so a bad one is a usage error naming the option.

/// Largest worker-thread count (`--threads`, `RAYON_NUM_THREADS`).
pub const MAX_THREADS: usize = 1024;
/// Largest `bootstrap --iterations`.
pub const MAX_BOOTSTRAP_ITERATIONS: usize = 1_000_000;
/// Smallest and largest `--mm-per-unit` (a model in nanometre … kilometre-scale units).
pub const MM_PER_UNIT_RANGE: (f64, f64) = (1e-9, 1e9);

/// clap value parser of `--mm-per-unit`: a finite number within [`MM_PER_UNIT_RANGE`].
pub fn parse_mm_per_unit(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    let (lo, hi) = MM_PER_UNIT_RANGE;
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "must be a number from {lo:e} to {hi:e} mm per model unit"
        ))
    }
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
        assert_eq!(parse_threads("1024"), Ok(1024));
        assert!(parse_threads("1025").is_err());
        assert!(parse_threads("0").is_err());
    }
}
