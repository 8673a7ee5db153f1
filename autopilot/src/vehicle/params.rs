//! The core's parameters, declared once per subsystem. ArduPilot Rover's
//! names, units and meanings where the concept matches (docs/architecture.md §MAVLink identity); Furrow's
//! own prefixes otherwise (`PVW_` preview tracker, `VEH_` vehicle geometry).
//!
//! Sources: docs/references.md §Seed 000, docs/references.md §Seed 002.

use params::{Param, ParamDef, ParamFlags, ParamName, ParamTableBuilder, ParamType, declare_params};

use crate::control::servo::ServoParams;
use crate::estimation::{EkfParams, GnssQualityParams};
use crate::geo::GeoParams;
use crate::obstacles::params::ObstacleParams;
use crate::telemetry::streams::StreamGroup;

declare_params! {
    /// Identity and scheduling.
    pub struct SystemParams {
        sysid: i16 = "SYSID_THISMAV" => {
            default: 1, range: 1, 255, unit: "", flags: [reboot_required],
            desc: "MAVLink system id of this vehicle",
        },
        gcs_sysid: i16 = "SYSID_MYGCS" => {
            default: 255, range: 1, 255, unit: "",
            desc: "System id of the ground station allowed to drive (manual input, GCS failsafe)",
        },
        loop_rate_hz: i16 = "SCHED_LOOP_RATE" => {
            default: 50, range: 10, 400, unit: "Hz", flags: [reboot_required],
            desc: "Core tick rate",
        },
        initial_mode: i8 = "INITIAL_MODE" => {
            default: 4, range: 0, 16, unit: "",
            desc: "Mode at start (ArduPilot Rover numbers; default HOLD)",
        },
        rc_override_time_s: f32 = "RC_OVERRIDE_TIME" => {
            default: 3.0, range: 0.0, 120.0, unit: "s",
            desc: "Manual input (MANUAL_CONTROL, RC override) is dropped after this silence",
        },
        arming_check: i32 = "ARMING_CHECK" => {
            default: 1, range: 0, 65535, unit: "",
            desc: "Arming checks (ArduPilot bits): 0 none, 1 all, 4 heading, 8 position fix, 16 EKF, 32 parameters, 256 battery, 8192 fence, 16384 mission, 32768 scanners",
        },
        boot_count: i32 = "STAT_BOOTCNT" => {
            default: 0, range: 0, 16000000, unit: "", flags: [read_only],
            desc: "Number of times the autopilot has started (kept in the data directory)",
        },
    }
}

declare_params! {
    /// Vehicle geometry and drive train.
    pub struct VehicleParams {
        drive_train: i8 = "VEH_DRIVE" => {
            default: 0, range: 0, 1, unit: "", flags: [reboot_required],
            desc: "Drive train: 0 Ackermann steering, 1 differential (skid) steering",
        },
        wheelbase_m: f32 = "VEH_WHEELBASE" => {
            default: 2.9, range: 0.1, 20.0, unit: "m",
            desc: "Distance between front and rear axles",
        },
        track_m: f32 = "VEH_TRACK" => {
            default: 1.6, range: 0.1, 10.0, unit: "m",
            desc: "Distance between left and right wheels",
        },
        steer_max_deg: f32 = "VEH_STEER_MAX" => {
            default: 30.0, range: 1.0, 60.0, unit: "deg",
            desc: "Largest centre steering angle the tracker commands",
        },
        steer_rate_deg_s: f32 = "VEH_STEER_RATE" => {
            default: 30.0, range: 0.0, 360.0, unit: "deg/s",
            desc: "Fastest the steering command may change, as the steering gear can (0: no limit)",
        },
        antenna_x_m: f32 = "GPS_POS1_X" => {
            default: 0.0, range: -10.0, 10.0, unit: "m",
            desc: "GNSS antenna position forward of the rear axle centre",
        },
        antenna_y_m: f32 = "GPS_POS1_Y" => {
            default: 0.0, range: -10.0, 10.0, unit: "m",
            desc: "GNSS antenna position right of the rear axle centre",
        },
    }
}

declare_params! {
    /// Waypoint navigation and speed control.
    pub struct NavParams {
        wp_speed_mps: f32 = "WP_SPEED" => {
            default: 2.0, range: 0.0, 10.0, unit: "m/s",
            desc: "Speed in AUTO and GUIDED",
        },
        wp_radius_m: f32 = "WP_RADIUS" => {
            default: 2.0, range: 0.0, 100.0, unit: "m",
            desc: "A waypoint within this distance counts as reached",
        },
        rtl_speed_mps: f32 = "RTL_SPEED" => {
            default: 0.0, range: 0.0, 10.0, unit: "m/s",
            desc: "Speed in RTL (0: WP_SPEED)",
        },
        cruise_speed_mps: f32 = "CRUISE_SPEED" => {
            default: 2.0, range: 0.1, 20.0, unit: "m/s",
            desc: "Speed reached at CRUISE_THROTTLE (throttle feed-forward)",
        },
        cruise_throttle_pct: f32 = "CRUISE_THROTTLE" => {
            default: 50.0, range: 1.0, 100.0, unit: "%",
            desc: "Throttle that gives CRUISE_SPEED",
        },
        accel_max_mps2: f32 = "ATC_ACCEL_MAX" => {
            default: 1.0, range: 0.1, 10.0, unit: "m/s/s",
            desc: "Acceleration limit of the speed demand",
        },
        decel_max_mps2: f32 = "ATC_DECEL_MAX" => {
            default: 0.0, range: 0.0, 10.0, unit: "m/s/s",
            desc: "Deceleration limit of the speed demand (0: ATC_ACCEL_MAX)",
        },
        // Off by default. On the simulated car 0.3 s (its drive's lag)
        // starts faster but left 2 of 64 RTK-grade RTL stops at 0.057°
        // (bar 0.05°); on the skid-steer 0.2 s ran the first 3 m after a
        // corner wider (p99 10.7 against 8.9 mm).
        drive_lag_s: f32 = "ATC_DRV_LAG" => {
            default: 0.0, range: 0.0, 2.0, unit: "s",
            desc: "The drive's first-order lag: while the speed demand ramps at ATC_ACCEL_MAX the throttle leads the ramp by this much so the wheels follow it (0: no lead)",
        },
        speed_p: f32 = "ATC_SPEED_P" => {
            default: 0.2, range: 0.0, 2.0, unit: "",
            desc: "Speed controller P gain (throttle per m/s)",
        },
        speed_i: f32 = "ATC_SPEED_I" => {
            default: 0.2, range: 0.0, 2.0, unit: "",
            desc: "Speed controller I gain",
        },
        speed_d: f32 = "ATC_SPEED_D" => {
            default: 0.0, range: 0.0, 0.5, unit: "",
            desc: "Speed controller D gain",
        },
        speed_imax: f32 = "ATC_SPEED_IMAX" => {
            default: 1.0, range: 0.0, 1.0, unit: "",
            desc: "Speed controller integrator limit (throttle fraction)",
        },
        turn_max_g: f32 = "ATC_TURN_MAX_G" => {
            default: 0.02, range: 0.01, 1.0, unit: "gravities",
            desc: "Lateral acceleration allowed on a path arc: sets the speed there",
        },
        arc_margin: f32 = "WP_ARC_MARGIN" => {
            default: 1.2, range: 1.0, 5.0, unit: "",
            desc: "Corner arc radius as a multiple of the tightest turn (VEH_WHEELBASE / tan VEH_STEER_MAX)",
        },
        stop_tol_mm: f32 = "WP_STOP_TOL_MM" => {
            default: 10.0, range: 1.0, 1000.0, unit: "mm",
            desc: "A precision stop (hold, last item, before a direction change) must end this close",
        },
        stop_tol_deg: f32 = "WP_STOP_TOL_DEG" => {
            default: 0.05, range: 0.001, 10.0, unit: "deg",
            desc: "A precision stop must end with the path's heading within this",
        },
        approach_gain: f32 = "WP_APPR_GAIN" => {
            default: 0.6, range: 0.05, 5.0, unit: "1/s",
            desc: "Final approach to a stop: speed per m still to go",
        },
    }
}

declare_params! {
    /// Manoeuvres: forward/reverse paths to a pose the current leg cannot reach.
    pub struct ManoeuvreParams {
        length_max_m: f32 = "MNV_LEN_MAX" => {
            default: 60.0, range: 1.0, 1000.0, unit: "m",
            desc: "Longest manoeuvre planned to reach a pose; beyond it the goal is refused",
        },
        direction_changes_max: i8 = "MNV_DIR_MAX" => {
            default: 3, range: 0, 10, unit: "",
            desc: "Most changes between forward and reverse a manoeuvre may have",
        },
        approach_m: f32 = "MNV_APPR_LEN" => {
            default: 8.0, range: 0.0, 50.0, unit: "m",
            desc: "Straight a manoeuvre ends with, into the goal (a precision stop settles on it)",
        },
        speed_mps: f32 = "MNV_SPEED" => {
            default: 0.5, range: 0.05, 5.0, unit: "m/s",
            desc: "Speed limit on a manoeuvre",
        },
        pivot: bool = "MNV_PIVOT" => {
            default: false, range: 0, 1, unit: "",
            desc: "1: a differential-drive vehicle may turn on the spot in a manoeuvre (face the goal, drive straight, turn onto its heading); 0: arcs only. Default 1 for differential drive; ignored for Ackermann",
        },
        pivot_rate_deg_s: f32 = "MNV_PIVOT_RATE" => {
            default: 30.0, range: 1.0, 180.0, unit: "deg/s",
            desc: "Fastest turn on the spot",
        },
        mission_yaw: bool = "MNV_WP_YAW" => {
            default: false, range: 0, 1, unit: "",
            desc: "1: a mission stop's NAV_WAYPOINT param 4 is the heading to stop facing (NaN none); 0 ignores it as ArduPilot Rover does",
        },
    }
}

declare_params! {
    /// The preview-point tracker (seed 000 §2.4).
    pub struct PreviewParams {
        dist_m: f32 = "PVW_DIST" => {
            default: 2.0, range: 0.2, 20.0, unit: "m",
            desc: "Preview distance at standstill",
        },
        dist_k_s: f32 = "PVW_DIST_K" => {
            default: 0.5, range: 0.0, 5.0, unit: "s",
            desc: "Preview distance added per m/s of speed",
        },
        lat_p: f32 = "PVW_LAT_P" => {
            default: 2.0, range: 0.0, 10.0, unit: "",
            desc: "Lateral PID P gain (m of correction per m of offset)",
        },
        lat_i: f32 = "PVW_LAT_I" => {
            default: 0.0, range: 0.0, 10.0, unit: "",
            desc: "Lateral PID I gain",
        },
        lat_d: f32 = "PVW_LAT_D" => {
            default: 0.0, range: 0.0, 10.0, unit: "",
            desc: "Lateral PID D gain",
        },
        lat_imax_m: f32 = "PVW_LAT_IMAX" => {
            default: 0.5, range: 0.0, 5.0, unit: "m",
            desc: "Lateral PID integrator limit",
        },
        yaw_p: f32 = "PVW_YAW_P" => {
            default: 0.8, range: 0.0, 10.0, unit: "",
            desc: "Yaw PID P gain (rad of steering per rad of heading error)",
        },
        yaw_i: f32 = "PVW_YAW_I" => {
            default: 0.0, range: 0.0, 10.0, unit: "",
            desc: "Yaw PID I gain",
        },
        yaw_d: f32 = "PVW_YAW_D" => {
            default: 0.0, range: 0.0, 10.0, unit: "",
            desc: "Yaw PID D gain",
        },
        yaw_imax_rad: f32 = "PVW_YAW_IMAX" => {
            default: 0.2, range: 0.0, 1.0, unit: "rad",
            desc: "Yaw PID integrator limit",
        },
        stop_dist_m: f32 = "PVW_STOP_DIST" => {
            default: 6.0, range: 0.0, 20.0, unit: "m",
            desc: "Preview distance at a precision stop (reached over the last twice this distance; 0: off)",
        },
        ff_time_s: f32 = "PVW_FF_TIME" => {
            default: 0.12, range: 0.0, 3.0, unit: "s",
            desc: "The path's curvature is fed forward to the steering this far ahead in travel time where a turn begins or tightens",
        },
        ff_exit_s: f32 = "PVW_FF_EXIT" => {
            default: 0.12, range: 0.0, 3.0, unit: "s",
            desc: "As PVW_FF_TIME where a turn ends or eases (a skid-steer vehicle unwinds a turn more slowly than it winds one)",
        },
        spd_p: f32 = "PVW_SPD_P" => {
            default: 2.0, range: 0.0, 20.0, unit: "m/s/rad",
            desc: "Speed PID P gain: speed taken off per rad of heading error",
        },
        spd_i: f32 = "PVW_SPD_I" => {
            default: 0.0, range: 0.0, 20.0, unit: "",
            desc: "Speed PID I gain",
        },
        spd_d: f32 = "PVW_SPD_D" => {
            default: 0.0, range: 0.0, 5.0, unit: "",
            desc: "Speed PID D gain",
        },
        spd_imax_mps: f32 = "PVW_SPD_IMAX" => {
            default: 1.0, range: 0.0, 10.0, unit: "m/s",
            desc: "Speed PID integrator limit",
        },
    }
}

declare_params! {
    /// The magnetic-tape guide (seed 002 §2, §4): two 16-probe sensors.
    pub struct MagneticParams {
        pitch_mm: f32 = "MAG_PITCH_MM" => {
            default: 10.0, range: 1.0, 100.0, unit: "mm",
            desc: "Distance between neighbouring probes of a sensor",
        },
        front_x_m: f32 = "MAG_FRONT_X" => {
            default: 1.0, range: -10.0, 10.0, unit: "m",
            desc: "Front sensor centre, forward of the rear axle centre",
        },
        rear_x_m: f32 = "MAG_REAR_X" => {
            default: -1.0, range: -10.0, 10.0, unit: "m",
            desc: "Rear sensor centre, forward of the rear axle centre (negative: behind it)",
        },
        steer_p: f32 = "MAG_STR_P" => {
            default: 9.0, range: 0.0, 100.0, unit: "rad/m",
            desc: "Steering PID P gain on the lateral deviation (incremental form, eq. 15 of the double-magnetic-guide paper)",
        },
        steer_i: f32 = "MAG_STR_I" => {
            default: 2.0, range: 0.0, 100.0, unit: "rad/m/s",
            desc: "Steering PID I gain (0 in the double-magnetic-guide paper)",
        },
        steer_d: f32 = "MAG_STR_D" => {
            default: 6.0, range: 0.0, 100.0, unit: "rad.s/m",
            desc: "Steering PID D gain",
        },
        steer_correction_deg: f32 = "MAG_STR_CMAX" => {
            default: 30.0, range: 1.0, 60.0, unit: "deg",
            desc: "Largest correction of the P and D terms about the integral (the sensors' geometry may limit it further)",
        },
        speed_p: f32 = "MAG_SPD_P" => {
            default: 3.0, range: 0.0, 100.0, unit: "m/s/rad",
            desc: "Speed PID P gain on the angle deviation beyond MAG_SPD_DB",
        },
        speed_i: f32 = "MAG_SPD_I" => {
            default: 1.0, range: 0.0, 100.0, unit: "m/s/rad/s",
            desc: "Speed PID I gain",
        },
        speed_deadband_deg: f32 = "MAG_SPD_DB" => {
            default: 5.0, range: 0.0, 45.0, unit: "deg",
            desc: "Angle deviation the speed PID ignores",
        },
        speed_mps: f32 = "MAG_SPEED" => {
            default: 1.5, range: 0.05, 5.0, unit: "m/s",
            desc: "Speed on the tape when aligned",
        },
        speed_min_mps: f32 = "MAG_SPEED_MIN" => {
            default: 0.5, range: 0.0, 5.0, unit: "m/s",
            desc: "The speed PID never asks for less",
        },
        lost_speed_mps: f32 = "MAG_LOST_SPD" => {
            default: 0.5, range: 0.0, 5.0, unit: "m/s",
            desc: "Speed while both sensors are off the tape after losing it (searching: back towards the side it was last seen, then straight); a start with no sensor on the tape searches faster, up to MAG_SPEED, where the steering can still turn along the tape once a sensor finds it",
        },
        lost_hold_s: f32 = "MAG_LOST_HOLD" => {
            default: 0.3, range: 0.0, 5.0, unit: "s",
            desc: "Both sensors off the tape: first 1.5 s steering on the deviation carried forward from speed and yaw rate (dead reckoning), then the last demand this long, then the search",
        },
        lost_stop_s: f32 = "MAG_LOST_STOP" => {
            default: 10.0, range: 0.0, 600.0, unit: "s",
            desc: "Off the tape this long: stop and switch to HOLD (0: never)",
        },
    }
}

declare_params! {
    /// Missions (ArduPilot Rover's names).
    pub struct MissionParams {
        done_behave: i8 = "MIS_DONE_BEHAVE" => {
            default: 0, range: 0, 3, unit: "",
            desc: "At mission end: 0 hold in AUTO, 3 MANUAL (1 LOITER and 2 ACRO hold, Furrow has neither)",
        },
        restart: bool = "MIS_RESTART" => {
            default: false, range: 0, 1, unit: "",
            desc: "Entering AUTO: 0 resumes the mission where it was, 1 restarts it",
        },
    }
}

declare_params! {
    /// The geofence (ArduPilot's names).
    pub struct FenceParams {
        enable: bool = "FENCE_ENABLE" => {
            default: true, range: 0, 1, unit: "",
            desc: "1: an uploaded fence is enforced (breach action, arming check)",
        },
        action: i8 = "FENCE_ACTION" => {
            default: 1, range: 0, 2, unit: "",
            desc: "On a breach: 0 report only, 1 RTL (HOLD if RTL is impossible), 2 HOLD",
        },
    }
}

declare_params! {
    /// Arming requirements and failsafes (ArduPilot's names where Rover has
    /// one). Actions: 0 report only, 1 RTL (HOLD if impossible), 2 HOLD,
    /// 5 disarm (outputs to trim at once).
    pub struct FailsafeParams {
        rtk_required: i8 = "ARMING_RTK_REQ" => {
            default: 2, range: 0, 2, unit: "",
            desc: "Fix needed to arm in a mode that drives itself: 0 any fix, 1 RTK float or better, 2 RTK fixed",
        },
        action: i8 = "FS_ACTION" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action of the GCS failsafe: 0 none, 1 RTL, 2 HOLD, 5 disarm",
        },
        gcs_enable: i8 = "FS_GCS_ENABLE" => {
            default: 0, range: 0, 2, unit: "",
            desc: "GCS heartbeat failsafe: 0 off, 1 on, 2 on but AUTO carries on with its mission",
        },
        gcs_timeout_s: f32 = "FS_GCS_TIMEOUT" => {
            default: 5.0, range: 1.0, 120.0, unit: "s",
            desc: "GCS failsafe after this long without a heartbeat from the ground station (SYSID_MYGCS)",
        },
        gnss_lost_s: f32 = "FS_GNSS_TIMEOUT" => {
            default: 1.0, range: 0.2, 30.0, unit: "s",
            desc: "GNSS lost after this long without a fix",
        },
        gnss_action: i8 = "FS_GNSS_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action when the GNSS is lost (degraded fixes: GPS_FLOAT_ACT, GPS_SINGLE_ACT)",
        },
        heading_lost_s: f32 = "FS_HDG_TIMEOUT" => {
            default: 1.0, range: 0.2, 30.0, unit: "s",
            desc: "Heading lost after this long without a heading measurement (or a frozen one)",
        },
        heading_action: i8 = "FS_HDG_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action when the heading is lost while driving on a heading sensor",
        },
        ekf_action: i8 = "FS_EKF_ACTION" => {
            default: 1, range: 0, 2, unit: "",
            desc: "EKF failsafe (ArduPilot's values): 0 disabled, 1 HOLD, 2 report only",
        },
        scanner_action: i8 = "FS_SCAN_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action when an enabled scanner goes stale while obstacle stopping is on",
        },
        loop_overrun_ms: i16 = "FS_LOOP_MS" => {
            default: 200, range: 20, 5000, unit: "ms",
            desc: "Core deadline failsafe: a gap this long between core ticks",
        },
        loop_action: i8 = "FS_LOOP_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action after a core deadline overrun",
        },
        xtrack_max_m: f32 = "FS_XTRACK_M" => {
            default: 0.0, range: 0.0, 100.0, unit: "m",
            desc: "Control failsafe: off the leg by more than this for a second (a stuck steering, say; 0: off). A mission that turns round on the spot (Ackermann) leaves its leg by a turning circle",
        },
        control_action: i8 = "FS_CTRL_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action of the control failsafe (a vehicle still moving 3 s into HOLD is always disarmed)",
        },
        resume: bool = "FS_RESUME" => {
            default: false, range: 0, 1, unit: "",
            desc: "1: after a GNSS, heading, EKF or scanner failsafe clears, AUTO or RTL goes on where it stopped (0: stays stopped until the operator acts; GUIDED always stays)",
        },
        batt_low_volt: f32 = "BATT_LOW_VOLT" => {
            default: 0.0, range: 0.0, 100.0, unit: "V",
            desc: "Battery low below this voltage (0: off)",
        },
        batt_crit_volt: f32 = "BATT_CRT_VOLT" => {
            default: 0.0, range: 0.0, 100.0, unit: "V",
            desc: "Battery critical below this voltage (0: off)",
        },
        batt_low_timer_s: f32 = "BATT_LOW_TIMER" => {
            default: 10.0, range: 0.0, 120.0, unit: "s",
            desc: "Voltage must stay below the threshold this long",
        },
        batt_low_action: i8 = "BATT_FS_LOW_ACT" => {
            default: 0, range: 0, 5, unit: "",
            desc: "Action on low battery",
        },
        batt_crit_action: i8 = "BATT_FS_CRT_ACT" => {
            default: 2, range: 0, 5, unit: "",
            desc: "Action on critical battery",
        },
    }
}

declare_params! {
    /// MAVLink 2 message signing (the key itself lives in the data directory).
    pub struct SigningParams {
        require: i8 = "SIGN_REQUIRE" => {
            default: 15, range: 0, 15, unit: "",
            desc: "Once a signing key is set, links of these stream slots act only on signed packets (bit n: slot n; secure links never require)",
        },
    }
}

/// `SRn_*`: default telemetry rates per link slot (Hz), one group per
/// ArduPilot stream (`SRn_POSITION`, `SRn_EXTRA1`, …).
#[derive(Clone, Copy, Debug)]
pub struct StreamRateParams {
    slots: [[Param<i16>; StreamGroup::COUNT]; StreamRateParams::SLOTS],
}

impl StreamRateParams {
    pub const SLOTS: usize = 4;

    pub fn register(builder: &mut ParamTableBuilder) -> Self {
        let slots = std::array::from_fn(|slot| {
            std::array::from_fn(|g| {
                let group = StreamGroup::ALL[g];
                let index = builder.add(ParamDef {
                    name: ParamName::new(format!("SR{slot}_{}", group.param_suffix()))
                        .expect("valid stream parameter name"),
                    ty: ParamType::Int16,
                    default: f64::from(group.default_rate_hz()),
                    min: 0.0,
                    max: 50.0,
                    unit: "Hz",
                    description: group.description(),
                    flags: ParamFlags::default(),
                });
                Param::from_index(index)
            })
        });
        StreamRateParams { slots }
    }

    /// The parameter holding the rate of `group` on links of `slot`.
    pub fn rate(&self, slot: u8, group: StreamGroup) -> Param<i16> {
        let slot = usize::from(slot).min(Self::SLOTS - 1);
        self.slots[slot][group as usize]
    }
}

/// All of the core's parameter handles.
#[derive(Clone, Copy, Debug)]
pub struct CoreParams {
    pub system: SystemParams,
    pub vehicle: VehicleParams,
    pub nav: NavParams,
    pub preview: PreviewParams,
    pub manoeuvre: ManoeuvreParams,
    pub mission: MissionParams,
    pub magnetic: MagneticParams,
    pub fence: FenceParams,
    pub geo: GeoParams,
    pub ekf: EkfParams,
    pub gnss_quality: GnssQualityParams,
    pub streams: StreamRateParams,
    pub obstacles: ObstacleParams,
    pub servos: ServoParams,
    pub failsafe: FailsafeParams,
    pub signing: SigningParams,
    pub logging: crate::logging::params::LogParams,
}

impl CoreParams {
    /// Declares every core parameter, in the table's order.
    pub fn register(builder: &mut ParamTableBuilder) -> Self {
        CoreParams {
            system: SystemParams::register(builder),
            vehicle: VehicleParams::register(builder),
            nav: NavParams::register(builder),
            preview: PreviewParams::register(builder),
            manoeuvre: ManoeuvreParams::register(builder),
            mission: MissionParams::register(builder),
            magnetic: MagneticParams::register(builder),
            fence: FenceParams::register(builder),
            geo: GeoParams::register(builder),
            ekf: EkfParams::register(builder),
            gnss_quality: GnssQualityParams::register(builder),
            streams: StreamRateParams::register(builder),
            obstacles: ObstacleParams::register(builder),
            servos: ServoParams::register(builder),
            failsafe: FailsafeParams::register(builder),
            signing: SigningParams::register(builder),
            logging: crate::logging::params::LogParams::register(builder),
        }
    }
}
