//! `SIM_*` parameters: the simulator's knobs, in the same table as the
//! autopilot's so a ground station can change them at run time (as in
//! ArduPilot's SITL).

use drivers::gnss::FixQuality;
use params::{ParamTable, declare_params};
use sim::{GnssSimConfig, SimScannerConfig};

use crate::obstacles::params::ScannerParams;

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
            desc: "Simulated GNSS slow random walk per axis (1 sigma, 60 s correlation; a change rescales the walk at once)",
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
        gps_glitch_north_m: f32 = "SIM_GPS_GLITCH_N" => {
            default: 0.0, range: -1000.0, 1000.0, unit: "m",
            desc: "Fault: added to the simulated GNSS position northward (a position jump)",
        },
        gps_glitch_east_m: f32 = "SIM_GPS_GLITCH_E" => {
            default: 0.0, range: -1000.0, 1000.0, unit: "m",
            desc: "Fault: added to the simulated GNSS position eastward (a position jump)",
        },
        heading_freeze: bool = "SIM_HDG_FREEZE" => {
            default: false, range: 0, 1, unit: "",
            desc: "Fault: 1 freezes the simulated dual-antenna heading at its value when set",
        },
        actuator_stuck: i8 = "SIM_ACT_STUCK" => {
            default: 0, range: 0, 3, unit: "",
            desc: "Fault: actuators stuck at their demand when set (1 steering, 2 throttle, 3 both)",
        },
        link_drop_s: f32 = "SIM_LINK_DROP" => {
            default: 0.0, range: 0.0, 600.0, unit: "s",
            desc: "Fault: every MAVLink message in and out is lost for this long from when it is set (then back to 0)",
        },
        cpu_stall_ms: i16 = "SIM_CPU_STALL" => {
            default: 0, range: 0, 10000, unit: "ms",
            desc: "Fault: the core is not stepped for this long from when it is set, the world goes on (then back to 0)",
        },
        battery_volt: f32 = "SIM_BATT_VOLT" => {
            default: 0.0, range: 0.0, 100.0, unit: "V",
            desc: "Fault: the battery monitor reads this voltage (0: the simulated pack's own)",
        },
        scan_disable: i8 = "SIM_SCAN_DISABLE" => {
            default: 0, range: 0, 3, unit: "",
            desc: "Bitmask of simulated scanners that stop sending (1 front, 2 rear): a scanner stall",
        },
        scan_rate_hz: f32 = "SIM_SCAN_RATE" => {
            default: 50.0, range: 1.0, 100.0, unit: "Hz",
            desc: "Simulated laser scans per second (LMS1xx: 25 or 50)",
        },
        scan_fov_deg: f32 = "SIM_SCAN_FOV" => {
            default: 270.0, range: 10.0, 360.0, unit: "deg",
            desc: "Simulated scanner field of view",
        },
        scan_step_deg: f32 = "SIM_SCAN_STEP" => {
            default: 0.5, range: 0.1, 5.0, unit: "deg",
            desc: "Simulated scanner angular step",
        },
        scan_noise_m: f32 = "SIM_SCAN_NOISE" => {
            default: 0.01, range: 0.0, 1.0, unit: "m",
            desc: "Simulated scanner range noise (1 sigma)",
        },
        scan_dropout: f32 = "SIM_SCAN_DROP" => {
            default: 0.002, range: 0.0, 1.0, unit: "",
            desc: "Probability that a simulated beam returns nothing",
        },
    }
}

impl SimParams {
    /// `SIM_SPEEDUP` as a factor; `None` means as fast as possible.
    pub fn speedup(&self, table: &ParamTable) -> Option<f64> {
        let s = f64::from(self.speedup.get(table));
        (s > 0.0).then_some(s)
    }

    /// The simulated scanners, at the mounts the autopilot is told of
    /// (`SCANn_*`): index 0 front, 1 rear.
    pub fn scanner_configs(&self, table: &ParamTable, scanners: &ScannerParams) -> Vec<SimScannerConfig> {
        let disabled = self.scan_disable.get(table);
        let mounts = [
            (
                scanners.scan1_enable.get(table),
                scanners.scan1_x_m,
                scanners.scan1_y_m,
                scanners.scan1_yaw_deg,
            ),
            (
                scanners.scan2_enable.get(table),
                scanners.scan2_x_m,
                scanners.scan2_y_m,
                scanners.scan2_yaw_deg,
            ),
        ];
        mounts
            .iter()
            .enumerate()
            .map(|(i, (fitted, x, y, yaw))| SimScannerConfig {
                enabled: *fitted && disabled & (1 << i) == 0,
                mount_x_m: f64::from(x.get(table)),
                mount_y_m: f64::from(y.get(table)),
                mount_yaw_rad: f64::from(yaw.get(table)).to_radians(),
                fov_rad: f64::from(self.scan_fov_deg.get(table)).to_radians(),
                step_rad: f64::from(self.scan_step_deg.get(table)).to_radians(),
                rate_hz: f64::from(self.scan_rate_hz.get(table)),
                max_range_m: f64::from(scanners.max_range_m.get(table)),
                range_sigma_m: f64::from(self.scan_noise_m.get(table)),
                dropout_probability: f64::from(self.scan_dropout.get(table)),
            })
            .collect()
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
            glitch_ned_m: (
                f64::from(self.gps_glitch_north_m.get(table)),
                f64::from(self.gps_glitch_east_m.get(table)),
            ),
            ..GnssSimConfig::default()
        }
    }
}
