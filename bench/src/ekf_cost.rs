//! What one EKF operation costs, timed on the filter of a simulation that
//! has been driving (printed by `furrow-bench sitl`).

use std::hint::black_box;
use std::time::Instant;

use autopilot::estimation::ekf::Ekf;

/// Operations per figure: enough to average out a scheduler tick.
const OPERATIONS: u32 = 200_000;
/// The sigmas of an RTK receiver with a dual-antenna heading.
const GNSS_SIGMA_M: f64 = 0.011;
const VELOCITY_SIGMA_MPS: f64 = 0.02;
const HEADING_SIGMA_RAD: f64 = 0.05 * std::f64::consts::PI / 180.0;

/// An operation on the filter, with its label.
type Timed<'a> = (&'a str, &'a dyn Fn(&mut Ekf));

/// Prints ns per predict, per update and per status, each from a fresh
/// copy of `running`.
pub fn print(running: &Ekf) {
    let s = running.state();
    let (north_m, east_m) = (s.north_m + 0.5 * s.yaw_rad.cos(), s.east_m + 0.5 * s.yaw_rad.sin());
    let timed: [Timed; 5] = [
        ("predict(0.02 s)", &|e| {
            let _ = e.predict(black_box(0.02));
        }),
        ("update_gnss_position", &|e| {
            black_box(e.update_gnss_position(north_m, east_m, GNSS_SIGMA_M, GNSS_SIGMA_M));
        }),
        ("update_gnss_velocity", &|e| {
            black_box(e.update_gnss_velocity(1.0, Some(s.yaw_rad), VELOCITY_SIGMA_MPS));
        }),
        ("update_heading", &|e| {
            black_box(e.update_heading(s.yaw_rad, HEADING_SIGMA_RAD));
        }),
        ("status()", &|e| {
            black_box(e.status());
        }),
    ];
    println!("EKF cost per operation ({OPERATIONS} each, on the filter after the drive):");
    for (label, operation) in timed {
        let mut ekf = running.clone();
        let start = Instant::now();
        for _ in 0..OPERATIONS {
            operation(&mut ekf);
        }
        let ns = start.elapsed().as_nanos() as f64 / f64::from(OPERATIONS);
        println!("  {label}: {ns:.0} ns");
    }
}
