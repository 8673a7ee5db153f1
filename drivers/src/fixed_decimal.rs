//! Numbers with a fixed count of decimals, as the simulated devices write
//! them (`$VNIMU`, NMEA): the text of `format!("{:+0w$.d$}")`, made without
//! the standard formatter's exact-decimal machinery in the usual case.
//!
//! `{:.d$}` prints the decimal nearest to the binary value. Scaling by 10^d
//! and rounding gets the same digits unless the scaled value lies within a
//! rounding error of a half; the product's exact remainder (one fused
//! multiply-add) says which case this is, and those few numbers, and any
//! too large for the integer route, go to the standard formatter. At 50
//! IMU lines a second the standard route (Grisu, falling back to Dragon for
//! some values) was several per cent of a simulated second.

use std::fmt;

/// `value` with `decimals` places, zero-padded to `width` characters, with
/// a `+` on numbers that are not negative if `plus`: what
/// `{:+0width$.decimals$}` (or without `+`) writes.
#[derive(Clone, Copy, Debug)]
pub struct FixedDecimal {
    pub value: f64,
    pub decimals: usize,
    pub width: usize,
    pub plus: bool,
}

/// The largest scaled value (and its decimals) the integer route takes:
/// 10^decimals and the rounded scaled value are exact in an f64.
const MAX_DECIMALS: usize = 9;
const MAX_SCALED: f64 = 9_007_199_254_740_992.0; // 2^53
/// Room for a sign, 16 whole digits, the point, 9 decimals, and padding to
/// [`MAX_WIDTH`].
const TEXT_LEN: usize = 40;
const MAX_WIDTH: usize = 32;

impl FixedDecimal {
    /// `value` with `decimals` places, no padding, no `+`.
    pub fn new(value: f64, decimals: usize) -> Self {
        Self {
            value,
            decimals,
            width: 0,
            plus: false,
        }
    }

    /// The digits before and after the point, if the integer route gives
    /// exactly the standard formatter's.
    fn scaled(&self) -> Option<(u64, u64)> {
        if self.decimals > MAX_DECIMALS || self.width > MAX_WIDTH || !self.value.is_finite() {
            return None;
        }
        let scale = 10u64.pow(self.decimals as u32);
        let magnitude = self.value.abs();
        let rounded = (magnitude * scale as f64).round();
        if rounded >= MAX_SCALED {
            return None;
        }
        // The remainder of the exact product: below a half, the rounding
        // above picked the nearest decimal; at or above it, let the
        // standard formatter decide.
        let remainder = magnitude.mul_add(scale as f64, -rounded);
        if remainder.abs() >= 0.5 {
            return None;
        }
        let units = rounded as u64;
        Some((units / scale, units % scale))
    }
}

impl fmt::Display for FixedDecimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some((whole, fraction)) = self.scaled() else {
            let (value, width, decimals) = (self.value, self.width, self.decimals);
            return if self.plus {
                write!(f, "{value:+0width$.decimals$}")
            } else {
                write!(f, "{value:0width$.decimals$}")
            };
        };
        // Written backwards from the end: fraction digits, point, whole
        // digits, padding zeros (the buffer starts as zeros), sign.
        let mut text = [b'0'; TEXT_LEN];
        let mut start = text.len();
        if self.decimals > 0 {
            start = write_digits_before(&mut text, start, fraction, self.decimals);
            start -= 1;
            text[start] = b'.';
        }
        start = write_digits_before(&mut text, start, whole, 1);
        let sign = if self.value.is_sign_negative() {
            Some(b'-')
        } else {
            self.plus.then_some(b'+')
        };
        let used = text.len() - start + usize::from(sign.is_some());
        start -= self.width.saturating_sub(used);
        if let Some(sign) = sign {
            start -= 1;
            text[start] = sign;
        }
        // Only ASCII digits, '.', '+' and '-' were written.
        f.write_str(std::str::from_utf8(&text[start..]).map_err(|_| fmt::Error)?)
    }
}

/// Writes `n` in decimal, at least `at_least` digits (leading zeros),
/// ending just before `end`; returns where the digits start.
fn write_digits_before(text: &mut [u8], end: usize, mut n: u64, at_least: usize) -> usize {
    let mut start = end;
    while n > 0 || end - start < at_least {
        start -= 1;
        text[start] = b'0' + (n % 10) as u8;
        n /= 10;
    }
    start
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn standard(value: f64, decimals: usize, width: usize, plus: bool) -> String {
        if plus {
            format!("{value:+0width$.decimals$}")
        } else {
            format!("{value:0width$.decimals$}")
        }
    }

    fn fast(value: f64, decimals: usize, width: usize, plus: bool) -> String {
        FixedDecimal {
            value,
            decimals,
            width,
            plus,
        }
        .to_string()
    }

    #[test]
    fn device_fields_and_edge_values_match_the_formatter() {
        let values = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            0.125,
            0.0625,
            1e-12,
            -1e-12,
            0.99995,
            9.9995,
            59.99999995,
            1e15,
            1e17,
            -1e300,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            101.325,
            -9.80665,
            0.1,
            0.3,
        ];
        for value in values {
            for decimals in [0, 1, 3, 4, 6, 9, 12] {
                for (width, plus) in [(0, false), (8, true), (10, true), (5, true), (7, false)] {
                    assert_eq!(
                        fast(value, decimals, width, plus),
                        standard(value, decimals, width, plus),
                        "{value:e} .{decimals} width {width} plus {plus}"
                    );
                }
            }
        }
    }

    proptest! {
        #[test]
        fn matches_the_formatter(
            mantissa in -1.0f64..1.0,
            exponent in -12i32..16,
            decimals in 0usize..11,
            width in 0usize..14,
            plus in any::<bool>(),
        ) {
            let value = mantissa * 10f64.powi(exponent);
            prop_assert_eq!(fast(value, decimals, width, plus), standard(value, decimals, width, plus));
        }

        /// Halves and near-halves: the cases the integer route must hand over.
        #[test]
        fn matches_the_formatter_at_halves(
            units in 0u64..2_000_000,
            decimals in 0usize..7,
            nudge_ulps in -2i64..=2,
        ) {
            let half = (units as f64 + 0.5) / 10f64.powi(decimals as i32);
            let value = f64::from_bits((half.to_bits() as i64 + nudge_ulps) as u64);
            prop_assert_eq!(fast(value, decimals, 0, false), standard(value, decimals, 0, false));
            prop_assert_eq!(fast(-value, decimals, 9, true), standard(-value, decimals, 9, true));
        }
    }
}
