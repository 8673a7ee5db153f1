//! A position on the earth.

/// A WGS-84 position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoPoint {
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Altitude above mean sea level. (The simulated receiver reports a geoid
    /// separation of 0, so in SITL it is also the height above the ellipsoid.)
    pub alt_m: f64,
}

impl GeoPoint {
    pub fn new(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Self {
        GeoPoint {
            lat_deg,
            lon_deg,
            alt_m,
        }
    }

    /// Whether this is a position on the earth (finite, in range).
    pub fn is_valid(&self) -> bool {
        self.lat_deg.is_finite()
            && self.lon_deg.is_finite()
            && self.alt_m.is_finite()
            && self.lat_deg.abs() <= 90.0
            && self.lon_deg.abs() <= 180.0
    }

    /// MAVLink's integer degrees × 1e7.
    pub fn lat_e7(&self) -> i32 {
        (self.lat_deg * 1e7).round() as i32
    }

    pub fn lon_e7(&self) -> i32 {
        (self.lon_deg * 1e7).round() as i32
    }

    pub fn from_e7(lat_e7: i32, lon_e7: i32, alt_m: f64) -> Self {
        GeoPoint {
            lat_deg: f64::from(lat_e7) * 1e-7,
            lon_deg: f64::from(lon_e7) * 1e-7,
            alt_m,
        }
    }
}
