//! `printf("%.17g")` for f64, as COLMAP's text writer prints every double.

use std::fmt::Write;

/// Appends `x` formatted like C's `%.17g` (17 significant digits, trailing zeros removed,
/// exponent form `1.7763568394002505e-15` when the exponent is < −4 or ≥ 17, `-0` kept).
pub fn push_g17(out: &mut String, x: f64) {
    if x.is_nan() {
        out.push_str(if x.is_sign_negative() { "-nan" } else { "nan" });
        return;
    }
    if x.is_infinite() {
        out.push_str(if x < 0.0 { "-inf" } else { "inf" });
        return;
    }
    if x == 0.0 {
        out.push_str(if x.is_sign_negative() { "-0" } else { "0" });
        return;
    }
    // The exponent %g decides on is the one of the %.16e rendering (after rounding).
    let mut sci = String::with_capacity(32);
    let _ = write!(sci, "{x:.16e}");
    let (mantissa, exp) = match sci.split_once('e') {
        Some((m, e)) => (m, e.parse::<i32>().unwrap_or(0)),
        None => (sci.as_str(), 0),
    };
    if !(-4..17).contains(&exp) {
        out.push_str(strip_zeros(mantissa));
        out.push('e');
        out.push(if exp < 0 { '-' } else { '+' });
        let _ = write!(out, "{:02}", exp.unsigned_abs());
    } else {
        let decimals = (16 - exp) as usize;
        let mut fixed = String::with_capacity(32);
        let _ = write!(fixed, "{x:.decimals$}");
        out.push_str(strip_zeros(&fixed));
    }
}

/// `x` as a `%.17g` string.
pub fn g17(x: f64) -> String {
    let mut s = String::new();
    push_g17(&mut s, x);
    s
}

fn strip_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::g17;

    #[test]
    #[allow(clippy::excessive_precision)]
    fn g17_nominal() {
        // Expected strings are COLMAP 4.2.1 text output (fixtures/colmap/*/txt) and glibc printf.
        assert_eq!(g17(1280.0), "1280");
        assert_eq!(g17(515.5), "515.5");
        assert_eq!(g17(-0.08), "-0.080000000000000002");
        assert_eq!(g17(0.0012), "0.0011999999999999999");
        assert_eq!(g17(-0.0007), "-0.00069999999999999999");
        assert_eq!(g17(0.02), "0.02");
        assert_eq!(g17(5.5511151231257827e-17), "5.5511151231257827e-17");
        assert_eq!(g17(1.7763568394002505e-15), "1.7763568394002505e-15");
    }

    #[test]
    fn g17_edges() {
        assert_eq!(g17(-0.0), "-0");
        assert_eq!(g17(0.0), "0");
        assert_eq!(g17(1e17), "1e+17");
        assert_eq!(g17(1e16), "10000000000000000");
        assert_eq!(g17(0.0001), "0.0001");
        assert_eq!(g17(0.00001), "1.0000000000000001e-05");
        assert_eq!(g17(1e300), "1.0000000000000001e+300");
        assert_eq!(g17(f64::MIN_POSITIVE), "2.2250738585072014e-308");
        assert_eq!(g17(5e-324), "4.9406564584124654e-324");
        assert_eq!(g17(f64::INFINITY), "inf");
        assert_eq!(g17(f64::NAN), "nan");
    }

    #[test]
    fn g17_round_trip() {
        let mut x = 1.234_567_890_123_456_7e-30_f64;
        for _ in 0..200 {
            let s = g17(x);
            assert_eq!(s.parse::<f64>().map(f64::to_bits), Ok(x.to_bits()), "{s}");
            x *= -3.7;
        }
    }
}
