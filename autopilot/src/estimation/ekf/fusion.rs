//! Measurement updates: gating, fusion, resets after persistent rejection,
//! and initialisation from held samples.

use nalgebra::{SMatrix, SVector};

use super::model::{
    Hessian, antenna_position, antenna_position_hessians, antenna_velocity, antenna_velocity_hessians, second_order,
};
use super::state::*;
use super::{Ekf, Fusion, InputError, STATE_LEN, Skip, StateCovariance, StateVector, all_finite, sigma_ok, wrap_pi};

/// The white part of a GNSS σ never drops below this fraction of it, even
/// when the configured walk σ is as large as the σ the receiver reports.
const MIN_WHITE_FRACTION: f64 = 0.5;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Position = 0,
    Velocity = 1,
    Heading = 2,
    Odometry = 3,
    YawRate = 4,
}

/// A sample held until the filter can start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Held<T> {
    at_s: f64,
    value: T,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HeldFix {
    antenna_north_m: f64,
    antenna_east_m: f64,
    sigma_north_m: f64,
    sigma_east_m: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HeldHeading {
    yaw_rad: f64,
    sigma_rad: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HeldVelocity {
    speed_mps: f64,
    course_rad: f64,
}

enum Gate {
    Accepted(f64),
    Rejected(f64),
    Numerical,
}

impl Ekf {
    /// Gates and fuses one measurement with Joseph-form covariance update; the
    /// state and covariance change only if the result is finite.
    fn fuse<const M: usize>(
        &mut self,
        kind: Kind,
        innovation: SVector<f64, M>,
        h: SMatrix<f64, M, STATE_LEN>,
        r: SMatrix<f64, M, M>,
    ) -> Gate {
        let gate = if M == 1 {
            self.gate_chi2_1dof[kind as usize]
        } else {
            self.gate_chi2_2dof[kind as usize]
        };
        let pht = self.p * h.transpose();
        let s = h * pht + r;
        let s = (s + s.transpose()) * 0.5;
        let Some(s_inv) = s.try_inverse() else {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        };
        let nis = (innovation.transpose() * s_inv * innovation)[(0, 0)];
        let test_ratio = nis / gate;
        if !test_ratio.is_finite() || test_ratio < 0.0 {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        }
        let s_diag = s.diagonal();
        let record = &mut self.innovations[kind as usize];
        record.record(innovation.as_slice(), s_diag.as_slice(), test_ratio);
        if test_ratio > 1.0 {
            record.reject(self.time_s);
            return Gate::Rejected(test_ratio);
        }
        let k = pht * s_inv;
        let mut x = self.x + k * innovation;
        x[YAW] = wrap_pi(x[YAW]);
        // Joseph form (I − KH)·P·(I − KH)ᵀ + K·R·Kᵀ, expanded with B = P·Hᵀ
        // and S = H·P·Hᵀ + R into P − K·Bᵀ − B·Kᵀ + K·S·Kᵀ: the same
        // polynomial in K (so a rounding error in K still only enters to
        // second order), at rank-M cost instead of two 8×8 products.
        let kbt = k * pht.transpose();
        let ksk = k * s * k.transpose();
        let mut p = self.p;
        for i in 0..STATE_LEN {
            for j in i..STATE_LEN {
                // Built symmetric: both triangles get the same value.
                let v = self.p[(i, j)] - kbt[(i, j)] - kbt[(j, i)] + 0.5 * (ksk[(i, j)] + ksk[(j, i)]);
                p[(i, j)] = v;
                p[(j, i)] = v;
            }
        }
        let diagonal_ok = p.diagonal().iter().all(|v| *v >= 0.0);
        if !(all_finite(x.as_slice()) && all_finite(p.as_slice()) && diagonal_ok) {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        }
        self.x = x;
        self.p = p;
        self.innovations[kind as usize].accept(self.time_s);
        Gate::Accepted(test_ratio)
    }

    /// White part of a GNSS position σ: the receiver's σ (GST) covers its
    /// whole error, of which the filter models `gnss_walk_sigma_m` as a state.
    fn white_variance(&self, sigma_m: f64) -> f64 {
        let total = sigma_m * sigma_m;
        (total - self.config.gnss_walk_sigma_m.powi(2)).max(MIN_WHITE_FRACTION.powi(2) * total)
    }

    /// GNSS antenna position (local NED) with its receiver-reported 1-σ per
    /// axis (from GST, else from the fix quality). Gated; persistent
    /// rejection resets the position to the fix.
    pub fn update_gnss_position(
        &mut self,
        antenna_north_m: f64,
        antenna_east_m: f64,
        sigma_north_m: f64,
        sigma_east_m: f64,
    ) -> Fusion {
        if !all_finite(&[antenna_north_m, antenna_east_m, sigma_north_m, sigma_east_m]) {
            return self.refused(InputError::NotFinite);
        }
        if !(sigma_ok(sigma_north_m) && sigma_ok(sigma_east_m)) {
            return self.refused(InputError::BadSigma);
        }
        let fix = HeldFix {
            antenna_north_m,
            antenna_east_m,
            sigma_north_m,
            sigma_east_m,
        };
        if !self.initialised {
            self.held_fix = Some(Held {
                at_s: self.time_s,
                value: fix,
            });
            return self.try_start();
        }
        let (predicted, h) = antenna_position(&self.x, self.config.antenna_body_m);
        let hessians = antenna_position_hessians(&self.x, self.config.antenna_body_m);
        let (mean2, cov2) = second_order(&self.p, &hessians);
        let innovation = SVector::<f64, 2>::new(antenna_north_m, antenna_east_m) - predicted - mean2;
        let r = SMatrix::<f64, 2, 2>::from_diagonal(&SVector::<f64, 2>::new(
            self.white_variance(sigma_north_m),
            self.white_variance(sigma_east_m),
        )) + cov2;
        match self.fuse(Kind::Position, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Position as usize];
                if record.rejecting_for_s(self.time_s) >= self.config.position_reset_after_s {
                    let shift = self.reset_position_to_gnss_fix(&fix);
                    let record = &mut self.innovations[Kind::Position as usize];
                    record.resets = record.resets.saturating_add(1);
                    record.accept(self.time_s);
                    Fusion::Reset { test_ratio, shift }
                } else {
                    Fusion::Rejected { test_ratio }
                }
            }
        }
    }

    /// Resets the position to a GNSS antenna fix (a relocation, e.g. after a
    /// fix type change), keeping yaw and the rest. Returns the shift (m).
    pub fn reset_position_to_gnss(
        &mut self,
        antenna_north_m: f64,
        antenna_east_m: f64,
        sigma_north_m: f64,
        sigma_east_m: f64,
    ) -> Result<[f64; 2], InputError> {
        if !all_finite(&[antenna_north_m, antenna_east_m, sigma_north_m, sigma_east_m]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !(sigma_ok(sigma_north_m) && sigma_ok(sigma_east_m)) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        Ok(self.reset_position_to_gnss_fix(&HeldFix {
            antenna_north_m,
            antenna_east_m,
            sigma_north_m,
            sigma_east_m,
        }))
    }

    /// Sets the reference point from an antenna fix through the lever arm and
    /// rebuilds the position and bias rows of P: with the error
    /// e_p = −J·e_yaw − b − w (J = d(R(yaw)·r)/d yaw, b the slow GNSS error,
    /// w the white one) the new rows follow exactly from the yaw row.
    fn reset_position_to_gnss_fix(&mut self, fix: &HeldFix) -> [f64; 2] {
        let (ax, ay) = self.config.antenna_body_m;
        let (s, c) = self.x[YAW].sin_cos();
        let old = [self.x[NORTH], self.x[EAST]];
        self.x[NORTH] = fix.antenna_north_m - (c * ax - s * ay);
        self.x[EAST] = fix.antenna_east_m - (s * ax + c * ay);
        self.x[BIAS_NORTH] = 0.0;
        self.x[BIAS_EAST] = 0.0;
        let j = [-s * ax - c * ay, c * ax - s * ay];
        let bias_var = self.config.gnss_walk_sigma_m.powi(2);
        let white = [
            self.white_variance(fix.sigma_north_m),
            self.white_variance(fix.sigma_east_m),
        ];
        let yaw_row = self.p.row(YAW).into_owned();
        let yaw_var = self.p[(YAW, YAW)];
        let (pos, bias) = ([NORTH, EAST], [BIAS_NORTH, BIAS_EAST]);
        for i in [NORTH, EAST, BIAS_NORTH, BIAS_EAST] {
            for k in 0..STATE_LEN {
                self.p[(i, k)] = 0.0;
                self.p[(k, i)] = 0.0;
            }
        }
        for (a, &row) in pos.iter().enumerate() {
            for col in [YAW, SPEED, CURVATURE, PIVOT_RATE] {
                self.p[(row, col)] = -j[a] * yaw_row[col];
                self.p[(col, row)] = self.p[(row, col)];
            }
            for (b, &col) in pos.iter().enumerate() {
                self.p[(row, col)] = j[a] * j[b] * yaw_var;
            }
            self.p[(row, row)] += white[a] + bias_var;
            self.p[(row, bias[a])] = -bias_var;
            self.p[(bias[a], row)] = -bias_var;
            self.p[(bias[a], bias[a])] = bias_var;
        }
        let shift = [self.x[NORTH] - old[0], self.x[EAST] - old[1]];
        self.last_position_reset_m = shift;
        shift
    }

    /// GNSS speed over ground (≥ 0) and course over ground (rad, from north,
    /// clockwise; `None` when the receiver leaves it empty) of the antenna,
    /// with the velocity σ per axis (the antenna velocity includes ω × r).
    ///
    /// Below `min_course_speed_mps` the course is noise and is not used: the
    /// sample then says only that the antenna moves no faster than the
    /// reported speed, fused as a zero velocity with variance σ² + speed²/2
    /// per axis (the true velocity has that magnitude in an unknown
    /// direction). That is what lets a stopped vehicle's fixes average down.
    pub fn update_gnss_velocity(&mut self, speed_mps: f64, course_rad: Option<f64>, sigma_mps: f64) -> Fusion {
        if !all_finite(&[speed_mps, course_rad.unwrap_or(0.0), sigma_mps]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma_mps) {
            return self.refused(InputError::BadSigma);
        }
        if speed_mps < 0.0 {
            return self.refused(InputError::OutOfRange);
        }
        let low_speed = speed_mps < self.config.min_course_speed_mps;
        if !self.initialised {
            if let Some(course_rad) = course_rad.filter(|_| !low_speed) {
                self.held_velocity = Some(Held {
                    at_s: self.time_s,
                    value: HeldVelocity { speed_mps, course_rad },
                });
            }
            return Fusion::Skipped(Skip::NotInitialised);
        }
        let (measured, variance) = match course_rad {
            _ if low_speed => (
                SVector::<f64, 2>::zeros(),
                sigma_mps * sigma_mps + 0.5 * speed_mps * speed_mps,
            ),
            Some(course) => {
                let (s, c) = course.sin_cos();
                (
                    SVector::<f64, 2>::new(speed_mps * c, speed_mps * s),
                    sigma_mps * sigma_mps,
                )
            }
            None => return Fusion::Skipped(Skip::NoCourse),
        };
        let (predicted, h) = antenna_velocity(&self.x, self.config.antenna_body_m);
        let hessians = antenna_velocity_hessians(&self.x, self.config.antenna_body_m);
        let (mean2, cov2) = second_order(&self.p, &hessians);
        let innovation = measured - predicted - mean2;
        let r = SMatrix::<f64, 2, 2>::identity() * variance + cov2;
        match self.fuse(Kind::Velocity, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Velocity as usize];
                if record.rejecting_for_s(self.time_s) < self.config.velocity_reset_after_s {
                    return Fusion::Rejected { test_ratio };
                }
                // The speed that makes the antenna's along-body velocity
                // match: u = v − ω·a_y, with ω kept.
                let (sy, cy) = self.x[YAW].sin_cos();
                let along = measured[0] * cy + measured[1] * sy;
                let w = self.x[SPEED] * self.x[CURVATURE] + self.x[PIVOT_RATE];
                let speed = along + w * self.config.antenna_body_m.1;
                let old = self.x[SPEED];
                self.reset_speed_unchecked(speed, variance.sqrt());
                let record = &mut self.innovations[Kind::Velocity as usize];
                record.resets = record.resets.saturating_add(1);
                record.accept(self.time_s);
                Fusion::Reset {
                    test_ratio,
                    shift: [speed - old, 0.0],
                }
            }
        }
    }

    /// True heading of the body x axis (dual-antenna, or magnetometer already
    /// corrected for declination), rad from north clockwise, any wrap, with
    /// its σ. Gated on the wrapped innovation; persistent rejection resets.
    pub fn update_heading(&mut self, yaw_rad: f64, sigma_rad: f64) -> Fusion {
        if !all_finite(&[yaw_rad, sigma_rad]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma_rad) {
            return self.refused(InputError::BadSigma);
        }
        let yaw_rad = wrap_pi(yaw_rad);
        if !self.initialised {
            self.held_heading = Some(Held {
                at_s: self.time_s,
                value: HeldHeading { yaw_rad, sigma_rad },
            });
            return self.try_start();
        }
        let mut h = SMatrix::<f64, 1, STATE_LEN>::zeros();
        h[(0, YAW)] = 1.0;
        let innovation = SVector::<f64, 1>::new(wrap_pi(yaw_rad - self.x[YAW]));
        let r = SMatrix::<f64, 1, 1>::new(sigma_rad * sigma_rad);
        match self.fuse(Kind::Heading, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Heading as usize];
                if record.rejecting_for_s(self.time_s) >= self.config.heading_reset_after_s {
                    let old = self.x[YAW];
                    self.reset_heading_unchecked(yaw_rad, sigma_rad);
                    let record = &mut self.innovations[Kind::Heading as usize];
                    record.resets = record.resets.saturating_add(1);
                    record.accept(self.time_s);
                    Fusion::Reset {
                        test_ratio,
                        shift: [wrap_pi(yaw_rad - old), 0.0],
                    }
                } else {
                    Fusion::Rejected { test_ratio }
                }
            }
        }
    }

    /// Sets the yaw with its σ, forgetting its correlations; the vehicle turns
    /// about the GNSS antenna (see the automatic reset in `update_heading`).
    pub fn reset_heading(&mut self, yaw_rad: f64, sigma_rad: f64) -> Result<(), InputError> {
        if !all_finite(&[yaw_rad, sigma_rad]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !sigma_ok(sigma_rad) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.reset_heading_unchecked(yaw_rad, sigma_rad);
        Ok(())
    }

    /// Rotates the vehicle about the GNSS antenna, the point the fixes
    /// measure: rotating about the reference point would move the predicted
    /// antenna by lever arm × angle and make the next fixes look like a jump.
    fn reset_heading_unchecked(&mut self, yaw_rad: f64, sigma_rad: f64) {
        let (ax, ay) = self.config.antenna_body_m;
        let lever_ned = |yaw: f64| {
            let (s, c) = yaw.sin_cos();
            [c * ax - s * ay, s * ax + c * ay]
        };
        let (old, new) = (lever_ned(self.x[YAW]), lever_ned(yaw_rad));
        self.x[NORTH] += old[0] - new[0];
        self.x[EAST] += old[1] - new[1];
        self.x[YAW] = wrap_pi(yaw_rad);
        for k in 0..STATE_LEN {
            self.p[(YAW, k)] = 0.0;
            self.p[(k, YAW)] = 0.0;
        }
        self.p[(YAW, YAW)] = sigma_rad * sigma_rad;
        // The reference point now hangs off the antenna through the new yaw:
        // its error gains −J·e_yaw (J = d(R·r)/d yaw), independent of the rest.
        let (s, c) = self.x[YAW].sin_cos();
        let j = [-s * ax - c * ay, c * ax - s * ay];
        let var = sigma_rad * sigma_rad;
        for (a, &row) in [NORTH, EAST].iter().enumerate() {
            self.p[(row, YAW)] = -j[a] * var;
            self.p[(YAW, row)] = -j[a] * var;
            for (b, &col) in [NORTH, EAST].iter().enumerate() {
                self.p[(row, col)] += j[a] * j[b] * var;
            }
        }
    }

    /// Sets the signed speed with its σ, forgetting its correlations.
    pub fn reset_speed(&mut self, speed_mps: f64, sigma_mps: f64) -> Result<(), InputError> {
        if !all_finite(&[speed_mps, sigma_mps]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !sigma_ok(sigma_mps) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.reset_speed_unchecked(speed_mps, sigma_mps);
        Ok(())
    }

    fn reset_speed_unchecked(&mut self, speed_mps: f64, sigma_mps: f64) {
        self.x[SPEED] = speed_mps;
        for k in 0..STATE_LEN {
            self.p[(SPEED, k)] = 0.0;
            self.p[(k, SPEED)] = 0.0;
        }
        self.p[(SPEED, SPEED)] = sigma_mps * sigma_mps;
    }

    /// Signed forward speed of the reference point from wheel odometry.
    pub fn update_odometry_speed(&mut self, speed_mps: f64, sigma_mps: f64) -> Fusion {
        self.update_scalar(Kind::Odometry, speed_mps, sigma_mps)
    }

    /// Yaw rate (gyro z, clockwise positive, bias already removed).
    pub fn update_yaw_rate(&mut self, rate_rad_s: f64, sigma_rad_s: f64) -> Fusion {
        self.update_scalar(Kind::YawRate, rate_rad_s, sigma_rad_s)
    }

    fn update_scalar(&mut self, kind: Kind, value: f64, sigma: f64) -> Fusion {
        if !all_finite(&[value, sigma]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma) {
            return self.refused(InputError::BadSigma);
        }
        if !self.initialised {
            return Fusion::Skipped(Skip::NotInitialised);
        }
        let mut h = SMatrix::<f64, 1, STATE_LEN>::zeros();
        let predicted = match kind {
            Kind::YawRate => {
                h[(0, SPEED)] = self.x[CURVATURE];
                h[(0, CURVATURE)] = self.x[SPEED];
                h[(0, PIVOT_RATE)] = 1.0;
                self.x[SPEED] * self.x[CURVATURE] + self.x[PIVOT_RATE]
            }
            _ => {
                h[(0, SPEED)] = 1.0;
                self.x[SPEED]
            }
        };
        // ω = v·κ + ω_p is bilinear: its v×κ Hessian entry is 1.
        let mut hessian = Hessian::zeros();
        if kind == Kind::YawRate {
            hessian[(1, 2)] = 1.0;
            hessian[(2, 1)] = 1.0;
        }
        let (mean2, cov2) = second_order(&self.p, &[hessian]);
        let innovation = SVector::<f64, 1>::new(value - predicted) - mean2;
        let r = SMatrix::<f64, 1, 1>::new(sigma * sigma) + cov2;
        match self.fuse(kind, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Rejected(test_ratio) => Fusion::Rejected { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
        }
    }

    /// Starts the filter once a fresh fix and a fresh heading are both held.
    fn try_start(&mut self) -> Fusion {
        let now = self.time_s;
        let max_age = self.config.init_max_age_s;
        let fresh = |at_s: f64| now - at_s <= max_age;
        let (Some(fix), Some(heading)) = (self.held_fix, self.held_heading) else {
            return Fusion::Held;
        };
        if !(fresh(fix.at_s) && fresh(heading.at_s)) {
            return Fusion::Held;
        }
        let yaw = heading.value.yaw_rad;
        // A held GNSS velocity gives the signed speed: its projection on the
        // heading (negative when the course points backwards).
        let speed = match self.held_velocity {
            Some(v) if fresh(v.at_s) && v.value.speed_mps >= self.config.min_course_speed_mps => {
                v.value.speed_mps * (v.value.course_rad - yaw).cos()
            }
            _ => 0.0,
        };
        // The fix may be older than the heading (or the reverse); the vehicle
        // may have moved meanwhile: widen the position σ by the speed σ × age.
        let age_s = (fix.at_s - heading.at_s).abs();
        let widen = self.config.init_speed_sigma_mps * age_s;
        let mut fix = fix.value;
        fix.sigma_north_m = fix.sigma_north_m.hypot(widen);
        fix.sigma_east_m = fix.sigma_east_m.hypot(widen);
        let c = self.config;
        self.x = StateVector::zeros();
        self.x[YAW] = yaw;
        self.x[SPEED] = speed;
        self.p = StateCovariance::from_diagonal(&StateVector::from([
            0.0,
            0.0,
            heading.value.sigma_rad.powi(2),
            c.init_speed_sigma_mps.powi(2),
            c.max_curvature_per_m.powi(2),
            c.init_pivot_rate_sigma_rad_s.powi(2),
            0.0,
            0.0,
        ]));
        self.reset_position_to_gnss_fix(&fix);
        self.last_position_reset_m = [0.0; 2];
        self.initialised = true;
        self.held_fix = None;
        self.held_heading = None;
        self.held_velocity = None;
        let now = self.time_s;
        self.innovations[Kind::Position as usize].last_accepted_s = Some(now);
        self.innovations[Kind::Heading as usize].last_accepted_s = Some(now);
        Fusion::Initialised
    }
}
