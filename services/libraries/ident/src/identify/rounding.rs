//! Numbers rounded to their standard errors, as the reports print them.

/// `value` rounded to its standard error (two significant digits of the error), in scientific
/// notation; three significant digits when the error is not known.
pub fn round_to(value: f64, stderr: f64) -> String {
    if !value.is_finite() {
        return value.to_string();
    }
    if !(stderr.is_finite() && stderr > 0.0) {
        return format!("{value:.2e}");
    }
    let e_se = stderr.log10().floor() as i32 - 1;
    let e_v = if value == 0.0 {
        e_se + 1
    } else {
        value.abs().log10().floor() as i32
    };
    let digits = (e_v - e_se).clamp(0, 12) as usize;
    if e_v < e_se {
        // The value is below its error's last digit: zero within the error.
        return format!("{:.1e}", 0.0);
    }
    format!("{value:.digits$e}")
}

/// `value ± stderr`, the value rounded to its error (see [`round_to`]).
pub fn with_error(value: f64, stderr: f64) -> String {
    if stderr.is_finite() && stderr > 0.0 {
        format!("{} ± {stderr:.1e}", round_to(value, stderr))
    } else {
        round_to(value, stderr)
    }
}
