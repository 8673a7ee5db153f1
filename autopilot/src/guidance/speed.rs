//! How fast to drive along a leg: the cruise speed, limited by the path's
//! curvature ahead (a lateral-acceleration limit, braking in time for an
//! arc), by the heading error (seed 002 §4.1: a PID on the angle deviation
//! whose output is the speed), and by a stop at the leg's end, whose final
//! approach is a position loop that ends on the point (docs/architecture.md §Path tracking).
//! A stop that may end farther from its point than the loop's own precision
//! (a VDA 5050 node's `allowedDeviationXY`) is driven in on the braking
//! profile alone, which ends on the point. The speed loop and the drive
//! lag behind that profile, so the vehicle reaches the point still rolling:
//! from there, within the stop's slack, the schedule holds it
//! ([`SpeedLimit::Hold`]: the drive lets go and the vehicle rolls to rest
//! where its lag takes it, rather than chase a speed of 0 on a lagging
//! measurement, which backed it up), and only an overshoot beyond the
//! slack is driven back.
//!
//! Sources: docs/references.md §Seed 002.

use crate::control::pid::{PidGains, PidState};
use crate::guidance::path::ArcSpan;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedConfig {
    pub cruise_mps: f64,
    /// Deceleration the schedule plans with (below the vehicle's brake limit).
    pub decel_mps2: f64,
    /// Lateral acceleration allowed on an arc (`ATC_TURN_MAX_G`·g).
    pub lateral_accel_mps2: f64,
    /// Heading error (rad) → speed reduction (m/s) (`PVW_SPD_*`).
    pub heading: PidGains,
    /// Slowest the heading and curvature limits go, so the vehicle does not
    /// crawl while it turns onto the path: this, or a quarter of the cruise
    /// speed if that is more.
    pub min_mps: f64,
    /// Final approach to a stop: speed = gain × distance to go
    /// (`WP_APPR_GAIN`), which also backs up after an overshoot.
    pub approach_gain_per_s: f64,
    /// How much farther from its point a stop may end than the precision
    /// the approach loop is tuned for (the stop's tolerance less
    /// `WP_STOP_TOL_MM`; 0 for a precision stop). More than 0: no loop
    /// short of the point, a hold past it by up to this, and beyond, the
    /// loop's distance offset by it.
    pub stop_slack_m: f64,
    /// With the steering rate (`VEH_STEER_RATE`, 0 for none): how long the
    /// wheels take to turn to an arc's angle, which the arc's speed covers.
    pub wheelbase_m: f64,
    pub steer_rate_rad_s: f64,
}

/// What set the speed, for telemetry and tuning.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpeedLimit {
    #[default]
    Cruise,
    Curvature,
    Heading,
    Braking,
    Approach,
    /// At or past a stop's point within its slack: the drive lets go, and
    /// the vehicle rolls to rest (no speed is chased).
    Hold,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedStatus {
    /// Along the direction of travel; negative backs up to a stop point
    /// after an overshoot.
    pub speed_mps: f64,
    pub limit: SpeedLimit,
    /// The heading PID's reduction.
    pub heading_reduction_mps: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedState {
    heading: PidState,
}

impl SpeedState {
    pub fn reset(&mut self) {
        *self = SpeedState::default();
    }
}

/// Where the vehicle is and what lies ahead on its leg.
#[derive(Clone, Copy, Debug)]
pub struct SpeedInputs<'a> {
    pub along_m: f64,
    /// Along-track position of the stop, when the leg ends in one.
    pub stop_at_m: Option<f64>,
    /// The leg's arcs.
    pub arcs: &'a [ArcSpan],
    /// The tracker's heading error relative to the path.
    pub heading_error_rad: f64,
}

/// The fastest the vehicle may go `distance_m` before a point it must pass
/// at `speed_at_mps`, braking at `decel_mps2`.
pub fn braking_limit(speed_at_mps: f64, distance_m: f64, decel_mps2: f64) -> f64 {
    (speed_at_mps * speed_at_mps + 2.0 * decel_mps2 * distance_m.max(0.0)).sqrt()
}

/// How far the vehicle drives, at `speed_mps`, while the steering turns
/// between straight and an arc of `curvature` at the rate limit. The
/// tracker turns the wheels half of it before the arc and half on it (and
/// the same at the arc's end), so the arc's speed holds from one such
/// distance before the arc to one after it: the steering ramp is planned
/// at the speed it is driven at, and the vehicle is not still braking into
/// it or already speeding out of it.
fn steering_transition_m(config: &SpeedConfig, curvature: f64, speed_mps: f64) -> f64 {
    if config.steer_rate_rad_s > 0.0 {
        (config.wheelbase_m * curvature.abs()).atan() / config.steer_rate_rad_s * speed_mps
    } else {
        0.0
    }
}

pub fn scheduled_speed(
    config: &SpeedConfig,
    state: &mut SpeedState,
    inputs: &SpeedInputs<'_>,
    dt_s: f64,
) -> SpeedStatus {
    let cruise = config.cruise_mps.max(0.0);
    let decel = config.decel_mps2.max(0.01);
    let floor = config.min_mps.max(0.25 * cruise).min(cruise);
    let mut status = SpeedStatus {
        speed_mps: cruise,
        limit: SpeedLimit::Cruise,
        heading_reduction_mps: 0.0,
    };
    let limit = |speed: f64, why: SpeedLimit, status: &mut SpeedStatus| {
        if speed < status.speed_mps {
            status.speed_mps = speed;
            status.limit = why;
        }
    };

    for arc in inputs.arcs {
        if arc.curvature.abs() > 1e-9 && config.lateral_accel_mps2 > 0.0 {
            let on_arc = (config.lateral_accel_mps2 / arc.curvature.abs()).sqrt().max(floor);
            let transition_m = steering_transition_m(config, arc.curvature, on_arc);
            if inputs.along_m > arc.end_m + transition_m {
                continue;
            }
            limit(
                braking_limit(on_arc, arc.start_m - transition_m - inputs.along_m, decel),
                SpeedLimit::Curvature,
                &mut status,
            );
        }
    }

    let reduction = state
        .heading
        .update(&config.heading, inputs.heading_error_rad.abs(), dt_s)
        .output()
        .max(0.0);
    status.heading_reduction_mps = reduction;
    limit((cruise - reduction).max(floor), SpeedLimit::Heading, &mut status);

    if let Some(stop_m) = inputs.stop_at_m {
        let remaining = stop_m - inputs.along_m;
        limit(braking_limit(0.0, remaining, decel), SpeedLimit::Braking, &mut status);
        // The position loop: never below it near the stop (the heading and
        // curvature floors do not apply), signed so an overshoot backs up,
        // no faster than the vehicle cruises.
        let approach = approach_loop_mps(config, remaining).max(-cruise);
        if approach < status.speed_mps {
            status.speed_mps = approach;
            status.limit = SpeedLimit::Approach;
        }
        let slack = config.stop_slack_m.max(0.0);
        if slack > 0.0 && (-slack..=0.0).contains(&remaining) {
            status.speed_mps = 0.0;
            status.limit = SpeedLimit::Hold;
        }
    }
    status
}

/// The final approach's position loop with `remaining_m` to go to a stop
/// (negative past it). A stop with slack has none short of its point (the
/// braking profile brings the vehicle in); past it the loop runs as if the
/// point were the slack farther, so only an overshoot beyond the slack
/// backs up.
pub fn approach_loop_mps(config: &SpeedConfig, remaining_m: f64) -> f64 {
    let slack = config.stop_slack_m.max(0.0);
    if slack > 0.0 && remaining_m > 0.0 {
        return f64::INFINITY;
    }
    config.approach_gain_per_s * (remaining_m + slack)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CONFIG: SpeedConfig = SpeedConfig {
        cruise_mps: 2.0,
        decel_mps2: 0.5,
        lateral_accel_mps2: 0.5,
        heading: PidGains {
            kp: 2.0,
            ki: 0.0,
            kd: 0.0,
            imax: 0.0,
        },
        min_mps: 0.1,
        approach_gain_per_s: 1.0,
        stop_slack_m: 0.0,
        wheelbase_m: 2.0,
        steer_rate_rad_s: 0.0,
    };

    fn speed(along_m: f64, stop_at_m: Option<f64>, arcs: &[ArcSpan], heading_error_rad: f64) -> SpeedStatus {
        speed_with(&CONFIG, along_m, stop_at_m, arcs, heading_error_rad)
    }

    fn speed_with(
        config: &SpeedConfig,
        along_m: f64,
        stop_at_m: Option<f64>,
        arcs: &[ArcSpan],
        heading_error_rad: f64,
    ) -> SpeedStatus {
        scheduled_speed(
            config,
            &mut SpeedState::default(),
            &SpeedInputs {
                along_m,
                stop_at_m,
                arcs,
                heading_error_rad,
            },
            0.02,
        )
    }

    #[test]
    fn cruises_far_from_the_stop_and_brakes_near_it() {
        assert_eq!(speed(0.0, Some(50.0), &[], 0.0).speed_mps, 2.0);
        let st = speed(47.0, Some(50.0), &[], 0.0);
        assert_eq!(st.limit, SpeedLimit::Braking);
        assert!((st.speed_mps - 3f64.sqrt()).abs() < 1e-12);
        let st = speed(49.5, Some(50.0), &[], 0.0);
        assert_eq!(st.limit, SpeedLimit::Approach);
        assert!((st.speed_mps - 0.5).abs() < 1e-12);
        assert_eq!(speed(50.0, Some(50.0), &[], 0.0).speed_mps, 0.0);
        assert!(
            speed(50.01, Some(50.0), &[], 0.0).speed_mps < 0.0,
            "an overshoot backs up"
        );
        // Found by the mission_flight fuzz target: 10 m past the stop the
        // position loop asked for 10 m/s backwards with a 2 m/s cruise.
        assert_eq!(
            speed(60.0, Some(50.0), &[], 0.0).speed_mps,
            -2.0,
            "no faster than cruise"
        );
    }

    /// A stop that may end 0.29 m farther than the loop's precision (with
    /// the vehicle's gain and planned deceleration): no loop short of the
    /// point, so 0.3 m out the braking profile's 0.69 m/s (the precision
    /// loop's 0.18), ending on the point; at the point and past it within
    /// the slack a hold; past by more, backed up.
    #[test]
    fn a_wide_stop_is_braked_into_and_held_past_its_point() {
        let precise = SpeedConfig {
            approach_gain_per_s: 0.6,
            decel_mps2: 0.8,
            ..CONFIG
        };
        let wide = SpeedConfig {
            stop_slack_m: 0.29,
            ..precise
        };
        let st = speed_with(&wide, 49.7, Some(50.0), &[], 0.0);
        assert_eq!(st.limit, SpeedLimit::Braking);
        assert!((st.speed_mps - 0.48f64.sqrt()).abs() < 1e-12, "{st:?}");
        let before = speed_with(&precise, 49.7, Some(50.0), &[], 0.0);
        assert!((before.speed_mps - 0.6 * 0.3).abs() < 1e-12, "{before:?}");
        let st = speed_with(&wide, 49.99, Some(50.0), &[], 0.0);
        assert_eq!(st.limit, SpeedLimit::Braking);
        assert!((st.speed_mps - 0.016f64.sqrt()).abs() < 1e-12, "{st:?}");
        for along_m in [50.0, 50.2, 50.29] {
            let held = speed_with(&wide, along_m, Some(50.0), &[], 0.0);
            assert_eq!((held.speed_mps, held.limit), (0.0, SpeedLimit::Hold), "{along_m}");
        }
        let st = speed_with(&wide, 50.5, Some(50.0), &[], 0.0);
        assert_eq!(st.limit, SpeedLimit::Approach);
        assert!(
            (st.speed_mps + 0.6 * 0.21).abs() < 1e-12,
            "past by more: backs up {st:?}"
        );
        let precise_past = speed_with(&precise, 50.2, Some(50.0), &[], 0.0);
        assert_eq!(
            precise_past.limit,
            SpeedLimit::Approach,
            "a precision stop is never held"
        );
        assert!((precise_past.speed_mps + 0.6 * 0.2).abs() < 1e-12, "{precise_past:?}");
    }

    #[test]
    fn slows_for_an_arc_in_time_and_on_it() {
        // 0.5 m/s² on a 2 m radius: 1 m/s on the arc.
        let arcs = [ArcSpan {
            start_m: 20.0,
            end_m: 23.0,
            curvature: -0.5,
        }];
        let on_arc = speed(21.0, None, &arcs, 0.0);
        assert_eq!(on_arc.limit, SpeedLimit::Curvature);
        assert!((on_arc.speed_mps - 1.0).abs() < 1e-12);
        let before = speed(17.0, None, &arcs, 0.0);
        assert!((before.speed_mps - 4f64.sqrt()).abs() < 1e-12, "{before:?}");
        assert_eq!(speed(0.0, None, &arcs, 0.0).speed_mps, 2.0);
        assert_eq!(speed(23.01, None, &arcs, 0.0).speed_mps, 2.0, "the arc is behind");
    }

    /// With a steering rate limit the arc's speed covers the wheels'
    /// turning in and out: 1 s at 1 m/s either side for a 45° angle at
    /// 45°/s (wheelbase 2 m, radius 2 m).
    #[test]
    fn the_arc_speed_covers_the_steering_transitions() {
        let config = SpeedConfig {
            steer_rate_rad_s: 45f64.to_radians(),
            ..CONFIG
        };
        let arcs = [ArcSpan {
            start_m: 20.0,
            end_m: 23.0,
            curvature: 0.5,
        }];
        for along_m in [19.0, 21.0, 23.9] {
            let st = speed_with(&config, along_m, None, &arcs, 0.0);
            assert!((st.speed_mps - 1.0).abs() < 1e-9, "{along_m} m: {st:?}");
        }
        let before = speed_with(&config, 16.0, None, &arcs, 0.0);
        assert!(
            (before.speed_mps - 4f64.sqrt()).abs() < 1e-9,
            "braking ends 1 m early: {before:?}"
        );
        assert_eq!(speed_with(&config, 24.01, None, &arcs, 0.0).speed_mps, 2.0);
    }

    #[test]
    fn heading_error_slows_down_but_not_to_a_stall() {
        let st = speed(0.0, None, &[], 0.25);
        assert_eq!(st.limit, SpeedLimit::Heading);
        assert!((st.speed_mps - 1.5).abs() < 1e-12);
        assert_eq!(speed(0.0, None, &[], 3.0).speed_mps, 0.5, "a quarter of cruise");
    }
}
