//! Gauss–Krüger (transverse Mercator, scale 1 on the central meridian), seed
//! 001 §II.B.
//!
//! Seed 001 gives the classical power series in the longitude difference λ
//! (its eq. 1–2, with the meridian arc S of eq. 3 and N of eq. 4). Corrected
//! (the extraction lost the exponents: "λ 2", "tan 2φ", "cos 3φ" are λ²,
//! tan²φ, cos³φ, and the λ⁶ term's "270η⁴" is 270η²), with t = tan φ:
//!
//! ```text
//! X = S + N t cos²φ λ²/2 + N t cos⁴φ (5 − t² + 9η² + 4η⁴) λ⁴/24
//!       + N t cos⁶φ (61 − 58t² + t⁴ + 270η² − 330t²η²) λ⁶/720
//! Y = N cos φ λ + N cos³φ (1 − t² + η²) λ³/6
//!       + N cos⁵φ (5 − 18t² + t⁴ + 14η² − 58t²η²) λ⁵/120
//! ```
//!
//! That series is the Taylor expansion in λ of the conformal mapping; its
//! truncation error grows as λ⁷–λ⁸ (sub-millimetre at 3°, metres at 10°) and
//! it needs a separate meridian-arc series per ellipsoid (eq. 3 is IAG-75's).
//! Here the same projection is computed with Krüger's series in the third
//! flattening n to n⁶ (Krüger 1912, as given by Karney 2011, J. Geodesy 85),
//! which is accurate to a few nanometres within 3900 km of the central
//! meridian on any of these ellipsoids and comes with a reverse series, so the
//! inverse needs no footpoint iteration beyond a Newton solve for latitude
//! from conformal latitude. The unit tests check it against the corrected
//! seed series (within ±3°) and seed eq. 3's IAG-75 meridian arc; the
//! integration tests check it against PROJ.
//!
//! Sources: docs/references.md §Seed 001.

use super::ellipsoid::Ellipsoid;
use super::wrap_pi;

/// A transverse Mercator projection with scale 1 on its central meridian and
/// no false easting or northing: grid north is metres from the equator along
/// the central meridian, grid east metres from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransverseMercator {
    ellipsoid: Ellipsoid,
    central_meridian_deg: f64,
    /// First eccentricity.
    e: f64,
    /// Rectifying radius A: the meridian's length is 2πA.
    rectifying_radius_m: f64,
    /// Krüger's forward (α) and reverse (β) coefficients, j = 1…6.
    alpha: [f64; 6],
    beta: [f64; 6],
}

/// Width of the zones a national grid divides the earth into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZoneWidth {
    /// 3° zones, central meridians at multiples of 3° (large-scale surveys).
    Three,
    /// 6° zones, central meridians at 3° + multiples of 6° (as UTM's).
    Six,
}

/// The central meridian of the zone holding a longitude, degrees in (−180, 180].
pub fn zone_meridian_deg(lon_deg: f64, width: ZoneWidth) -> f64 {
    let cm = match width {
        ZoneWidth::Three => 3.0 * (lon_deg / 3.0).round(),
        ZoneWidth::Six => 6.0 * (lon_deg / 6.0).floor() + 3.0,
    };
    if cm > 180.0 {
        cm - 360.0
    } else if cm <= -180.0 {
        cm + 360.0
    } else {
        cm
    }
}

impl TransverseMercator {
    pub fn new(ellipsoid: Ellipsoid, central_meridian_deg: f64) -> Self {
        let n = ellipsoid.third_flattening();
        let (n2, n3) = (n * n, n * n * n);
        let (n4, n5, n6) = (n2 * n2, n2 * n3, n3 * n3);
        let alpha = [
            n / 2.0 - 2.0 / 3.0 * n2 + 5.0 / 16.0 * n3 + 41.0 / 180.0 * n4 - 127.0 / 288.0 * n5 + 7891.0 / 37800.0 * n6,
            13.0 / 48.0 * n2 - 3.0 / 5.0 * n3 + 557.0 / 1440.0 * n4 + 281.0 / 630.0 * n5
                - 1_983_433.0 / 1_935_360.0 * n6,
            61.0 / 240.0 * n3 - 103.0 / 140.0 * n4 + 15061.0 / 26880.0 * n5 + 167_603.0 / 181_440.0 * n6,
            49561.0 / 161_280.0 * n4 - 179.0 / 168.0 * n5 + 6_601_661.0 / 7_257_600.0 * n6,
            34729.0 / 80640.0 * n5 - 3_418_889.0 / 1_995_840.0 * n6,
            212_378_941.0 / 319_334_400.0 * n6,
        ];
        let beta = [
            n / 2.0 - 2.0 / 3.0 * n2 + 37.0 / 96.0 * n3 - 1.0 / 360.0 * n4 - 81.0 / 512.0 * n5
                + 96199.0 / 604_800.0 * n6,
            1.0 / 48.0 * n2 + 1.0 / 15.0 * n3 - 437.0 / 1440.0 * n4 + 46.0 / 105.0 * n5
                - 1_118_711.0 / 3_870_720.0 * n6,
            17.0 / 480.0 * n3 - 37.0 / 840.0 * n4 - 209.0 / 4480.0 * n5 + 5569.0 / 90720.0 * n6,
            4397.0 / 161_280.0 * n4 - 11.0 / 504.0 * n5 - 830_251.0 / 7_257_600.0 * n6,
            4583.0 / 161_280.0 * n5 - 108_847.0 / 3_991_680.0 * n6,
            20_648_693.0 / 638_668_800.0 * n6,
        ];
        TransverseMercator {
            ellipsoid,
            central_meridian_deg,
            e: ellipsoid.eccentricity_sq().sqrt(),
            rectifying_radius_m: ellipsoid.semi_major_m() / (1.0 + n) * (1.0 + n2 / 4.0 + n4 / 64.0 + n6 / 256.0),
            alpha,
            beta,
        }
    }

    pub fn ellipsoid(&self) -> Ellipsoid {
        self.ellipsoid
    }

    pub fn central_meridian_deg(&self) -> f64 {
        self.central_meridian_deg
    }

    /// Grid (north, east) of a latitude/longitude. Longitudes wrap, so a
    /// zone at ±180° works; points beyond 90° of longitude from the central
    /// meridian (only ever near a pole for a local frame) continue over the
    /// pole instead of jumping.
    pub fn forward(&self, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        // The difference in degrees first: exact for nearby longitudes.
        let lambda = wrap_pi((lon_deg - self.central_meridian_deg).to_radians());
        let tau_p = conformal_tan(lat_deg.to_radians().tan(), self.e);
        // Gauss–Schreiber: the conformal sphere's transverse Mercator.
        let xi_p = tau_p.atan2(lambda.cos());
        let eta_p = (lambda.sin() / tau_p.hypot(lambda.cos())).asinh();
        let (mut xi, mut eta) = (xi_p, eta_p);
        for (j, a) in self.alpha.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi += a * (k * xi_p).sin() * (k * eta_p).cosh();
            eta += a * (k * xi_p).cos() * (k * eta_p).sinh();
        }
        (self.rectifying_radius_m * xi, self.rectifying_radius_m * eta)
    }

    /// Latitude/longitude (degrees, longitude in [−180, 180)) of a grid
    /// position.
    pub fn inverse(&self, north_m: f64, east_m: f64) -> (f64, f64) {
        let xi = north_m / self.rectifying_radius_m;
        let eta = east_m / self.rectifying_radius_m;
        let (mut xi_p, mut eta_p) = (xi, eta);
        for (j, b) in self.beta.iter().enumerate() {
            let k = 2.0 * (j + 1) as f64;
            xi_p -= b * (k * xi).sin() * (k * eta).cosh();
            eta_p -= b * (k * xi).cos() * (k * eta).sinh();
        }
        let tau_p = xi_p.sin() / eta_p.sinh().hypot(xi_p.cos());
        let lambda = eta_p.sinh().atan2(xi_p.cos());
        let lat_deg = geodetic_tan(tau_p, self.e).atan().to_degrees();
        let lon_deg = self.central_meridian_deg + lambda.to_degrees();
        // Back into [−180, 180) for a zone at the antimeridian.
        let lon_deg = (lon_deg + 180.0).rem_euclid(360.0) - 180.0;
        (lat_deg, lon_deg)
    }
}

/// tan χ of the conformal latitude χ from τ = tan φ (Karney 2011 eq. 7–9).
/// Written with tangents so it stays finite up to the pole (tan 90° is 1.6e16
/// in f64, whose square still fits).
fn conformal_tan(tau: f64, e: f64) -> f64 {
    let sigma = (e * (e * tau / 1f64.hypot(tau)).atanh()).sinh();
    tau * 1f64.hypot(sigma) - sigma * 1f64.hypot(tau)
}

/// τ = tan φ from τ′ = tan χ by Newton's method (Karney 2011 eq. 19–21):
/// converges to machine precision in two or three steps.
fn geodetic_tan(tau_p: f64, e: f64) -> f64 {
    let one_minus_e2 = 1.0 - e * e;
    let mut tau = tau_p / one_minus_e2;
    for _ in 0..6 {
        let tau_p_i = conformal_tan(tau, e);
        let step = (tau_p - tau_p_i) * (1.0 + one_minus_e2 * tau * tau)
            / (one_minus_e2 * 1f64.hypot(tau) * 1f64.hypot(tau_p_i));
        tau += step;
        if step.is_nan() || step.abs() <= 1e-15 * tau.abs().max(1.0) {
            break;
        }
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 001 eq. 1–2 (corrected, see the module docs) with the meridian
    /// arc taken from Krüger's series at λ = 0: an independent cross-check of
    /// the n-series within a zone.
    fn seed_series(tm: &TransverseMercator, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        let phi = lat_deg.to_radians();
        let l = wrap_pi((lon_deg - tm.central_meridian_deg).to_radians());
        let e2 = tm.ellipsoid.eccentricity_sq();
        let eta2 = e2 / (1.0 - e2) * phi.cos().powi(2);
        let t = phi.tan();
        let (t2, t4) = (t * t, t.powi(4));
        let n = tm.ellipsoid.radii_of_curvature_m(phi).1;
        let c = phi.cos();
        let s = tm.forward(lat_deg, tm.central_meridian_deg()).0;
        let x = s
            + n * t * c.powi(2) * l.powi(2) / 2.0
            + n * t * c.powi(4) * (5.0 - t2 + 9.0 * eta2 + 4.0 * eta2 * eta2) * l.powi(4) / 24.0
            + n * t * c.powi(6) * (61.0 - 58.0 * t2 + t4 + 270.0 * eta2 - 330.0 * t2 * eta2) * l.powi(6) / 720.0;
        let y = n * c * l
            + n * c.powi(3) * (1.0 - t2 + eta2) * l.powi(3) / 6.0
            + n * c.powi(5) * (5.0 - 18.0 * t2 + t4 + 14.0 * eta2 - 58.0 * t2 * eta2) * l.powi(5) / 120.0;
        (x, y)
    }

    #[test]
    fn agrees_with_the_corrected_seed_series_within_a_3_degree_half_zone() {
        for ellipsoid in Ellipsoid::ALL {
            let tm = TransverseMercator::new(ellipsoid, 117.0);
            for lat in [-70.0, -30.0, 0.0, 15.0, 29.133, 45.0, 60.0, 80.0] {
                for dlon in [-3.0, -1.0, 0.5, 2.0, 3.0] {
                    let (x, y) = tm.forward(lat, 117.0 + dlon);
                    let (xs, ys) = seed_series(&tm, lat, 117.0 + dlon);
                    assert!(
                        (x - xs).abs() < 1e-3 && (y - ys).abs() < 1e-3,
                        "{lat} {dlon}: {} {}",
                        x - xs,
                        y - ys
                    );
                }
            }
        }
    }

    #[test]
    fn seed_eq3_is_the_iag75_meridian_arc() {
        // Seed 001 eq. 3, φ in degrees for the linear term.
        let tm = TransverseMercator::new(Ellipsoid::Iag75, 0.0);
        for lat in [5.0, 29.133, 45.0, 70.0, 89.0] {
            let p = f64::to_radians(lat);
            let s = 111_133.004_6 * lat - 16_038.528 * (2.0 * p).sin() + 16.833 * (4.0 * p).sin()
                - 0.022 * (6.0 * p).sin()
                + 0.000_03 * (8.0 * p).sin();
            // The seed's coefficients are rounded to 0.1 mm per degree.
            assert!(
                (tm.forward(lat, 0.0).0 - s).abs() < 0.02,
                "{lat}: {}",
                tm.forward(lat, 0.0).0 - s
            );
        }
    }

    #[test]
    fn inverse_undoes_forward_to_nanometres_across_a_zone() {
        for ellipsoid in Ellipsoid::ALL {
            let tm = TransverseMercator::new(ellipsoid, -177.0);
            for lat in [-89.9, -45.0, 0.0, 0.001, 29.133, 60.0, 89.99] {
                for dlon in [-3.5, -0.1, 0.0, 2.5, 4.0] {
                    let (x, y) = tm.forward(lat, -177.0 + dlon);
                    let (lat2, lon2) = tm.inverse(x, y);
                    let (x2, y2) = tm.forward(lat2, lon2);
                    assert!((x2 - x).abs() < 1e-8 && (y2 - y).abs() < 1e-8, "{lat} {dlon}");
                    assert!(
                        (lat2 - lat).abs() < 1e-12 && (wrap_pi((lon2 - (-177.0 + dlon)).to_radians())).abs() < 1e-11
                    );
                }
            }
        }
    }

    #[test]
    fn zone_meridians() {
        assert_eq!(zone_meridian_deg(119.64, ZoneWidth::Three), 120.0);
        assert_eq!(zone_meridian_deg(119.64, ZoneWidth::Six), 117.0);
        assert_eq!(zone_meridian_deg(-1.0, ZoneWidth::Six), -3.0);
        assert_eq!(zone_meridian_deg(179.9, ZoneWidth::Three), 180.0);
        assert_eq!(zone_meridian_deg(179.9, ZoneWidth::Six), 177.0);
        assert_eq!(zone_meridian_deg(-179.95, ZoneWidth::Three), 180.0);
    }

    #[test]
    fn poles_and_nan_do_not_panic() {
        let tm = TransverseMercator::new(Ellipsoid::Wgs84, 0.0);
        let (x, y) = tm.forward(90.0, 45.0);
        assert!((x - tm.rectifying_radius_m * std::f64::consts::FRAC_PI_2).abs() < 1e-6 && y.abs() < 1e-6);
        let (lat, _) = tm.inverse(x, y);
        assert!((lat - 90.0).abs() < 1e-9);
        let (x, y) = tm.forward(f64::NAN, 0.0);
        assert!(x.is_nan() && y.is_nan());
        let (lat, lon) = tm.inverse(f64::NAN, f64::INFINITY);
        assert!(lat.is_nan() && lon.is_nan());
    }
}
