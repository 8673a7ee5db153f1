//! The description of one parameter.

use std::borrow::Cow;
use std::fmt;

/// How a parameter travels in MAVLink (`MAV_PARAM_TYPE`). Furrow uses the
/// subset ArduPilot uses; every value fits exactly in an `f32` when sent with
/// the C-cast encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParamType {
    Uint8,
    Int8,
    Int16,
    Int32,
    Real32,
}

impl ParamType {
    /// The `MAV_PARAM_TYPE` number.
    pub fn mav_param_type(self) -> u8 {
        match self {
            ParamType::Uint8 => 1,
            ParamType::Int8 => 2,
            ParamType::Int16 => 4,
            ParamType::Int32 => 6,
            ParamType::Real32 => 9,
        }
    }

    /// Smallest and largest value the type itself can hold.
    pub fn limits(self) -> (f64, f64) {
        match self {
            ParamType::Uint8 => (0.0, f64::from(u8::MAX)),
            ParamType::Int8 => (f64::from(i8::MIN), f64::from(i8::MAX)),
            ParamType::Int16 => (f64::from(i16::MIN), f64::from(i16::MAX)),
            // Values beyond 2^24 cannot cross MAVLink exactly with the C-cast
            // encoding; the declared ranges keep well inside this.
            ParamType::Int32 => (f64::from(i32::MIN), f64::from(i32::MAX)),
            ParamType::Real32 => (f64::from(f32::MIN), f64::from(f32::MAX)),
        }
    }

    /// The value as this type stores it: integers round to nearest, floats
    /// round to `f32`.
    pub fn quantize(self, value: f64) -> f64 {
        // `+ 0.0` makes -0 plain 0: files and the wire keep no sign on a
        // zero, so a -0 in force would reload as 0 and change `_HASH_CHECK`.
        match self {
            ParamType::Real32 => f64::from(value as f32) + 0.0,
            _ => value.round() + 0.0,
        }
    }
}

/// A parameter id: 1–16 characters of `A-Z`, `0-9`, `_`, starting with a
/// letter (MAVLink ids are 16 bytes with no terminator when full).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParamName(Cow<'static, str>);

/// Why a string is not a valid parameter id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ParamNameError {
    Empty,
    TooLong(usize),
    BadChar(char),
}

impl fmt::Display for ParamNameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamNameError::Empty => write!(f, "empty parameter name"),
            ParamNameError::TooLong(n) => write!(f, "parameter name has {n} characters (max 16)"),
            ParamNameError::BadChar(c) => write!(f, "parameter name has invalid character {c:?}"),
        }
    }
}

impl std::error::Error for ParamNameError {}

impl ParamName {
    pub const MAX_LEN: usize = 16;

    /// Validates `name`.
    pub fn new(name: impl Into<Cow<'static, str>>) -> Result<Self, ParamNameError> {
        let name = name.into();
        if name.is_empty() {
            return Err(ParamNameError::Empty);
        }
        if name.len() > Self::MAX_LEN {
            return Err(ParamNameError::TooLong(name.len()));
        }
        for (i, c) in name.chars().enumerate() {
            let ok = c.is_ascii_uppercase() || c == '_' || (i > 0 && c.is_ascii_digit());
            if !ok {
                return Err(ParamNameError::BadChar(c));
            }
        }
        Ok(ParamName(name))
    }

    /// The id as MAVLink's fixed 16-byte field: NUL padded, no terminator
    /// when the name is exactly 16 characters.
    pub fn to_mavlink_id(&self) -> [u8; 16] {
        let mut id = [0u8; 16];
        id[..self.0.len()].copy_from_slice(self.0.as_bytes());
        id
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for ParamName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// Behaviour flags of a parameter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParamFlags {
    /// The new value is stored at once but used only after a restart.
    pub reboot_required: bool,
    /// Reported, never set from outside.
    pub read_only: bool,
}

/// Everything known about one parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDef {
    pub name: ParamName,
    pub ty: ParamType,
    pub default: f64,
    pub min: f64,
    pub max: f64,
    /// Unit as ArduPilot writes it (`m/s`, `deg`, `Hz`, ``), for GCS metadata.
    pub unit: &'static str,
    pub description: &'static str,
    pub flags: ParamFlags,
}

impl ParamDef {
    /// Checks that the declaration is self-consistent; a failure here is a
    /// programming error found at start-up.
    pub fn check(&self) -> Result<(), String> {
        let (lo, hi) = self.ty.limits();
        if !(self.min.is_finite() && self.max.is_finite() && self.default.is_finite()) {
            return Err(format!("{}: non-finite range or default", self.name));
        }
        if self.min > self.max || self.min < lo || self.max > hi {
            return Err(format!(
                "{}: range {}..{} invalid for {:?}",
                self.name, self.min, self.max, self.ty
            ));
        }
        if self.default < self.min || self.default > self.max {
            return Err(format!(
                "{}: default {} outside {}..{}",
                self.name, self.default, self.min, self.max
            ));
        }
        if self.ty != ParamType::Real32 && self.ty.quantize(self.default) != self.default {
            return Err(format!("{}: default {} is not an integer", self.name, self.default));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_mavlink_rules() {
        assert!(ParamName::new("WP_SPEED").is_ok());
        assert!(ParamName::new("SR0_POSITION").is_ok());
        assert_eq!(ParamName::new(""), Err(ParamNameError::Empty));
        assert_eq!(ParamName::new("ABCDEFGHIJKLMNOPQ"), Err(ParamNameError::TooLong(17)));
        assert_eq!(ParamName::new("wp_speed"), Err(ParamNameError::BadChar('w')));
        assert_eq!(ParamName::new("0ABC"), Err(ParamNameError::BadChar('0')));
    }

    #[test]
    fn full_length_id_has_no_terminator() {
        let id = ParamName::new("ABCDEFGHIJKLMNOP").unwrap().to_mavlink_id();
        assert_eq!(&id, b"ABCDEFGHIJKLMNOP");
        let id = ParamName::new("WP_SPEED").unwrap().to_mavlink_id();
        assert_eq!(&id[..9], b"WP_SPEED\0");
    }

    #[test]
    fn quantize_rounds_to_the_stored_type() {
        assert_eq!(ParamType::Int8.quantize(2.6), 3.0);
        assert_eq!(ParamType::Real32.quantize(0.1), f64::from(0.1f32));
        assert_eq!(ParamType::Real32.quantize(-0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(ParamType::Int8.quantize(-0.4).to_bits(), 0.0f64.to_bits());
    }
}
