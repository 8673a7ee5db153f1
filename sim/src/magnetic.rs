//! Magnetic guide tape on the ground and the two 16-probe sensors under the
//! vehicle that read it (seed 002 §2, §4.2; docs/architecture.md §Kinematics and the magnetic guide).
//!
//! The tape is a chain of straight and circular segments in the home NED
//! frame. Each sensor is a row of 16 probes across the vehicle (along body y)
//! at a body x offset from the reference point (the rear axle centre). A probe
//! triggers when it is within half the tape width plus a detection margin of
//! the tape's centreline: the 30 mm tape over 10 mm probes triggers 3–4
//! adjacent probes (3–5 with edge noise), as the seed reports.
//!
//! Probe numbering follows seed 002 §4.2: a vehicle deviated to the left sees
//! the tape under its right-hand probes and reads `num` < 17, so the numbers
//! run from right to left. Probe `i` (1-based) is bit `i − 1` of the mask;
//! probe 1 is the rightmost (body +y), probe 16 the leftmost. A sensor mounted
//! the other way round reads `mask.reverse_bits()`.
//!
//! Placement: on an arc of radius R, points of the vehicle at body x sit
//! x²/(2R) further out than the rear axle centre, so two sensors can both be
//! centred on a curved tape only if they are symmetric about the rear axle
//! (x_rear = −x_front). With a ±75 mm sensor range this is not a detail: a
//! sensor 3 m ahead of the rear axle is 0.3 m off a 15 m arc. The defaults
//! are therefore ±1 m.
//!
//! Sources: docs/references.md §Seed 002.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::VehicleTruth;
use super::seed::splitmix_finalise;

/// Probes per sensor.
pub const MAGNETIC_PROBES: usize = 16;

/// One piece of tape centreline. Points are (north, east) in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TapeSegment {
    Line {
        start_m: (f64, f64),
        end_m: (f64, f64),
    },
    /// Points `centre + radius·(cos β, sin β)` for bearings β from
    /// `start_bearing_rad` over `sweep_rad`; a positive sweep is clockwise
    /// (seen from above), i.e. the tape turns right.
    Arc {
        centre_m: (f64, f64),
        radius_m: f64,
        start_bearing_rad: f64,
        sweep_rad: f64,
    },
}

/// Where a point is relative to the tape: the nearest point of the centreline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapeFix {
    /// Signed offset of the point from the centreline, perpendicular to the
    /// tape there: positive = the point is to the right of the tape (looking
    /// along the tape's direction).
    pub offset_m: f64,
    /// Euclidean distance to the centreline (= |offset| except past its ends).
    pub distance_m: f64,
    /// The tape's direction at the nearest point, 0 = north, clockwise.
    pub heading_rad: f64,
    /// Signed curvature there: positive = turning right.
    pub curvature_1pm: f64,
    /// Arc length from the start of the tape to the nearest point.
    pub along_m: f64,
}

/// A magnetic tape laid on the ground.
#[derive(Clone, Debug, PartialEq)]
pub struct MagneticTape {
    width_m: f64,
    segments: Vec<TapeSegment>,
}

impl MagneticTape {
    /// Common guide tape width.
    pub const DEFAULT_WIDTH_M: f64 = 0.030;

    /// Tape from explicit segments. A non-finite or negative width counts as 0.
    pub fn from_segments(segments: Vec<TapeSegment>, width_m: f64) -> Self {
        let width_m = if width_m.is_finite() { width_m.max(0.0) } else { 0.0 };
        Self { width_m, segments }
    }

    /// Straight tape through `points` (north, east); repeated points are skipped.
    pub fn polyline(points: &[(f64, f64)], width_m: f64) -> Self {
        let segments = points
            .windows(2)
            .filter(|w| w[0] != w[1])
            .map(|w| TapeSegment::Line {
                start_m: w[0],
                end_m: w[1],
            })
            .collect();
        Self::from_segments(segments, width_m)
    }

    pub fn width_m(&self) -> f64 {
        self.width_m
    }

    pub fn segments(&self) -> &[TapeSegment] {
        &self.segments
    }

    pub fn length_m(&self) -> f64 {
        self.segments.iter().map(segment_length_m).sum()
    }

    /// The nearest point of the centreline to (`north_m`, `east_m`); `None`
    /// for a tape without segments.
    pub fn locate(&self, north_m: f64, east_m: f64) -> Option<TapeFix> {
        let mut along_m = 0.0;
        let mut best: Option<TapeFix> = None;
        for segment in &self.segments {
            let fix = locate_on_segment(segment, (north_m, east_m), along_m);
            if best.is_none_or(|b| fix.distance_m < b.distance_m) {
                best = Some(fix);
            }
            along_m += segment_length_m(segment);
        }
        best
    }

    /// Distance from the centreline; infinite for a tape without segments.
    pub fn distance_m(&self, north_m: f64, east_m: f64) -> f64 {
        self.segments
            .iter()
            .map(|s| locate_on_segment(s, (north_m, east_m), 0.0).distance_m)
            .fold(f64::INFINITY, f64::min)
    }
}

/// Lays tape the way one would on the floor: from a start pose, straight runs
/// and arcs, each continuing from where the last one ended.
#[derive(Clone, Debug, PartialEq)]
pub struct TapeBuilder {
    segments: Vec<TapeSegment>,
    north_m: f64,
    east_m: f64,
    heading_rad: f64,
}

impl TapeBuilder {
    /// Start at (`north_m`, `east_m`) heading `heading_rad` (0 = north, clockwise).
    pub fn new(north_m: f64, east_m: f64, heading_rad: f64) -> Self {
        Self {
            segments: Vec::new(),
            north_m,
            east_m,
            heading_rad,
        }
    }

    /// The current end of the tape: (north, east, heading).
    pub fn pose(&self) -> (f64, f64, f64) {
        (self.north_m, self.east_m, self.heading_rad)
    }

    /// A straight run; non-positive lengths add nothing.
    pub fn line(mut self, length_m: f64) -> Self {
        if length_m > 0.0 {
            let (sin, cos) = self.heading_rad.sin_cos();
            let end_m = (self.north_m + length_m * cos, self.east_m + length_m * sin);
            self.segments.push(TapeSegment::Line {
                start_m: (self.north_m, self.east_m),
                end_m,
            });
            (self.north_m, self.east_m) = end_m;
        }
        self
    }

    /// An arc of `radius_m` turning the tape by `turn_rad` (positive = right).
    /// A zero turn or a non-positive radius adds nothing.
    pub fn arc(mut self, radius_m: f64, turn_rad: f64) -> Self {
        if !(radius_m > 0.0 && turn_rad != 0.0 && turn_rad.is_finite()) {
            return self;
        }
        // The centre is on the side the tape turns to; the bearing from the
        // centre to the tape is the heading ∓ 90°.
        let side = turn_rad.signum();
        let to_centre = self.heading_rad + side * FRAC_PI_2;
        let centre_m = (
            self.north_m + radius_m * to_centre.cos(),
            self.east_m + radius_m * to_centre.sin(),
        );
        let start_bearing_rad = to_centre + PI;
        self.segments.push(TapeSegment::Arc {
            centre_m,
            radius_m,
            start_bearing_rad,
            sweep_rad: turn_rad,
        });
        let end_bearing = start_bearing_rad + turn_rad;
        self.north_m = centre_m.0 + radius_m * end_bearing.cos();
        self.east_m = centre_m.1 + radius_m * end_bearing.sin();
        self.heading_rad += turn_rad;
        self
    }

    pub fn build(self, width_m: f64) -> MagneticTape {
        MagneticTape::from_segments(self.segments, width_m)
    }
}

fn segment_length_m(segment: &TapeSegment) -> f64 {
    match *segment {
        TapeSegment::Line { start_m, end_m } => (end_m.0 - start_m.0).hypot(end_m.1 - start_m.1),
        TapeSegment::Arc {
            radius_m, sweep_rad, ..
        } => radius_m.abs() * sweep_rad.abs(),
    }
}

/// Offset of `p` from a tape point with direction `heading_rad`: the right
/// component, and the distance.
fn offset_from(point_m: (f64, f64), p: (f64, f64), heading_rad: f64) -> (f64, f64) {
    let (dn, de) = (p.0 - point_m.0, p.1 - point_m.1);
    let (sin, cos) = heading_rad.sin_cos();
    // Body y for a heading is (−sin, cos) in (north, east).
    (-dn * sin + de * cos, dn.hypot(de))
}

fn locate_on_segment(segment: &TapeSegment, p: (f64, f64), along_before_m: f64) -> TapeFix {
    match *segment {
        TapeSegment::Line { start_m, end_m } => {
            let (ln, le) = (end_m.0 - start_m.0, end_m.1 - start_m.1);
            let length_m = ln.hypot(le);
            let heading_rad = le.atan2(ln);
            let t_m = if length_m > 0.0 {
                (((p.0 - start_m.0) * ln + (p.1 - start_m.1) * le) / length_m).clamp(0.0, length_m)
            } else {
                0.0
            };
            let (sin, cos) = heading_rad.sin_cos();
            let nearest = (start_m.0 + t_m * cos, start_m.1 + t_m * sin);
            let (offset_m, distance_m) = offset_from(nearest, p, heading_rad);
            TapeFix {
                offset_m,
                distance_m,
                heading_rad,
                curvature_1pm: 0.0,
                along_m: along_before_m + t_m,
            }
        }
        TapeSegment::Arc {
            centre_m,
            radius_m,
            start_bearing_rad,
            sweep_rad,
        } => {
            let radius_m = radius_m.abs();
            let dir = if sweep_rad >= 0.0 { 1.0 } else { -1.0 };
            let (dn, de) = (p.0 - centre_m.0, p.1 - centre_m.1);
            // How far round the arc, in its own direction, p's bearing lies.
            let into_rad = (dir * (de.atan2(dn) - start_bearing_rad)).rem_euclid(TAU);
            let reach_rad = sweep_rad.abs();
            let into_rad = if into_rad <= reach_rad {
                into_rad
            } else {
                // Past one end: the nearer end point, measured round the gap.
                let past_end = into_rad - reach_rad;
                let before_start = TAU - into_rad;
                if past_end < before_start { reach_rad } else { 0.0 }
            };
            let bearing = start_bearing_rad + dir * into_rad;
            let nearest = (
                centre_m.0 + radius_m * bearing.cos(),
                centre_m.1 + radius_m * bearing.sin(),
            );
            let heading_rad = bearing + dir * FRAC_PI_2;
            let (offset_m, distance_m) = offset_from(nearest, p, heading_rad);
            TapeFix {
                offset_m,
                distance_m,
                heading_rad: wrap_pi(heading_rad),
                curvature_1pm: dir / radius_m,
                along_m: along_before_m + radius_m * into_rad,
            }
        }
    }
}

fn wrap_pi(angle_rad: f64) -> f64 {
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// Which of the two sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MagneticSensor {
    Front,
    Rear,
}

/// The two 16-probe sensors under the vehicle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagneticSensorConfig {
    /// Body x of the front sensor's centre from the reference point (the
    /// rear axle centre); the sensor spacing d is `front_x_m − rear_x_m`.
    pub front_x_m: f64,
    pub rear_x_m: f64,
    /// Distance between adjacent probes.
    pub probe_pitch_m: f64,
    /// How far beyond the tape's edge a probe still triggers (the field
    /// spreads past the tape).
    pub detect_margin_m: f64,
    /// σ of each probe's trigger threshold, drawn afresh for every reading:
    /// the edge probes flicker. 0 = noiseless.
    pub edge_noise_m: f64,
}

impl Default for MagneticSensorConfig {
    fn default() -> Self {
        Self {
            front_x_m: 1.0,
            rear_x_m: -1.0,
            probe_pitch_m: 0.010,
            // 15 + 2.5 mm is an odd multiple of a quarter pitch, so probes
            // enter and leave at different tape positions: 3 or 4 probes and a
            // reading that moves in 5 mm steps. 15 mm exactly would move in
            // 10 mm steps (one probe in, one out at the same position).
            detect_margin_m: 0.0025,
            edge_noise_m: 0.0,
        }
    }
}

impl MagneticSensorConfig {
    pub fn sensor_x_m(&self, sensor: MagneticSensor) -> f64 {
        match sensor {
            MagneticSensor::Front => self.front_x_m,
            MagneticSensor::Rear => self.rear_x_m,
        }
    }

    /// Body y of probe `probe` (1..=16): probe 1 is the rightmost.
    pub fn probe_y_m(&self, probe: usize) -> f64 {
        ((MAGNETIC_PROBES as f64 + 1.0) / 2.0 - probe as f64) * self.probe_pitch_m
    }

    /// (north, east) of the body point (`x_m`, `y_m`) for the vehicle at `truth`.
    pub fn body_to_local(truth: &VehicleTruth, x_m: f64, y_m: f64) -> (f64, f64) {
        let (sin, cos) = truth.yaw_rad.sin_cos();
        (
            truth.north_m + x_m * cos - y_m * sin,
            truth.east_m + x_m * sin + y_m * cos,
        )
    }

    /// (north, east) of a sensor's centre.
    pub fn sensor_point(&self, truth: &VehicleTruth, sensor: MagneticSensor) -> (f64, f64) {
        Self::body_to_local(truth, self.sensor_x_m(sensor), 0.0)
    }

    /// The noiseless reading of one sensor: bit i−1 set when probe i sees the tape.
    pub fn read(&self, tape: &MagneticTape, truth: &VehicleTruth, sensor: MagneticSensor) -> u16 {
        self.read_with(tape, truth, sensor, None)
    }

    pub(crate) fn read_with(
        &self,
        tape: &MagneticTape,
        truth: &VehicleTruth,
        sensor: MagneticSensor,
        mut rng: Option<&mut ChaCha8Rng>,
    ) -> u16 {
        let x_m = self.sensor_x_m(sensor);
        let half_m = tape.width_m() / 2.0 + self.detect_margin_m;
        let mut mask = 0u16;
        for probe in 1..=MAGNETIC_PROBES {
            let (n, e) = Self::body_to_local(truth, x_m, self.probe_y_m(probe));
            let jitter_m = match rng.as_deref_mut() {
                Some(rng) => self.edge_noise_m * rng.sample::<f64, _>(StandardNormal),
                None => 0.0,
            };
            if tape.distance_m(n, e) <= half_m + jitter_m {
                mask |= 1 << (probe - 1);
            }
        }
        mask
    }

    /// Both readings (front, rear). With edge noise, the draws depend only on
    /// `seed` and `time_ns`, so reading twice at one instant gives the same
    /// answer and reading at all does not disturb anything else.
    pub(crate) fn read_both(&self, tape: &MagneticTape, truth: &VehicleTruth, seed: u64, time_ns: u128) -> (u16, u16) {
        let noisy = self.edge_noise_m.is_finite() && self.edge_noise_m > 0.0;
        let mut rng = noisy.then(|| ChaCha8Rng::seed_from_u64(mix(seed, time_ns)));
        let front = self.read_with(tape, truth, MagneticSensor::Front, rng.as_mut());
        let rear = self.read_with(tape, truth, MagneticSensor::Rear, rng.as_mut());
        (front, rear)
    }
}

/// SplitMix64 finaliser over the seed (tagged, so this stream is not the
/// GNSS receiver's) and the instant.
fn mix(seed: u64, time_ns: u128) -> u64 {
    splitmix_finalise(seed ^ 0x4d41_474e_4554_4943 ^ (time_ns as u64) ^ ((time_ns >> 64) as u64).rotate_left(17))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::super::{ActuatorDemand, GnssSimConfig, World, WorldConfig};
    use super::*;

    fn pose(north_m: f64, east_m: f64, yaw_deg: f64) -> VehicleTruth {
        VehicleTruth {
            north_m,
            east_m,
            yaw_rad: yaw_deg.to_radians(),
            ..VehicleTruth::default()
        }
    }

    /// Seed 002's `num`: twice the mean index of the triggered probes.
    fn num(mask: u16) -> f64 {
        let probes: Vec<u32> = (0..16).filter(|b| mask & (1 << b) != 0).map(|b| b + 1).collect();
        2.0 * f64::from(probes.iter().sum::<u32>()) / probes.len() as f64
    }

    fn north_tape() -> MagneticTape {
        MagneticTape::polyline(&[(-50.0, 0.0), (50.0, 0.0)], MagneticTape::DEFAULT_WIDTH_M)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn builder_lays_lines_and_arcs_end_to_end() {
        let b = TapeBuilder::new(0.0, 0.0, 0.0).line(5.0).arc(10.0, FRAC_PI_2);
        let (n, e, h) = b.pose();
        assert!(close(n, 15.0) && close(e, 10.0) && close(h, FRAC_PI_2), "{n} {e} {h}");
        let b = b.arc(4.0, -PI);
        let (n, e, h) = b.pose();
        assert!(close(n, 23.0) && close(e, 10.0) && close(h, -FRAC_PI_2), "{n} {e} {h}");
        let tape = b.build(0.03);
        assert!(close(tape.length_m(), 5.0 + 10.0 * FRAC_PI_2 + 4.0 * PI));
        // Every join is on the tape.
        for (n, e) in [(5.0, 0.0), (15.0, 10.0), (23.0, 10.0)] {
            assert!(tape.distance_m(n, e) < 1e-9);
        }
    }

    #[test]
    fn offsets_are_positive_to_the_right_of_the_tape() {
        let fix = north_tape().locate(3.0, 0.2).unwrap();
        assert!(close(fix.offset_m, 0.2) && close(fix.heading_rad, 0.0) && close(fix.along_m, 53.0));
        // Right-turning arc about (0, 10): the centre side is the right.
        let right = TapeBuilder::new(0.0, 0.0, 0.0).arc(10.0, PI).build(0.03);
        let fix = right.locate(0.0, 0.5).unwrap();
        assert!(close(fix.offset_m, 0.5) && close(fix.curvature_1pm, 0.1), "{fix:?}");
        let fix = right.locate(10.3, 10.0).unwrap();
        assert!(
            close(fix.offset_m, -0.3) && close(fix.heading_rad, FRAC_PI_2),
            "{fix:?}"
        );
        // Left-turning arc about (0, −10): the centre side is the left.
        let left = TapeBuilder::new(0.0, 0.0, 0.0).arc(10.0, -PI).build(0.03);
        let fix = left.locate(10.3, -10.0).unwrap();
        assert!(
            close(fix.offset_m, 0.3) && close(fix.heading_rad, -FRAC_PI_2),
            "{fix:?}"
        );
        // Past the end of an arc: the end point is nearest.
        let fix = right.locate(-1.0, 20.0).unwrap();
        assert!(close(fix.distance_m, 1.0) && close(fix.along_m, 10.0 * PI), "{fix:?}");
        assert!(MagneticTape::polyline(&[], 0.03).locate(0.0, 0.0).is_none());
    }

    #[test]
    fn probes_count_from_the_right() {
        let cfg = MagneticSensorConfig::default();
        assert!(close(cfg.probe_y_m(1), 0.075) && close(cfg.probe_y_m(16), -0.075));
        let tape = north_tape();
        // Vehicle 20 mm left of the tape: the tape is under its right-hand
        // probes and num < 17 (seed 002 §4.2, "deviated left").
        let mask = cfg.read(&tape, &pose(0.0, -0.02, 0.0), MagneticSensor::Front);
        assert!(num(mask) < 17.0, "{mask:016b}");
        let mask = cfg.read(&tape, &pose(0.0, 0.02, 0.0), MagneticSensor::Front);
        assert!(num(mask) > 17.0, "{mask:016b}");
        // Yawed right on the tape: front reads > 17, rear < 17 ("车体右偏").
        let truth = pose(0.0, 0.0, 2.0);
        assert!(num(cfg.read(&tape, &truth, MagneticSensor::Front)) > 17.0);
        assert!(num(cfg.read(&tape, &truth, MagneticSensor::Rear)) < 17.0);
    }

    #[test]
    fn three_or_four_adjacent_probes_and_a_reading_in_half_pitch_steps() {
        let cfg = MagneticSensorConfig::default();
        let tape = north_tape();
        // While the triggered probes are all on the sensor: ±(75 − 17.5) mm.
        for k in -575..=575 {
            let offset_m = f64::from(k) * 1e-4;
            let mask = cfg.read(&tape, &pose(0.0, -offset_m, 0.0), MagneticSensor::Front);
            let count = mask.count_ones();
            assert!((3..=4).contains(&count), "{offset_m}: {mask:016b}");
            assert_eq!(mask >> mask.trailing_zeros(), (1 << count) - 1, "adjacent");
            // (17 − num)·pitch/2 is the tape's offset to the right, to ±2.5 mm.
            let sensed_m = (17.0 - num(mask)) * cfg.probe_pitch_m / 2.0;
            assert!((sensed_m - offset_m).abs() <= 0.0025 + 1e-9, "{offset_m}: {sensed_m}");
        }
        // Beyond it the reading sticks at the edge, then the tape is lost.
        let edge = cfg.read(&tape, &pose(0.0, 0.08, 0.0), MagneticSensor::Front);
        assert_eq!(edge, 0b11 << 14, "{edge:016b}");
        assert_eq!(cfg.read(&tape, &pose(0.0, 0.095, 0.0), MagneticSensor::Front), 0);
        assert_eq!(cfg.read(&tape, &pose(0.0, 0.2, 0.0), MagneticSensor::Front), 0);
        assert_eq!(cfg.read(&tape, &pose(0.0, -0.1, 0.0), MagneticSensor::Rear), 0);
    }

    #[test]
    fn edge_noise_flickers_the_edges_only() {
        let cfg = MagneticSensorConfig {
            edge_noise_m: 0.002,
            ..MagneticSensorConfig::default()
        };
        let tape = north_tape();
        let truth = pose(0.0, 0.013, 0.0);
        let mut counts = [0usize; 17];
        for t in 0..2000u128 {
            let (front, _) = cfg.read_both(&tape, &truth, 7, t * 20_000_000);
            counts[front.count_ones() as usize] += 1;
            for probe in 1..=MAGNETIC_PROBES {
                let distance_m = (cfg.probe_y_m(probe) + 0.013).abs();
                let on = front & (1 << (probe - 1)) != 0;
                // 5σ either side of the 17.5 mm threshold.
                assert!(on || distance_m > 0.0075, "{front:016b}");
                assert!(!on || distance_m < 0.0275, "{front:016b}");
            }
        }
        assert!(counts[3] > 100 && counts[4] > 100 && counts[5] > 0, "{counts:?}");
    }

    fn quiet_world(magnetic: MagneticSensorConfig) -> World {
        let config = WorldConfig {
            gnss: GnssSimConfig {
                enabled: false,
                ..GnssSimConfig::default()
            },
            magnetic,
            ..WorldConfig::default()
        };
        World::new(config, 3)
    }

    #[test]
    fn world_reads_the_tape_at_the_true_pose_and_stays_deterministic() {
        let noisy = MagneticSensorConfig {
            edge_noise_m: 0.002,
            ..MagneticSensorConfig::default()
        };
        let mut a = quiet_world(noisy);
        assert_eq!(a.magnetic_sensors(), None);
        let mut b = a.clone();
        let mut plain = quiet_world(noisy);
        let tape = north_tape();
        a.set_tape(Some(tape.clone()));
        b.set_tape(Some(tape));
        let demand = ActuatorDemand::Ackermann {
            steering: 0.0,
            throttle: 0.3,
        };
        for _ in 0..200 {
            for w in [&mut a, &mut b, &mut plain] {
                w.step(Duration::from_millis(20), &demand);
            }
            let reading = a.magnetic_sensors().unwrap();
            assert_eq!(Some(reading), a.magnetic_sensors(), "reading twice");
            assert_eq!(Some(reading), b.magnetic_sensors(), "same seed");
            assert!(reading.0.count_ones() >= 2 && reading.1.count_ones() >= 2);
        }
        // The tape changes nothing else.
        assert_eq!(a.truth(), plain.truth());
        assert_eq!(a.battery(), plain.battery());
        a.set_tape(None);
        assert_eq!(a.magnetic_sensors(), None);
    }
}
