//! `EKF_*`, `COMPASS_DEC` and the GNSS-quality actions `GPS_*_ACT`.

use params::{ParamTable, declare_params};

use super::ekf::EkfConfig;

declare_params! {
    /// The fusion filter (docs/architecture.md §Estimation).
    pub struct EkfParams {
        pos_gate_sigma: f32 = "EKF_POS_GATE" => {
            default: 5.0, range: 1.0, 100.0, unit: "sigma",
            desc: "GNSS position innovation gate: a fix further off is rejected as a jump",
        },
        vel_gate_sigma: f32 = "EKF_VEL_GATE" => {
            default: 5.0, range: 1.0, 100.0, unit: "sigma",
            desc: "GNSS velocity innovation gate",
        },
        hdg_gate_sigma: f32 = "EKF_HDG_GATE" => {
            default: 5.0, range: 1.0, 100.0, unit: "sigma",
            desc: "Heading innovation gate",
        },
        reset_time_s: f32 = "EKF_RESET_TIME" => {
            default: 1.5, range: 0.2, 30.0, unit: "s",
            desc: "Position, velocity or heading rejected this long is taken as real: the filter resets to it",
        },
        accel_noise: f32 = "EKF_ACC_NOISE" => {
            default: 0.3, range: 0.01, 10.0, unit: "m/s/s",
            desc: "Process noise: unannounced change of speed (per root-second)",
        },
        curvature_noise: f32 = "EKF_CURV_NOISE" => {
            default: 0.1, range: 0.001, 10.0, unit: "1/m/s",
            desc: "Process noise: unannounced change of path curvature (per root-second)",
        },
        gps_walk_m: f32 = "EKF_GPS_WALK" => {
            default: 0.005, range: 0.0, 1.0, unit: "m",
            desc: "Slowly wandering part of the GNSS position error (1-sigma per axis)",
        },
        gps_walk_tau_s: f32 = "EKF_GPS_TAU" => {
            default: 60.0, range: 1.0, 3600.0, unit: "s",
            desc: "Correlation time of the wandering GNSS error",
        },
        vel_noise_mps: f32 = "EKF_VEL_NOISE" => {
            default: 0.05, range: 0.001, 5.0, unit: "m/s",
            desc: "GNSS velocity 1-sigma",
        },
        hdg_noise_deg: f32 = "EKF_HDG_NOISE" => {
            default: 0.05, range: 0.001, 30.0, unit: "deg",
            desc: "Heading 1-sigma of the dual-antenna receiver or compass",
        },
        declination_rad: f32 = "COMPASS_DEC" => {
            default: 0.0, range: -std::f32::consts::PI, std::f32::consts::PI, unit: "rad",
            desc: "Magnetic declination, added to compass (HDM/HDG) headings; dual-antenna headings are true already",
        },
    }
}

declare_params! {
    /// What the vehicle does when the GNSS fix degrades from RTK fixed.
    pub struct GnssQualityParams {
        float_action: i8 = "GPS_FLOAT_ACT" => {
            default: 1, range: 0, 2, unit: "",
            desc: "RTK fixed lost to float: 0 continue, 1 slow to GPS_DEGR_SPEED, 2 hold",
        },
        single_action: i8 = "GPS_SINGLE_ACT" => {
            default: 2, range: 0, 2, unit: "",
            desc: "Fix down to single/DGPS: 0 continue, 1 slow to GPS_DEGR_SPEED, 2 hold",
        },
        degraded_speed_mps: f32 = "GPS_DEGR_SPEED" => {
            default: 0.5, range: 0.05, 10.0, unit: "m/s",
            desc: "Speed limit while the fix is degraded and the action is 'slow'",
        },
    }
}

/// What to do about a degraded fix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DegradedFixAction {
    Continue,
    Slow,
    Hold,
}

impl DegradedFixAction {
    pub fn from_param(value: i8) -> DegradedFixAction {
        match value {
            0 => DegradedFixAction::Continue,
            1 => DegradedFixAction::Slow,
            _ => DegradedFixAction::Hold,
        }
    }
}

impl EkfParams {
    /// The filter's tuning; geometry (antenna, turning) is the caller's.
    pub fn ekf_config(&self, table: &ParamTable, base: EkfConfig) -> EkfConfig {
        let f = |p: params::Param<f32>| f64::from(p.get(table));
        let reset = f(self.reset_time_s);
        EkfConfig {
            long_accel_sigma_mps2: f(self.accel_noise),
            curvature_rate_sigma_per_m_s: f(self.curvature_noise),
            gnss_walk_sigma_m: f(self.gps_walk_m),
            gnss_walk_tau_s: f(self.gps_walk_tau_s),
            position_gate_sigma: f(self.pos_gate_sigma),
            velocity_gate_sigma: f(self.vel_gate_sigma),
            heading_gate_sigma: f(self.hdg_gate_sigma),
            position_reset_after_s: reset,
            heading_reset_after_s: reset,
            velocity_reset_after_s: reset,
            ..base
        }
    }
}
