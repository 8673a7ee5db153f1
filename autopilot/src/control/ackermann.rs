//! Vehicle kinematics of seed 002 §3 (docs/architecture.md §Kinematics and the magnetic guide): from the tracker's centre
//! (bicycle) steering angle to each front wheel's angle under pure rolling
//! (eq. 6–9), the rear electronic differential (eq. 10–13), and the
//! differential-drive mapping of the same demand.
//!
//! Conventions: body x forward, y right; angles positive = right; the
//! reference point is the rear axle centre. The centre angle δ is the bicycle
//! model's: the rear axle centre moves on a circle of signed curvature
//! κ = tan δ / L (positive = turning right), about the instantaneous centre
//! (ICR) at body (0, 1/κ).
//!
//! The seed's equations are written for one turn direction at a time, with
//! magnitudes and with the inner wheel's angle as the input. Here both
//! directions are one signed formula. A front wheel whose kingpin is at body
//! (L, y_w) must roll perpendicular to the line from the ICR, so
//!
//! ```text
//! tan φ = L / (1/κ − y_w) = L·tan δ / (L − y_w·tan δ)
//! ```
//!
//! and eliminating δ between the two front wheels gives
//! 1/tan φ_R − 1/tan φ_L = −(W − e_L − e_R)/L: seed eq. 8 (left turn) and
//! eq. 9 (right turn) once their magnitudes are given signs. Each rear wheel,
//! at y = ∓W/2, is at radius 1/κ ± W/2 from the ICR, so at rear axle speed v
//! the wheels turn at v·(1 ± κW/2) and their ratio is the radius ratio of
//! eq. 12–13.
//!
//! Kingpin offsets: seed eq. 6–7 measure the front wheels' pure-rolling
//! geometry at points e_L, e_R inboard of the rear wheels' lines (the
//! kingpin axes; the front wheels' contact points sit that far outboard of
//! them). With e = 0 the front and rear tracks are equal.
//!
//! Sources: docs/references.md §Seed 002.

use std::f64::consts::FRAC_PI_2;

/// The steering and drive geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AckermannGeometry {
    /// L: front axle to rear axle.
    pub wheelbase_m: f64,
    /// W: between the rear wheels' centre planes.
    pub track_m: f64,
    /// e_L: how far the left kingpin axis is inboard of the left wheel line.
    pub kingpin_offset_left_m: f64,
    /// e_R: the same on the right.
    pub kingpin_offset_right_m: f64,
}

impl AckermannGeometry {
    /// Kingpins on the wheel lines (e_L = e_R = 0).
    pub fn new(wheelbase_m: f64, track_m: f64) -> Self {
        Self {
            wheelbase_m,
            track_m,
            kingpin_offset_left_m: 0.0,
            kingpin_offset_right_m: 0.0,
        }
    }

    /// Body y of the left and right kingpins.
    fn kingpin_y_m(&self) -> (f64, f64) {
        (
            -self.track_m / 2.0 + self.kingpin_offset_left_m,
            self.track_m / 2.0 - self.kingpin_offset_right_m,
        )
    }
}

/// Each front wheel's steering angle, positive = right.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontWheelAngles {
    pub left_rad: f64,
    pub right_rad: f64,
}

impl FrontWheelAngles {
    /// (inner, outer): the inner wheel is on the side the vehicle turns to;
    /// going straight, (left, right).
    pub fn inner_outer_rad(&self) -> (f64, f64) {
        if self.left_rad < 0.0 || self.right_rad < 0.0 {
            (self.left_rad, self.right_rad)
        } else {
            (self.right_rad, self.left_rad)
        }
    }
}

/// Left and right wheel speeds, signed (negative = backwards).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelSpeeds {
    pub left_mps: f64,
    pub right_mps: f64,
}

impl WheelSpeeds {
    /// Scaled down together, if need be, so neither exceeds `max_mps`: the
    /// curvature (their ratio) is kept and the speed gives way.
    pub fn limited(&self, max_mps: f64) -> WheelSpeeds {
        let max_mps = max_mps.abs();
        let peak = self.left_mps.abs().max(self.right_mps.abs());
        if peak > max_mps && peak > 0.0 {
            let k = max_mps / peak;
            WheelSpeeds {
                left_mps: self.left_mps * k,
                right_mps: self.right_mps * k,
            }
        } else {
            *self
        }
    }
}

/// The centre angle as used here: within ±90° (beyond, the formulas would
/// describe the vehicle driving the other way).
fn clamp_steer(steer_rad: f64) -> f64 {
    steer_rad.clamp(-FRAC_PI_2, FRAC_PI_2)
}

/// Signed curvature of the rear axle centre's path, κ = tan δ / L (1/m,
/// positive = right). Infinite at δ = ±90°, where the vehicle pivots about
/// the rear axle centre.
pub fn curvature_from_steer(wheelbase_m: f64, steer_rad: f64) -> f64 {
    clamp_steer(steer_rad).tan() / wheelbase_m
}

/// The centre angle for a curvature, δ = atan(L·κ).
pub fn steer_from_curvature(wheelbase_m: f64, curvature_1pm: f64) -> f64 {
    (wheelbase_m * curvature_1pm).atan()
}

/// Front wheel angles for the centre angle `steer_rad` (seed eq. 6–9 in
/// signed form). δ = 0 gives zeros; δ is clamped to ±90°, where the ICR is
/// the rear axle centre and each wheel is perpendicular to its line to it
/// (more than 90° for the inner wheel). Written with sin/cos, not tan, so it
/// holds all the way there.
pub fn front_wheel_angles(geometry: &AckermannGeometry, steer_rad: f64) -> FrontWheelAngles {
    let (sin, cos) = clamp_steer(steer_rad).sin_cos();
    let l = geometry.wheelbase_m;
    // tan φ = L·tan δ / (L − y_w·tan δ), times cos δ above and below.
    let wheel = |y_w: f64| (l * sin).atan2(l * cos - y_w * sin);
    let (left_y, right_y) = geometry.kingpin_y_m();
    FrontWheelAngles {
        left_rad: wheel(left_y),
        right_rad: wheel(right_y),
    }
}

/// Rear wheel speeds that move the rear axle centre at `speed_mps` with the
/// centre angle `steer_rad` (the electronic differential, seed eq. 10–13):
/// v·(1 ± κW/2), the outer wheel faster. Unbounded as δ → ±90°, where the
/// rear axle centre cannot move while the vehicle turns.
pub fn rear_wheel_speeds(geometry: &AckermannGeometry, steer_rad: f64, speed_mps: f64) -> WheelSpeeds {
    let curvature_1pm = curvature_from_steer(geometry.wheelbase_m, steer_rad);
    differential_wheel_speeds(speed_mps, curvature_1pm, geometry.track_m)
}

/// Right over left rear wheel speed (seed eq. 12–13: θ_BR/θ_BL = R_R/R_L),
/// = (L − (W/2)·tan δ) / (L + (W/2)·tan δ); 1 going straight, below 1
/// turning right. Negative once the ICR is inside the track (the inner
/// wheel turns backwards), infinite when it is under the left wheel.
pub fn rear_speed_ratio(geometry: &AckermannGeometry, steer_rad: f64) -> f64 {
    let (sin, cos) = clamp_steer(steer_rad).sin_cos();
    let l = geometry.wheelbase_m;
    let half_track_m = geometry.track_m / 2.0;
    (l * cos - half_track_m * sin) / (l * cos + half_track_m * sin)
}

/// Differential drive (and the rear wheels above): the wheel speeds that
/// move the axle centre at `speed_mps` along a path of signed curvature
/// `curvature_1pm` (positive = right; tan δ / L for a tracker's δ). The yaw
/// rate is v·κ, so each wheel, W/2 from the centre, gains or loses v·κ·W/2.
pub fn differential_wheel_speeds(speed_mps: f64, curvature_1pm: f64, track_m: f64) -> WheelSpeeds {
    let yaw_rate_rad_s = speed_mps * curvature_1pm;
    WheelSpeeds {
        left_mps: speed_mps + yaw_rate_rad_s * track_m / 2.0,
        right_mps: speed_mps - yaw_rate_rad_s * track_m / 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_ahead() {
        let g = AckermannGeometry::new(2.9, 1.6);
        let a = front_wheel_angles(&g, 0.0);
        assert_eq!((a.left_rad, a.right_rad), (0.0, 0.0));
        let v = rear_wheel_speeds(&g, 0.0, 1.5);
        assert_eq!((v.left_mps, v.right_mps), (1.5, 1.5));
        assert_eq!(rear_speed_ratio(&g, 0.0), 1.0);
    }

    #[test]
    fn right_turn_inner_wheel_is_the_right_one() {
        let g = AckermannGeometry::new(2.9, 1.6);
        let a = front_wheel_angles(&g, 0.3);
        assert!(a.right_rad > 0.3 && a.left_rad < 0.3 && a.left_rad > 0.0);
        assert_eq!(a.inner_outer_rad(), (a.right_rad, a.left_rad));
        let v = rear_wheel_speeds(&g, 0.3, 1.0);
        assert!(v.right_mps < 1.0 && v.left_mps > 1.0);
        assert!(((v.left_mps + v.right_mps) / 2.0 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn limited_keeps_the_ratio() {
        let w = WheelSpeeds {
            left_mps: 3.0,
            right_mps: -1.0,
        }
        .limited(1.5);
        assert_eq!((w.left_mps, w.right_mps), (1.5, -0.5));
    }
}
