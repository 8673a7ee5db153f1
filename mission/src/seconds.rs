//! Float seconds from outside (mission items, parameters, command fields,
//! files) as a [`Duration`], without the panic of `Duration::from_secs_f*`
//! on a NaN, negative, infinite or huge value. The one such conversion in
//! Furrow: every crate that turns float seconds into time uses it.

use std::time::Duration;

/// `secs` as a `Duration`, saturating: NaN and anything not above 0 is
/// zero, anything beyond `Duration::MAX` (infinity included) is
/// `Duration::MAX`. Validation bounds what a vehicle uses; this is the
/// defence in depth behind it.
pub fn duration_from_secs(secs: f64) -> Duration {
    if secs.is_nan() || secs <= 0.0 {
        return Duration::ZERO;
    }
    Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturates_instead_of_panicking() {
        assert_eq!(duration_from_secs(1.5), Duration::from_millis(1500));
        assert_eq!(duration_from_secs(f64::NAN), Duration::ZERO);
        assert_eq!(duration_from_secs(-f64::NAN), Duration::ZERO);
        assert_eq!(duration_from_secs(-1.0), Duration::ZERO);
        assert_eq!(duration_from_secs(-0.0), Duration::ZERO);
        assert_eq!(duration_from_secs(f64::NEG_INFINITY), Duration::ZERO);
        assert_eq!(duration_from_secs(1e20), Duration::MAX);
        assert_eq!(duration_from_secs(f64::INFINITY), Duration::MAX);
        assert_eq!(duration_from_secs(f64::from(f32::MAX)), Duration::MAX);
        assert_eq!(duration_from_secs(5e-324), Duration::ZERO);
    }
}
