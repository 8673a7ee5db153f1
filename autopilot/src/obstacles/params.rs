//! Obstacle parameters: the scanners' mounts (`SCANn_*`), the vehicle's
//! outline (`VEH_LEN_*`, `VEH_WIDTH`) and the avoidance policy (`OA_*`).
//! ArduPilot has `OA_TYPE` for its path planners; here 0 is "stop only" and
//! 1 the tangent-bug detour of seed 004 §III.D.
//!
//! Sources: docs/references.md §Seed 004.

use params::declare_params;

declare_params! {
    /// The vehicle's outline about its reference point (rear axle centre).
    pub struct FootprintParams {
        front_m: f32 = "VEH_LEN_FRONT" => {
            default: 3.6, range: 0.0, 30.0, unit: "m",
            desc: "Distance from the reference point (rear axle centre) forward to the front bumper",
        },
        rear_m: f32 = "VEH_LEN_REAR" => {
            default: 0.8, range: 0.0, 30.0, unit: "m",
            desc: "Distance from the reference point backward to the rear bumper",
        },
        width_m: f32 = "VEH_WIDTH" => {
            default: 2.0, range: 0.1, 10.0, unit: "m",
            desc: "Overall width of the vehicle (body or load, whichever is wider)",
        },
    }
}

declare_params! {
    /// Where the laser scanners sit (body frame from the reference point).
    pub struct ScannerParams {
        scan1_enable: bool = "SCAN1_ENABLE" => {
            default: 1, range: 0, 1, unit: "",
            desc: "Scanner 1 (front) fitted",
        },
        scan1_x_m: f32 = "SCAN1_POS_X" => {
            default: 3.6, range: -30.0, 30.0, unit: "m",
            desc: "Scanner 1 position forward of the reference point",
        },
        scan1_y_m: f32 = "SCAN1_POS_Y" => {
            default: 0.0, range: -10.0, 10.0, unit: "m",
            desc: "Scanner 1 position right of the reference point",
        },
        scan1_yaw_deg: f32 = "SCAN1_YAW" => {
            default: 0.0, range: -180.0, 180.0, unit: "deg",
            desc: "Scanner 1 forward axis, clockwise from the vehicle's",
        },
        scan2_enable: bool = "SCAN2_ENABLE" => {
            default: 1, range: 0, 1, unit: "",
            desc: "Scanner 2 (rear) fitted",
        },
        scan2_x_m: f32 = "SCAN2_POS_X" => {
            default: -0.8, range: -30.0, 30.0, unit: "m",
            desc: "Scanner 2 position forward of the reference point",
        },
        scan2_y_m: f32 = "SCAN2_POS_Y" => {
            default: 0.0, range: -10.0, 10.0, unit: "m",
            desc: "Scanner 2 position right of the reference point",
        },
        scan2_yaw_deg: f32 = "SCAN2_YAW" => {
            default: 180.0, range: -180.0, 180.0, unit: "deg",
            desc: "Scanner 2 forward axis, clockwise from the vehicle's",
        },
        max_range_m: f32 = "SCAN_RANGE_MAX" => {
            default: 20.0, range: 1.0, 80.0, unit: "m",
            desc: "Returns beyond this range are ignored",
        },
    }
}

declare_params! {
    /// Obstacle avoidance (docs/architecture.md §Obstacles).
    pub struct AvoidanceParams {
        enable: bool = "OA_ENABLE" => {
            default: 1, range: 0, 1, unit: "",
            desc: "Stop for obstacles seen by the scanners in AUTO, GUIDED, RTL and MAGNETIC (needs live scans to move)",
        },
        kind: i8 = "OA_TYPE" => {
            default: 0, range: 0, 1, unit: "",
            desc: "Static obstacle on the path: 0 stop and wait, 1 tangent-bug detour within OA_CORRIDOR",
        },
        corridor_m: f32 = "OA_CORRIDOR" => {
            default: 3.0, range: 0.0, 50.0, unit: "m",
            desc: "How far a detour may leave the planned line",
        },
        detour_wait_s: f32 = "OA_DETOUR_WAIT" => {
            default: 1.0, range: 0.0, 60.0, unit: "s",
            desc: "A stop for a static obstacle lasts this long before a detour is planned",
        },
        stop_cycles: i8 = "OA_STOP_CYCLES" => {
            default: 3, range: 0, 50, unit: "",
            desc: "Stop/go cycles for one object (a stop within 5 s of resuming from one) before the vehicle waits for a clear way (OA_TYPE 1: plans a detour); 0 never",
        },
        resume_s: f32 = "OA_RESUME_S" => {
            default: 2.0, range: 0.0, 60.0, unit: "s",
            desc: "The way must be clear this long before driving on after an obstacle stop",
        },
        auto_resume: bool = "OA_RESUME" => {
            default: 1, range: 0, 1, unit: "",
            desc: "After an obstacle stop: 1 drive on by itself once clear, 0 wait for the GCS (MAV_CMD_DO_PAUSE_CONTINUE)",
        },
        pass_first: bool = "OA_PASS" => {
            default: 0, range: 0, 1, unit: "",
            desc: "Pass-first rule (Pratama et al.): speed up past a crossing obstacle when there is time",
        },
        pass_speed_mps: f32 = "OA_PASS_SPEED" => {
            default: 3.0, range: 0.1, 10.0, unit: "m/s",
            desc: "The speed OA_PASS may accelerate to, to pass before a crossing obstacle",
        },
        margin_m: f32 = "OA_MARGIN" => {
            default: 0.3, range: 0.0, 5.0, unit: "m",
            desc: "Safe distance kept from predicted obstacle paths",
        },
        horizon_s: f32 = "OA_HORIZON" => {
            default: 3.0, range: 0.0, 30.0, unit: "s",
            desc: "A collision predicted sooner than this stops the vehicle",
        },
        decel_mps2: f32 = "OA_DECEL" => {
            default: 1.0, range: 0.1, 10.0, unit: "m/s/s",
            desc: "Braking deceleration assumed when sizing the protective field",
        },
        reaction_s: f32 = "OA_REACT_TIME" => {
            default: 0.15, range: 0.0, 2.0, unit: "s",
            desc: "Scan period, processing and actuator delay in the protective field's length",
        },
        field_margin_m: f32 = "OA_FIELD_MARGIN" => {
            default: 0.1, range: 0.0, 2.0, unit: "m",
            desc: "Supplement added to the protective field's length (Z_G)",
        },
        field_side_m: f32 = "OA_FIELD_SIDE" => {
            default: 0.15, range: 0.0, 2.0, unit: "m",
            desc: "Protective and warning fields reach this far beyond each side of the vehicle",
        },
        warning_s: f32 = "OA_WARN_TIME" => {
            default: 2.0, range: 0.0, 20.0, unit: "s",
            desc: "The warning field (slow down) reaches this much travel beyond the protective field",
        },
        scan_timeout_s: f32 = "OA_SCAN_TMO" => {
            default: 0.2, range: 0.02, 5.0, unit: "s",
            desc: "A scan older than this while moving stops the vehicle",
        },
        track_accel: f32 = "OA_TRK_ACC" => {
            default: 1.5, range: 0.01, 50.0, unit: "m2/s3",
            desc: "Obstacle tracker process noise: white-acceleration spectral density",
        },
        velocity_gate_mps: f32 = "OA_TRK_VEL_SD" => {
            default: 0.5, range: 0.01, 10.0, unit: "m/s",
            desc: "A track's velocity is used for collision prediction once its 1-sigma is below this, or after 1 s tracked, seen in the latest scan and 10 since it last coasted, while its speed is over twice that sigma (before: taken as standing)",
        },
        range_sigma_m: f32 = "OA_TRK_RNG_SD" => {
            default: 0.02, range: 0.001, 1.0, unit: "m",
            desc: "Scanner range noise (1 sigma) for the tracker's measurement covariance",
        },
        bearing_sigma_deg: f32 = "OA_TRK_BRG_SD" => {
            default: 0.3, range: 0.01, 10.0, unit: "deg",
            desc: "Scanner bearing noise (1 sigma) for the tracker's measurement covariance",
        },
    }
}

/// The handles of every obstacle parameter.
#[derive(Clone, Copy, Debug)]
pub struct ObstacleParams {
    pub footprint: FootprintParams,
    pub scanners: ScannerParams,
    pub avoidance: AvoidanceParams,
}

impl ObstacleParams {
    pub fn register(builder: &mut params::ParamTableBuilder) -> Self {
        ObstacleParams {
            footprint: FootprintParams::register(builder),
            scanners: ScannerParams::register(builder),
            avoidance: AvoidanceParams::register(builder),
        }
    }
}
