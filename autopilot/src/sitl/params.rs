//! `SIM_*` parameters: the simulator's knobs, in the same table as the
//! autopilot's so a ground station can change them at run time (as in
//! ArduPilot's SITL).

use drivers::gnss::FixQuality;
use drivers::sim::GnssSimConfig;
use params::{ParamTable, declare_params};

declare_params! {
    pub struct SimParams {
        speedup: f32 = "SIM_SPEEDUP" => {
            default: 1.0, range: 0.0, 100000.0, unit: "",
            desc: "Simulated seconds per wall second (0: as fast as possible)",
        },
        gps_disable: bool = "SIM_GPS_DISABLE" => {
            default: false, range: 0, 1, unit: "",
            desc: "1: the simulated GNSS receiver stops sending",
        },
        gps_rate_hz: f32 = "SIM_GPS_RATE" => {
            default: 10.0, range: 1.0, 100.0, unit: "Hz",
            desc: "Simulated GNSS epochs per second",
        },
        gps_noise_m: f32 = "SIM_GPS_NOISE" => {
            default: 0.01, range: 0.0, 10.0, unit: "m",
            desc: "Simulated GNSS white position noise per axis (1 sigma)",
        },
        gps_walk_m: f32 = "SIM_GPS_WALK" => {
            default: 0.005, range: 0.0, 10.0, unit: "m",
            desc: "Simulated GNSS slow random walk per axis (1 sigma, 60 s correlation)",
        },
        gps_quality: i8 = "SIM_GPS_QUALITY" => {
            default: 4, range: 0, 5, unit: "",
            desc: "Simulated GGA fix quality: 0 none, 1 single, 2 DGPS, 4 RTK fixed, 5 RTK float",
        },
        heading_enable: bool = "SIM_HDG_ENABLE" => {
            default: true, range: 0, 1, unit: "",
            desc: "1: the simulated receiver sends dual-antenna heading (HDT)",
        },
        heading_noise_deg: f32 = "SIM_HDG_NOISE" => {
            default: 0.05, range: 0.0, 10.0, unit: "deg",
            desc: "Simulated dual-antenna heading noise (1 sigma)",
        },
        antenna_x_m: f32 = "SIM_GPS_POS_X" => {
            default: 0.5, range: -10.0, 10.0, unit: "m",
            desc: "Simulated antenna position forward of the rear axle centre",
        },
        antenna_y_m: f32 = "SIM_GPS_POS_Y" => {
            default: 0.0, range: -10.0, 10.0, unit: "m",
            desc: "Simulated antenna position right of the rear axle centre",
        },
    }
}

impl SimParams {
    /// `SIM_SPEEDUP` as a factor; `None` means as fast as possible.
    pub fn speedup(&self, table: &ParamTable) -> Option<f64> {
        let s = f64::from(self.speedup.get(table));
        (s > 0.0).then_some(s)
    }

    /// The receiver the `SIM_GPS_*` parameters describe.
    pub fn gnss_config(&self, table: &ParamTable) -> GnssSimConfig {
        let quality = match self.gps_quality.get(table) {
            0 => FixQuality::NoFix,
            1 => FixQuality::Single,
            2 => FixQuality::Dgps,
            5 => FixQuality::RtkFloat,
            _ => FixQuality::RtkFixed,
        };
        GnssSimConfig {
            enabled: !self.gps_disable.get(table),
            rate_hz: f64::from(self.gps_rate_hz.get(table)),
            antenna_body_m: (
                f64::from(self.antenna_x_m.get(table)),
                f64::from(self.antenna_y_m.get(table)),
            ),
            pos_sigma_m: f64::from(self.gps_noise_m.get(table)),
            pos_walk_sigma_m: f64::from(self.gps_walk_m.get(table)),
            heading_enabled: self.heading_enable.get(table),
            heading_sigma_deg: f64::from(self.heading_noise_deg.get(table)),
            quality,
            ..GnssSimConfig::default()
        }
    }
}
