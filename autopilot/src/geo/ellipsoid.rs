//! Reference ellipsoids a Gauss–Krüger grid can be computed on.
//!
//! Sources: docs/references.md §Seed 001.

/// An earth ellipsoid, by its defining semi-major axis and inverse flattening.
///
/// Only the shape changes: the latitude/longitude fed in are always the
/// receiver's WGS-84 values (no datum shift). That is what a site grid needs
/// when it was set up with WGS-84 coordinates on a national ellipsoid's
/// projection; for a real Xi'an-80 or Beijing-54 grid the datum offset (tens
/// of metres) is absorbed by the plane transform fitted to common points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Ellipsoid {
    /// WGS-84 (GNSS receivers; CGCS2000 differs by 0.1 mm in b).
    #[default]
    Wgs84,
    /// IAG-75 (IUGG 1975), the ellipsoid of China's Xi'an-80 system (seed 001).
    Iag75,
    /// Krassovsky 1940, the ellipsoid of Beijing-54.
    Krassovsky,
}

impl Ellipsoid {
    pub const ALL: [Ellipsoid; 3] = [Ellipsoid::Wgs84, Ellipsoid::Iag75, Ellipsoid::Krassovsky];

    /// The `GEO_ELLIPSOID` number; unknown numbers are WGS-84.
    pub fn from_param(value: i8) -> Ellipsoid {
        match value {
            1 => Ellipsoid::Iag75,
            2 => Ellipsoid::Krassovsky,
            _ => Ellipsoid::Wgs84,
        }
    }

    /// Semi-major (equatorial) axis.
    pub fn semi_major_m(self) -> f64 {
        match self {
            Ellipsoid::Wgs84 => 6_378_137.0,
            Ellipsoid::Iag75 => 6_378_140.0,
            Ellipsoid::Krassovsky => 6_378_245.0,
        }
    }

    /// 1/f, the defining constant next to `a`.
    pub fn inverse_flattening(self) -> f64 {
        match self {
            Ellipsoid::Wgs84 => 298.257_223_563,
            Ellipsoid::Iag75 => 298.257,
            Ellipsoid::Krassovsky => 298.3,
        }
    }

    pub fn flattening(self) -> f64 {
        1.0 / self.inverse_flattening()
    }

    /// First eccentricity squared, e² = f(2 − f).
    pub fn eccentricity_sq(self) -> f64 {
        let f = self.flattening();
        f * (2.0 - f)
    }

    /// Third flattening n = f / (2 − f), the small parameter of Krüger's series.
    pub fn third_flattening(self) -> f64 {
        let f = self.flattening();
        f / (2.0 - f)
    }

    /// Meridian (M) and prime-vertical (N) radii of curvature at a latitude.
    pub fn radii_of_curvature_m(self, lat_rad: f64) -> (f64, f64) {
        let e2 = self.eccentricity_sq();
        let w2 = 1.0 - e2 * lat_rad.sin().powi(2);
        let w = w2.sqrt();
        (self.semi_major_m() * (1.0 - e2) / (w2 * w), self.semi_major_m() / w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_001_eccentricities_match_iag75() {
        // Seed 001 §II.B quotes e = 0.081 819 221 and e' = 0.082 094 469
        // for IAG-75; e'² = e² / (1 − e²).
        let e2 = Ellipsoid::Iag75.eccentricity_sq();
        assert!((e2.sqrt() - 0.081_819_221).abs() < 1e-9, "{}", e2.sqrt());
        assert!(((e2 / (1.0 - e2)).sqrt() - 0.082_094_469).abs() < 1e-9);
    }

    #[test]
    fn radii_at_the_equator_and_pole() {
        let wgs = Ellipsoid::Wgs84;
        let (m, n) = wgs.radii_of_curvature_m(0.0);
        assert!((n - 6_378_137.0).abs() < 1e-6);
        assert!((m - 6_335_439.327).abs() < 1e-3, "{m}");
        let (m, n) = wgs.radii_of_curvature_m(std::f64::consts::FRAC_PI_2);
        assert!((m - n).abs() < 1e-6, "at the pole both are a²/b");
    }

    #[test]
    fn unknown_param_values_are_wgs84() {
        assert_eq!(Ellipsoid::from_param(1), Ellipsoid::Iag75);
        assert_eq!(Ellipsoid::from_param(2), Ellipsoid::Krassovsky);
        assert_eq!(Ellipsoid::from_param(-3), Ellipsoid::Wgs84);
    }
}
