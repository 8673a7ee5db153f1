//! The simulator's truth, in SITL only: SIMSTATE as ArduPilot's SITL sends
//! it, and a stop's error measured on the true pose beside the estimate's.
//! Nothing here steers the vehicle.

use mavlink::dialects::ardupilotmega::SIMSTATE_DATA;

use super::Core;
use crate::geo::{GeoPoint, wrap_pi};
use crate::guidance::navigator::StopReport;

/// What an accelerometer at rest reads on its z axis (down), m/s².
const STANDARD_GRAVITY_MPS2: f64 = 9.80665;

impl Core {
    /// SIMSTATE (ardupilotmega, id 164): attitude in rad, specific force in
    /// the body frame in m/s² (z reads −g at rest, as an accelerometer and
    /// ArduPilot's SITL do), body rates in rad/s, position in degE7. A
    /// ground vehicle on the plane: no roll or pitch; the lateral force is
    /// the centripetal v·ω.
    pub(super) fn simstate(&self) -> Option<SIMSTATE_DATA> {
        let t = self.sim_truth?;
        let at = GeoPoint::new(t.lat_deg, t.lon_deg, 0.0);
        Some(SIMSTATE_DATA {
            roll: 0.0,
            pitch: 0.0,
            yaw: wrap_pi(t.yaw_rad) as f32,
            xacc: t.accel_mps2 as f32,
            yacc: (t.speed_mps * t.yaw_rate_rad_s) as f32,
            zacc: -STANDARD_GRAVITY_MPS2 as f32,
            xgyro: 0.0,
            ygyro: 0.0,
            zgyro: t.yaw_rate_rad_s as f32,
            lat: at.lat_e7(),
            lng: at.lon_e7(),
        })
    }

    /// "SITL truth #8: 4.1 mm, yaw 0.012 deg": the stop of `report` measured
    /// on the simulator's pose instead of the estimate, against the same
    /// stop point (the leg's end) and heading (recovered from the estimate
    /// and the report's yaw error). None outside SITL.
    pub(super) fn true_stop_text(&self, report: &StopReport) -> Option<String> {
        let truth = self.sim_truth?;
        let frame = self.frame()?;
        let stop_point = self.navigator.target()?.point;
        let estimate = self.estimator.estimate();
        let path_yaw = wrap_pi(estimate.yaw_rad - report.yaw_error_rad);
        let at = GeoPoint::new(truth.lat_deg, truth.lon_deg, frame.origin().alt_m);
        let true_position = frame.to_local(&at);
        let true_yaw = frame.heading_to_local(&at, truth.yaw_rad);
        let error_m = true_position.distance_to(&stop_point);
        let yaw_error_rad = wrap_pi(true_yaw - path_yaw);
        let which = report.seq.map_or(String::new(), |seq| format!(" #{seq}"));
        Some(format!(
            "SITL truth{which}: {:.1} mm, yaw {:.3} deg",
            error_m * 1000.0,
            yaw_error_rad.to_degrees()
        ))
    }
}
