//! Controller defaults that depend on the drive train, applied on top of
//! the declared defaults (like ArduPilot's per-frame defaults files) by
//! every place that builds a parameter table for a vehicle: SITL's and a
//! real vehicle's.

use params::ParamTableBuilder;

use super::mixer::DriveTrain;

/// Speed demand ramp of a skid-steer vehicle, as a share of what its
/// drive can do (`ATC_ACCEL_MAX`, m/s²).
///
/// A skid-steer vehicle turns by speeding one side up against the other.
/// When the speed demand ramps at the wheels' own acceleration limit, the
/// side that must speed up to correct the heading is already at its limit,
/// and out of a corner (slow on the arc, accelerating onto the straight)
/// the turn cannot be taken out in time: measured on the bench course with
/// 1 m/s² at the wheels, the vehicle ran 30–60 mm wide after every corner
/// at 1 m/s², under 12 mm at 0.5.
const DIFFERENTIAL_ACCEL_MPS2: f64 = 0.5;
/// Braking stays at the drive's usual figure: it is planned at 80 % of it,
/// and the wheels brake harder than they accelerate.
const DIFFERENTIAL_DECEL_MPS2: f64 = 1.0;
/// Feed-forward lead where a skid-steer vehicle takes a turn out
/// (`PVW_FF_EXIT`, s): it unwinds a turn by speeding its inner wheels up
/// while the whole vehicle speeds up out of the corner, which lags more
/// than winding one in. Measured on the bench courses (`furrow-bench
/// tracking --param PVW_FF_EXIT=…`): the first 3 m after a corner ran
/// 16–19 mm wide (p99) at the turn-in lead of 0.12 s, 10–12 mm at 0.2 s,
/// and wider again from 0.3 s.
const DIFFERENTIAL_FF_EXIT_S: f64 = 0.2;

/// Overrides the declared defaults for `drive`.
pub fn apply(builder: &mut ParamTableBuilder, drive: DriveTrain) {
    match drive {
        DriveTrain::Ackermann => {}
        DriveTrain::Differential => {
            builder.override_default("VEH_DRIVE", 1.0);
            // No steering gear: the "steering angle" is a curvature, and
            // the wheels' speed difference follows it as fast as they
            // follow speed. A rate limit here only delays taking a turn
            // out at a corner's end.
            builder.override_default("VEH_STEER_RATE", 0.0);
            builder.override_default("ATC_ACCEL_MAX", DIFFERENTIAL_ACCEL_MPS2);
            builder.override_default("ATC_DECEL_MAX", DIFFERENTIAL_DECEL_MPS2);
            builder.override_default("PVW_FF_EXIT", DIFFERENTIAL_FF_EXIT_S);
            // Two driven wheels turn it on the spot: manoeuvres may.
            builder.override_default("MNV_PIVOT", 1.0);
        }
    }
}
