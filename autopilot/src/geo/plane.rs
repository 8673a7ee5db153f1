//! The 4-parameter plane similarity transform into a site's plant grid
//! (seed 001 §II.C, eq. 6–7).
//!
//! Convention (both grids are north/east pairs, angles clockwise from north
//! like every heading in Furrow):
//!
//! ```text
//! north' = shift_north + scale · (north · cos r − east · sin r)
//! east'  = shift_east  + scale · (north · sin r + east · cos r)
//! ```
//!
//! so the shift is where the source origin lands in the grid, and a heading h
//! in the source is h + r in the grid. Seed 001 writes the same map the other
//! way round: with (x₀, y₀) the grid origin in source coordinates and α the
//! azimuth of the grid's x (north) axis in the source, clockwise,
//! x₂ = m[(x₁ − x₀) cos α + (y₁ − y₀) sin α], y₂ = m[(y₁ − y₀) cos α − (x₁ − x₀) sin α];
//! that is r = −α and shift = −m·R(−α)·(x₀, y₀) ([`PlaneTransform::from_seed`]).
//!
//! Writing a point as the complex number z = north + i·east, the map is
//! z′ = t + c·z with c = scale·e^{ir}: two common points fix c and t, and more
//! than two give the least-squares fit in closed form.
//!
//! Sources: docs/references.md §Seed 001.

use super::Ned;

/// A similarity transform of the plane: rotation, uniform scale, shift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneTransform {
    pub shift_north_m: f64,
    pub shift_east_m: f64,
    /// Clockwise rotation from source to destination axes.
    pub rotation_rad: f64,
    /// Destination metres per source metre.
    pub scale: f64,
}

/// Two source points closer than this are one point: no direction to fit.
const MIN_BASELINE_M: f64 = 1e-6;

impl PlaneTransform {
    pub const IDENTITY: PlaneTransform = PlaneTransform {
        shift_north_m: 0.0,
        shift_east_m: 0.0,
        rotation_rad: 0.0,
        scale: 1.0,
    };

    /// Seed 001 eq. 6–7's parameters: the grid origin in source coordinates,
    /// the azimuth of the grid's north axis in the source (clockwise) and the
    /// scale.
    pub fn from_seed(grid_origin_in_source: Ned, grid_north_azimuth_rad: f64, scale: f64) -> PlaneTransform {
        let rotation_rad = -grid_north_azimuth_rad;
        let (sin, cos) = rotation_rad.sin_cos();
        let (n0, e0) = (grid_origin_in_source.north_m, grid_origin_in_source.east_m);
        PlaneTransform {
            shift_north_m: -scale * (n0 * cos - e0 * sin),
            shift_east_m: -scale * (n0 * sin + e0 * cos),
            rotation_rad,
            scale,
        }
    }

    /// Whether every parameter is finite and the scale is not zero (so the
    /// transform can be inverted).
    pub fn is_valid(&self) -> bool {
        self.shift_north_m.is_finite()
            && self.shift_east_m.is_finite()
            && self.rotation_rad.is_finite()
            && self.scale.is_finite()
            && self.scale != 0.0
    }

    pub fn apply(&self, p: &Ned) -> Ned {
        let (sin, cos) = self.rotation_rad.sin_cos();
        Ned::new(
            self.shift_north_m + self.scale * (p.north_m * cos - p.east_m * sin),
            self.shift_east_m + self.scale * (p.north_m * sin + p.east_m * cos),
        )
    }

    /// The transform undoing this one; `None` unless [`is_valid`](Self::is_valid).
    pub fn invert(&self) -> Option<PlaneTransform> {
        if !self.is_valid() {
            return None;
        }
        // p = R(−r)·(p′ − t)/s: a transform with rotation −r, scale 1/s and
        // shift −R(−r)·t/s.
        let (sin, cos) = (-self.rotation_rad).sin_cos();
        let inv_scale = 1.0 / self.scale;
        let (tn, te) = (self.shift_north_m, self.shift_east_m);
        Some(PlaneTransform {
            shift_north_m: -inv_scale * (tn * cos - te * sin),
            shift_east_m: -inv_scale * (tn * sin + te * cos),
            rotation_rad: -self.rotation_rad,
            scale: inv_scale,
        })
    }

    /// The transform taking `src1` to `dst1` and `src2` to `dst2` (seed 001:
    /// the four parameters from two common points). `None` if the source or
    /// destination points coincide (no direction, or a zero scale) or any
    /// coordinate is not finite.
    pub fn from_two_points((src1, dst1): (Ned, Ned), (src2, dst2): (Ned, Ned)) -> Option<PlaneTransform> {
        Self::fit(&[(src1, dst1), (src2, dst2)])
    }

    /// The least-squares similarity transform through (source, destination)
    /// pairs: exact for two, the best fit for more (surveys usually give
    /// three or four control points). `None` if the source points are all
    /// one point, the fitted scale is zero, or any coordinate is not finite.
    pub fn fit(pairs: &[(Ned, Ned)]) -> Option<PlaneTransform> {
        if pairs.is_empty() {
            return None;
        }
        let count = pairs.len() as f64;
        let mean = |f: fn(&(Ned, Ned)) -> f64| pairs.iter().map(f).sum::<f64>() / count;
        let (sn, se) = (mean(|p| p.0.north_m), mean(|p| p.0.east_m));
        let (dn, de) = (mean(|p| p.1.north_m), mean(|p| p.1.east_m));
        // c = Σ (d − d̄)·conj(s − s̄) / Σ |s − s̄|², about the centroids.
        let (mut re, mut im, mut spread) = (0.0, 0.0, 0.0);
        for (s, d) in pairs {
            let (x, y) = (s.north_m - sn, s.east_m - se);
            let (u, v) = (d.north_m - dn, d.east_m - de);
            re += u * x + v * y;
            im += v * x - u * y;
            spread += x * x + y * y;
        }
        let baseline_m = (spread / count).sqrt();
        if !baseline_m.is_finite() || baseline_m < MIN_BASELINE_M / 2.0 {
            return None;
        }
        let (c_re, c_im) = (re / spread, im / spread);
        let fitted = PlaneTransform {
            shift_north_m: dn - (c_re * sn - c_im * se),
            shift_east_m: de - (c_re * se + c_im * sn),
            rotation_rad: c_im.atan2(c_re),
            scale: c_re.hypot(c_im),
        };
        fitted.is_valid().then_some(fitted)
    }
}

impl Default for PlaneTransform {
    fn default() -> Self {
        PlaneTransform::IDENTITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Ned, b: Ned, tol_m: f64) -> bool {
        a.distance_to(&b) < tol_m
    }

    #[test]
    fn rotation_is_clockwise_like_headings() {
        let quarter = PlaneTransform {
            rotation_rad: std::f64::consts::FRAC_PI_2,
            ..PlaneTransform::IDENTITY
        };
        // North (heading 0) becomes east (heading π/2).
        assert!(close(quarter.apply(&Ned::new(1.0, 0.0)), Ned::new(0.0, 1.0), 1e-12));
        let h = 0.3f64;
        let q = quarter.apply(&Ned::new(h.cos(), h.sin()));
        assert!((Ned::default().bearing_to(&q) - (h + std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
    }

    #[test]
    fn seed_form_matches_eq_6_7() {
        let (x0, y0, alpha, m) = (120.0, -35.0, 0.4f64, 1.000_2);
        let t = PlaneTransform::from_seed(Ned::new(x0, y0), alpha, m);
        for (x1, y1) in [(0.0, 0.0), (150.0, 20.0), (-3.0, 400.0)] {
            let x2 = m * (y1 - y0) * alpha.sin() + m * (x1 - x0) * alpha.cos();
            let y2 = m * (y1 - y0) * alpha.cos() - m * (x1 - x0) * alpha.sin();
            assert!(close(t.apply(&Ned::new(x1, y1)), Ned::new(x2, y2), 1e-9));
        }
        // The grid origin maps to (0, 0), the grid's north axis to north.
        assert!(close(t.apply(&Ned::new(x0, y0)), Ned::default(), 1e-9));
    }

    #[test]
    fn invert_undoes_apply() {
        let t = PlaneTransform {
            shift_north_m: 5021.3,
            shift_east_m: -88.0,
            rotation_rad: -2.9,
            scale: 0.9996,
        };
        let inv = t.invert().unwrap();
        let p = Ned::new(-1234.5, 678.9);
        assert!(close(inv.apply(&t.apply(&p)), p, 1e-9));
        assert!(close(t.apply(&inv.apply(&p)), p, 1e-9));
        assert!(PlaneTransform { scale: 0.0, ..t }.invert().is_none());
        assert!(
            PlaneTransform {
                rotation_rad: f64::NAN,
                ..t
            }
            .invert()
            .is_none()
        );
    }

    #[test]
    fn fit_recovers_a_transform_from_noisy_points() {
        let truth = PlaneTransform {
            shift_north_m: 300.0,
            shift_east_m: 700.0,
            rotation_rad: 0.25,
            scale: 1.0001,
        };
        let noise = [(0.002, -0.001), (-0.001, 0.0), (0.0, 0.002), (-0.001, -0.001)];
        let pairs: Vec<(Ned, Ned)> = [(0.0, 0.0), (500.0, 20.0), (480.0, 610.0), (-30.0, 590.0)]
            .iter()
            .zip(noise)
            .map(|(&(n, e), (dn, de))| {
                let d = truth.apply(&Ned::new(n, e));
                (Ned::new(n, e), Ned::new(d.north_m + dn, d.east_m + de))
            })
            .collect();
        let fitted = PlaneTransform::fit(&pairs).unwrap();
        assert!((fitted.rotation_rad - truth.rotation_rad).abs() < 1e-5);
        assert!((fitted.scale - truth.scale).abs() < 1e-5);
        assert!(close(
            fitted.apply(&Ned::new(250.0, 300.0)),
            truth.apply(&Ned::new(250.0, 300.0)),
            3e-3
        ));
    }

    #[test]
    fn degenerate_fits_are_none() {
        let a = (Ned::new(1.0, 2.0), Ned::new(10.0, 20.0));
        assert!(PlaneTransform::from_two_points(a, a).is_none());
        assert!(PlaneTransform::from_two_points(a, (Ned::new(5.0, 5.0), Ned::new(10.0, 20.0))).is_none());
        assert!(PlaneTransform::from_two_points(a, (Ned::new(f64::NAN, 5.0), Ned::new(1.0, 1.0))).is_none());
        assert!(PlaneTransform::fit(&[]).is_none());
        assert!(PlaneTransform::fit(&[a]).is_none());
    }
}
