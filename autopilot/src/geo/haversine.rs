//! Seed 000's spherical "haversine" local frame (§2.2, eq. 1–4, R = 6371 km).
//!
//! With the origin O at (φ₀, λ₀) and a point D at (φ, λ), Δφ = φ − φ₀ and
//! Δλ = λ − λ₀:
//!
//! ```text
//! north = 2R sin(Δφ/2)                  eq. 1: the chord of the meridian arc
//! east  = 2R cos φ sin(Δλ/2)            eq. 3: the chord along D's own parallel
//! ```
//!
//! Eq. 2 uses the origin's latitude instead of D's (the chord along O's
//! parallel). Eq. 3 is the one kept, because on the sphere the exact local
//! east is R cos φ sin Δλ: eq. 3 matches it up to third order, while eq. 2
//! misses the meridians' convergence and is off by ≈ north·east·tan φ₀ / R in
//! east (4.3 m for a point 7 km north and 7 km east at 29° N). Neither models
//! the curvature of the origin's parallel, which puts a point due east at
//! ≈ east²·tan φ₀ / (2R) north of it in a true local frame. Eq. 4 is
//! Ptolemy's theorem on the isosceles trapezoid O-B-D-A (A, D on D's parallel,
//! O, B on O's): √(y² + x₁x₂) is exactly the 3-D chord |OD|, i.e. the
//! haversine formula. The distance from the origin in this frame,
//! √(north² + east²) = √(y² + x₂²), differs from it by ≈ x₂(x₂ − x₁)/(2|OD|),
//! a second-order term (x₂ − x₁ ≈ −east·tan φ₀·Δφ).
//!
//! The frame is on a sphere of radius R, so against the WGS-84 ellipsoid its
//! north axis has a scale error R/M − 1 and its east axis R/N − 1 (M, N the
//! radii of curvature): +0.323 % and −0.190 % at 29.133° N, which dominates
//! everything else beyond a few metres (see the error table in `geo`).
//!
//! The inverse is exact: φ from north, then Δλ from east with D's cos φ.
//! Near a pole (cos φ → 0) longitude is undetermined and the inverse returns
//! what `asin` gives (NaN past the sphere); it never panics.
//!
//! Sources: docs/references.md §Seed 000.

use super::{GeoPoint, Ned, wrap_pi};

/// Seed 000's mean earth radius.
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Local north/east of `p` about `origin`.
pub fn to_local(origin: &GeoPoint, p: &GeoPoint) -> Ned {
    let dlat = (p.lat_deg - origin.lat_deg).to_radians();
    // Wrapped so an origin near ±180° sees its neighbours across the line.
    let dlon = wrap_pi((p.lon_deg - origin.lon_deg).to_radians());
    let two_r = 2.0 * EARTH_RADIUS_M;
    Ned::new(
        two_r * (dlat / 2.0).sin(),
        two_r * p.lat_deg.to_radians().cos() * (dlon / 2.0).sin(),
    )
}

/// The latitude/longitude (degrees, longitude in [−180, 180)) whose
/// [`to_local`] is `local`.
pub fn to_geodetic(origin: &GeoPoint, local: &Ned) -> (f64, f64) {
    let two_r = 2.0 * EARTH_RADIUS_M;
    let lat_deg = origin.lat_deg + (2.0 * (local.north_m / two_r).asin()).to_degrees();
    let dlon = 2.0 * (local.east_m / (two_r * lat_deg.to_radians().cos())).asin();
    let lon_deg = wrap_pi(origin.lon_deg.to_radians() + dlon).to_degrees();
    (lat_deg, lon_deg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_are_chords_of_the_sphere() {
        let o = GeoPoint::new(29.133, 119.64, 0.0);
        let n = to_local(&o, &GeoPoint::new(30.133, 119.64, 0.0));
        let chord = 2.0 * EARTH_RADIUS_M * (0.5f64.to_radians()).sin();
        assert!((n.north_m - chord).abs() < 1e-6 && n.east_m == 0.0);
        let e = to_local(&o, &GeoPoint::new(29.133, 120.64, 0.0));
        assert!((e.east_m - chord * 29.133f64.to_radians().cos()).abs() < 1e-6 && e.north_m == 0.0);
    }

    #[test]
    fn eq4_is_the_haversine_chord() {
        // √(y² + x₁x₂) (seed eq. 4) equals the chord from the haversine
        // formula's central angle.
        let (lat1, lat2) = (29.2f64.to_radians(), 29.133f64.to_radians());
        let dlon = 0.05f64.to_radians();
        let r = EARTH_RADIUS_M;
        let y = 2.0 * r * ((lat1 - lat2) / 2.0).sin();
        let (x1, x2) = (
            2.0 * r * lat2.cos() * (dlon / 2.0).sin(),
            2.0 * r * lat1.cos() * (dlon / 2.0).sin(),
        );
        let hav = ((lat1 - lat2) / 2.0).sin().powi(2) + lat1.cos() * lat2.cos() * (dlon / 2.0).sin().powi(2);
        let chord = 2.0 * r * hav.sqrt();
        assert!(((y * y + x1 * x2).sqrt() - chord).abs() < 1e-8);
    }

    #[test]
    fn inverse_is_exact_across_the_antimeridian() {
        let o = GeoPoint::new(-17.8, 179.9, 0.0);
        for p in [GeoPoint::new(-17.7, -179.95, 0.0), GeoPoint::new(-18.2, 179.5, 0.0)] {
            let local = to_local(&o, &p);
            assert!(local.east_m.abs() < 50_000.0);
            let (lat, lon) = to_geodetic(&o, &local);
            assert!(
                (lat - p.lat_deg).abs() < 1e-12 && (lon - p.lon_deg).abs() < 1e-10,
                "{lat} {lon}"
            );
        }
    }
}
