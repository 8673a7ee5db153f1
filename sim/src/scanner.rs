//! A simulated SICK LMS1xx laser scanner: ray-casts the world's obstacles
//! from where the scanner sits on the vehicle (docs/architecture.md §Obstacles).
//!
//! Beam `i` looks `−fov/2 + i·step` clockwise from the scanner's forward
//! axis, so a scan's `start_angle_rad` is `−fov/2` and its `step_rad` is
//! `+step` (the [`Scan`] convention). A beam that sees nothing within
//! `max_range_m`, or drops out, reads NaN.
//!
//! Scanner to world. Seed 004 eq. 1–2 writes a return as
//! `O = (d cos θ, d sin θ)` with θ from the scanner's horizontal x axis over
//! its 0°…180° field, then `A + R(γ)·O + D·(cos γ, sin γ)`. Two corrections:
//! with θ counted from that x axis, straight ahead is θ = 90°, so the
//! rotation must be by γ − 90°, not γ (as printed, a return dead ahead lands
//! to the vehicle's side); and an offset D along the heading alone cannot
//! place a scanner off the centre line or facing backwards (the AGV's rear
//! scanner). The general form, used here, with θ clockwise from the scanner's
//! forward axis, the vehicle at `p` with yaw ψ and the scanner mounted at
//! body `m` with yaw ψₘ:
//!
//! `world = p + R(ψ)·(m + R(ψₘ)·(d cos θ, d sin θ))`,
//! `R(a) = [[cos a, −sin a], [sin a, cos a]]`
//!
//! on (north, east) and (x forward, y right) alike: both pairs are
//! right-handed in the same sense, so a beam's world bearing is ψ + ψₘ + θ.
//!
//! Sources: docs/references.md §Seed 004.

use std::f64::consts::{PI, TAU};
use std::fmt;
use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::VehicleTruth;
use super::obstacles::{
    FacingOutline, ObstacleWorld, point_segment_distance, ray_circle_m, ray_segment_m, wrap_two_pi,
};
use super::seed::splitmix_finalise;
use drivers::scanner::Scan;

/// A mistyped step must not allocate millions of beams.
pub const MAX_BEAMS: usize = 4096;
/// No LMS1xx scans faster; a mistyped rate must not flood the scan queue.
const MAX_RATE_HZ: f64 = 100.0;
/// The rates an LMS1xx offers.
const LMS1XX_RATES_HZ: [f64; 2] = [25.0, 50.0];
/// Beams looked at together for an echo when a scan is measured.
const BEAM_BLOCK: usize = 8;

/// One simulated scanner.
#[derive(Clone, Debug, PartialEq)]
pub struct SimScannerConfig {
    pub enabled: bool,
    /// Body frame (x forward, y right) position from the reference point
    /// (the rear axle centre).
    pub mount_x_m: f64,
    pub mount_y_m: f64,
    /// The scanner's forward axis, clockwise from the vehicle's (π = facing backwards).
    pub mount_yaw_rad: f64,
    /// Field of view, centred on the forward axis.
    pub fov_rad: f64,
    /// Angle between beams.
    pub step_rad: f64,
    /// Scans per second: 50 or 25 on an LMS1xx. ≤ 0 or NaN sends none;
    /// faster than 100 Hz is capped there.
    pub rate_hz: f64,
    pub max_range_m: f64,
    /// σ of the Gaussian range noise.
    pub range_sigma_m: f64,
    /// Chance that a beam with an echo reads NaN all the same.
    pub dropout_probability: f64,
}

impl Default for SimScannerConfig {
    /// An LMS1xx at 50 Hz, 0.5°, 270°, on the bench vehicle's front bumper
    /// (the autopilot's `SCAN1_*` defaults).
    fn default() -> Self {
        Self {
            enabled: true,
            mount_x_m: 3.6,
            mount_y_m: 0.0,
            mount_yaw_rad: 0.0,
            fov_rad: 270f64.to_radians(),
            step_rad: 0.5f64.to_radians(),
            rate_hz: 50.0,
            max_range_m: 20.0,
            range_sigma_m: 0.01,
            dropout_probability: 0.002,
        }
    }
}

/// Which setting of a [`SimScannerConfig`] is unusable, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimScannerConfigError {
    pub field: &'static str,
    pub reason: &'static str,
}

impl fmt::Display for SimScannerConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "scanner {}: {}", self.field, self.reason)
    }
}

impl std::error::Error for SimScannerConfigError {}

impl SimScannerConfig {
    /// Beams in one scan: both ends of the field are included.
    pub fn beam_count(&self) -> usize {
        let ratio = self.fov_rad / self.step_rad;
        if !(ratio.is_finite() && ratio >= 0.0 && self.step_rad > 0.0) {
            return 0;
        }
        // The tolerance absorbs the rounding of fov and step to radians.
        ((ratio + 1e-6).floor() as usize + 1).min(MAX_BEAMS)
    }

    /// Checks what an LMS1xx can do; the simulator itself copes with
    /// anything (see the field docs), this is for callers that want to refuse.
    pub fn validate(&self) -> Result<(), SimScannerConfigError> {
        let fail = |field, reason| Err(SimScannerConfigError { field, reason });
        let finite = [
            ("mount_x_m", self.mount_x_m),
            ("mount_y_m", self.mount_y_m),
            ("mount_yaw_rad", self.mount_yaw_rad),
        ];
        if let Some((field, _)) = finite.iter().find(|(_, v)| !v.is_finite()) {
            return fail(field, "must be a finite number");
        }
        if !(self.fov_rad > 0.0 && self.fov_rad <= TAU) {
            return fail("fov_rad", "must be in (0, 2π]");
        }
        if !(self.step_rad > 0.0 && self.step_rad <= self.fov_rad) {
            return fail("step_rad", "must be > 0 and no larger than the field of view");
        }
        if self.fov_rad / self.step_rad >= MAX_BEAMS as f64 {
            return fail("step_rad", "gives more beams than MAX_BEAMS");
        }
        if !LMS1XX_RATES_HZ.contains(&self.rate_hz) {
            return fail("rate_hz", "an LMS1xx scans at 25 or 50 Hz");
        }
        if !(self.max_range_m > 0.0 && self.max_range_m.is_finite()) {
            return fail("max_range_m", "must be > 0 and finite");
        }
        if !(self.range_sigma_m >= 0.0 && self.range_sigma_m.is_finite()) {
            return fail("range_sigma_m", "must be ≥ 0 and finite");
        }
        if !(0.0..=1.0).contains(&self.dropout_probability) {
            return fail("dropout_probability", "must be in [0, 1]");
        }
        Ok(())
    }

    /// The scanner's world position (north, east) and the bearing of its
    /// forward axis, for the vehicle at `truth`.
    pub fn scanner_pose(&self, truth: &VehicleTruth) -> ([f64; 2], f64) {
        let (sin, cos) = truth.yaw_rad.sin_cos();
        let (x, y) = (self.mount_x_m, self.mount_y_m);
        (
            [truth.north_m + x * cos - y * sin, truth.east_m + x * sin + y * cos],
            truth.yaw_rad + self.mount_yaw_rad,
        )
    }
}

/// The scan a scanner configured as `config` takes at `t` from the vehicle
/// at `truth`, its noise drawn from `noise_seed` alone: the same inputs give
/// the same scan. Moving obstacles are placed at `t`.
pub fn render_scan(
    config: &SimScannerConfig,
    obstacles: &ObstacleWorld,
    truth: &VehicleTruth,
    t: Duration,
    scan_counter: u32,
    noise_seed: u64,
) -> Scan {
    let mut scan = Scan {
        t,
        scan_counter,
        start_angle_rad: 0.0,
        step_rad: 0.0,
        ranges_m: Vec::new(),
    };
    let stamp = ScanStamp {
        t,
        scan_counter,
        noise_seed,
    };
    render_scan_into(
        config,
        obstacles,
        truth,
        stamp,
        &mut RenderScratch::default(),
        &mut scan,
    );
    scan
}

/// When a scan is taken, its number, and the seed of its noise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScanStamp {
    pub t: Duration,
    pub scan_counter: u32,
    pub noise_seed: u64,
}

/// Per-beam working buffers of [`render_scan_into`], kept between scans so
/// rendering allocates nothing once they have grown.
#[derive(Clone, Debug, Default)]
pub struct RenderScratch {
    directions: BeamDirections,
    true_range_m: Vec<f64>,
}

/// [`render_scan`] into `out`, reusing its range buffer and `scratch`.
pub fn render_scan_into(
    config: &SimScannerConfig,
    obstacles: &ObstacleWorld,
    truth: &VehicleTruth,
    stamp: ScanStamp,
    scratch: &mut RenderScratch,
    out: &mut Scan,
) {
    let beams = config.beam_count();
    let start_angle_rad = -config.fov_rad / 2.0;
    let true_range_m = &mut scratch.true_range_m;
    true_range_m.clear();
    true_range_m.resize(beams, f64::INFINITY);
    cast_beams(config, obstacles, truth, stamp.t, &mut scratch.directions, true_range_m);

    let sigma_m = if config.range_sigma_m.is_finite() {
        config.range_sigma_m.max(0.0)
    } else {
        0.0
    };
    let dropout = if config.dropout_probability.is_nan() {
        0.0
    } else {
        config.dropout_probability.clamp(0.0, 1.0)
    };
    let max_range_m = config.max_range_m;
    // Draws are made only for beams with an echo, in beam order: an empty
    // yard costs none, and a block of beams without one is passed over at
    // once (most of a scan in open space).
    let mut rng = ChaCha8Rng::seed_from_u64(stamp.noise_seed);
    out.ranges_m.clear();
    out.ranges_m.resize(true_range_m.len(), f32::NAN);
    let blocks = out.ranges_m.chunks_mut(BEAM_BLOCK).zip(true_range_m.chunks(BEAM_BLOCK));
    for (ranges_m, true_ranges_m) in blocks {
        if !true_ranges_m.iter().any(|&range_m| range_m <= max_range_m) {
            continue;
        }
        for (measured_m, &range_m) in ranges_m.iter_mut().zip(true_ranges_m) {
            let echo = range_m <= max_range_m;
            if !echo || (dropout > 0.0 && rng.random::<f64>() < dropout) {
                continue;
            }
            let noise_m = if sigma_m > 0.0 {
                sigma_m * rng.sample::<f64, _>(StandardNormal)
            } else {
                0.0
            };
            *measured_m = (range_m + noise_m).max(0.0) as f32;
        }
    }
    out.t = stamp.t;
    out.scan_counter = stamp.scan_counter;
    out.start_angle_rad = start_angle_rad;
    out.step_rad = config.step_rad;
}

/// The true range of each beam to the nearest obstacle (left infinite where
/// none is in reach). Obstacles whose bounding circle is out of range or
/// outside the field of view are skipped whole, and so are those hidden
/// behind what the beams toward them already met; of the rest, only the
/// beams between a part's extreme bearings are cast.
fn cast_beams(
    config: &SimScannerConfig,
    obstacles: &ObstacleWorld,
    truth: &VehicleTruth,
    t: Duration,
    directions: &mut BeamDirections,
    true_range_m: &mut [f64],
) {
    let beams = true_range_m.len();
    let (origin, forward_rad) = config.scanner_pose(truth);
    let first_bearing_rad = forward_rad - config.fov_rad / 2.0;
    let step_rad = config.step_rad;
    directions.reset(beams, first_bearing_rad, step_rad);
    let max_range_m = config.max_range_m;
    let relative_rad = |p: [f64; 2]| wrap_two_pi((p[1] - origin[1]).atan2(p[0] - origin[0]) - first_bearing_rad);
    obstacles.for_each_shape_at(t.as_secs_f64(), |shape| {
        let outline = shape.outline();
        let (center, radius_m) = outline.bounding_circle();
        let center_m = distance(center, origin);
        if center_m - radius_m > max_range_m {
            return;
        }
        // No hit on the shape is nearer than its bounding circle: a beam
        // that already met something nearer keeps its range.
        let nearest_m = center_m - radius_m - OCCLUSION_SLACK_M;
        if center_m > radius_m {
            let half_rad = (radius_m / center_m).asin();
            let mid_rad = relative_rad(center);
            let mut windows = beam_windows(mid_rad - half_rad - 1e-9, mid_rad + half_rad + 1e-9, step_rad, beams);
            // Wholly outside the field of view, or wholly hidden: no beam
            // can reach it, or none would keep what it reads.
            if windows.all(|(from, to)| true_range_m[from..to].iter().all(|&range_m| range_m <= nearest_m)) {
                return;
            }
        }
        // Only a scanner within the bounding circle can be inside (the
        // slack covers a scanner on a corner, the circle's own rounding).
        if center_m <= radius_m + OCCLUSION_SLACK_M && outline.contains(origin) {
            // Inside an obstacle every beam is blocked at once.
            true_range_m.fill(0.0);
            return;
        }
        // Only the beams between a part's extreme bearings can hit it: a
        // person 5 m away spans a handful of the 541 beams, a wall's face
        // only the beams that reach it.
        let mut part = Part {
            true_range_m: &mut *true_range_m,
            directions: &mut *directions,
            step_rad,
            nearest_m,
        };
        match outline.facing(origin) {
            FacingOutline::Circle { center, radius_m } => {
                let half_rad = (radius_m / distance(center, origin)).asin();
                let mid_rad = relative_rad(center);
                part.cast(mid_rad - half_rad, mid_rad + half_rad, |dir| {
                    ray_circle_m(origin, dir, center, radius_m)
                });
            }
            FacingOutline::Edges(edges) => {
                for (a, b) in edges.iter() {
                    if point_segment_distance(origin, a, b) > max_range_m {
                        continue;
                    }
                    // The edge subtends less than π (the origin is off its line).
                    let from_rad = relative_rad(a);
                    let span_rad = wrap_pi(relative_rad(b) - from_rad);
                    part.cast(from_rad + span_rad.min(0.0), from_rad + span_rad.max(0.0), |dir| {
                        ray_segment_m(origin, dir, a, b)
                    });
                }
            }
        }
    });
}

/// How far (m) a hit, or the outline itself, may fall outside its shape's
/// bounding circle by the rounding of the circle, the ray and the unit
/// directions (~1e-14 m at the scanner's ranges): a beam is passed over
/// only if what it already met is nearer than the circle by this much.
const OCCLUSION_SLACK_M: f64 = 1e-6;

/// One part of an obstacle (a circle or a facing edge) being cast.
struct Part<'a> {
    true_range_m: &'a mut [f64],
    directions: &'a mut BeamDirections,
    step_rad: f64,
    /// Nothing of the obstacle is nearer than this (m).
    nearest_m: f64,
}

impl Part<'_> {
    /// Casts the beams between `lo_rad` and `hi_rad` (from the first beam)
    /// at the part, keeping each beam's nearer range. A beam that already
    /// met something nearer than the obstacle is passed over: its range
    /// could not change.
    fn cast(&mut self, lo_rad: f64, hi_rad: f64, hit: impl Fn([f64; 2]) -> Option<f64>) {
        let beams = self.true_range_m.len();
        for (from, to) in beam_windows(lo_rad - 1e-9, hi_rad + 1e-9, self.step_rad, beams) {
            // Directions are worked out only as far as beams are open.
            let open = |range_m: &f64| *range_m > self.nearest_m;
            let Some(first) = self.true_range_m[from..to].iter().position(open) else {
                continue;
            };
            let last = self.true_range_m[from..to].iter().rposition(open).unwrap_or(first);
            let (from, to) = (from + first, from + last + 1);
            let ranges_m = &mut self.true_range_m[from..to];
            for (range_m, dir) in ranges_m.iter_mut().zip(self.directions.get(from, to)) {
                if *range_m <= self.nearest_m {
                    continue;
                }
                if let Some(hit_m) = hit(*dir) {
                    *range_m = range_m.min(hit_m);
                }
            }
        }
    }
}

/// Beams per block of [`BeamDirections`]: one sin_cos, then rotations (the
/// drift over 31 rotations is ~1e-14 rad).
const DIRECTION_BLOCK: usize = 32;

/// Unit vectors of one scan's beams, computed a block at a time when a
/// cast first needs them: most scans reach a few obstacles, which span a
/// small part of the field.
#[derive(Clone, Debug, Default)]
struct BeamDirections {
    unit: Vec<[f64; 2]>,
    block_filled: Vec<bool>,
    first_bearing_rad: f64,
    step_rad: f64,
}

impl BeamDirections {
    /// Forgets the last scan's directions.
    fn reset(&mut self, beams: usize, first_bearing_rad: f64, step_rad: f64) {
        self.unit.resize(beams, [f64::NAN; 2]);
        self.block_filled.clear();
        self.block_filled.resize(beams.div_ceil(DIRECTION_BLOCK), false);
        self.first_bearing_rad = first_bearing_rad;
        self.step_rad = step_rad;
    }

    /// The directions of beams `from..to`.
    fn get(&mut self, from: usize, to: usize) -> &[[f64; 2]] {
        if from < to {
            for block in from / DIRECTION_BLOCK..=(to - 1) / DIRECTION_BLOCK {
                if !self.block_filled[block] {
                    self.fill(block);
                }
            }
        }
        &self.unit[from..to]
    }

    fn fill(&mut self, block: usize) {
        let (step_sin, step_cos) = self.step_rad.sin_cos();
        let first = block * DIRECTION_BLOCK;
        let last = (first + DIRECTION_BLOCK).min(self.unit.len());
        let (sin, cos) = (self.first_bearing_rad + first as f64 * self.step_rad).sin_cos();
        self.unit[first] = [cos, sin];
        for beam in first + 1..last {
            let [n, e] = self.unit[beam - 1];
            self.unit[beam] = [n * step_cos - e * step_sin, n * step_sin + e * step_cos];
        }
        self.block_filled[block] = true;
    }
}

/// The beam index ranges whose angles from the first beam fall in
/// [`lo_rad`, `hi_rad`] (an interval shorter than 2π, `lo_rad` near [0, 2π)),
/// trying it a turn earlier and later too.
fn beam_windows(lo_rad: f64, hi_rad: f64, step_rad: f64, beams: usize) -> impl Iterator<Item = (usize, usize)> {
    [-TAU, 0.0, TAU].into_iter().filter_map(move |wrap| {
        let from = ((lo_rad + wrap) / step_rad).ceil().max(0.0);
        let to = (((hi_rad + wrap) / step_rad).floor() + 1.0).min(beams as f64);
        (from < to).then_some((from as usize, to as usize))
    })
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn wrap_pi(angle_rad: f64) -> f64 {
    crate::obstacles::wrap_two_pi(angle_rad + PI) - PI
}

/// Scan `k` of a scanner at `rate_hz`, rounded to the nanosecond.
fn scan_time(k: u64, rate_hz: f64) -> Duration {
    Duration::from_nanos((k as f64 * 1e9 / rate_hz).round() as u64)
}

/// The index of the first scan at or after `t`.
fn first_scan_from(t: Duration, rate_hz: f64) -> u64 {
    let mut k = (t.as_secs_f64() * rate_hz).floor() as u64;
    // The float guess can be one off either way.
    while k > 0 && scan_time(k - 1, rate_hz) >= t {
        k -= 1;
    }
    while scan_time(k, rate_hz) < t {
        k += 1;
    }
    k
}

/// A scanner's schedule and noise stream: scans fall at exact multiples of
/// 1/`rate_hz` (like the GNSS epochs), counted from 0 by `scan_counter`.
#[derive(Clone, Debug)]
pub struct SimScanner {
    config: SimScannerConfig,
    /// The scanner's own seed; each scan's noise comes from it and the scan's number.
    seed: u64,
    rate_hz: Option<f64>,
    next_k: u64,
    scans_sent: u64,
    scratch: RenderScratch,
}

impl SimScanner {
    /// Scans from the first due time at or after `now`.
    pub fn new(config: SimScannerConfig, seed: u64, now: Duration) -> Self {
        let usable = config.enabled && config.rate_hz.is_finite() && config.rate_hz > 0.0;
        let rate_hz = usable.then(|| config.rate_hz.min(MAX_RATE_HZ));
        Self {
            next_k: rate_hz.map_or(0, |rate| first_scan_from(now, rate)),
            config,
            seed,
            rate_hz,
            scans_sent: 0,
            scratch: RenderScratch::default(),
        }
    }

    pub fn config(&self) -> &SimScannerConfig {
        &self.config
    }

    /// The next scan's time, if it is no later than `t`.
    pub fn due(&self, t: Duration) -> Option<Duration> {
        let rate_hz = self.rate_hz?;
        Some(scan_time(self.next_k, rate_hz)).filter(|&due| due <= t)
    }

    /// Take the next scan (due at [`Self::next_scan_time`]) with the vehicle
    /// at `truth` at that instant; `None` for a scanner that never scans.
    pub fn scan(&mut self, obstacles: &ObstacleWorld, truth: &VehicleTruth) -> Option<Scan> {
        let mut scan = Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad: 0.0,
            step_rad: 0.0,
            ranges_m: Vec::new(),
        };
        self.scan_into(obstacles, truth, &mut scan).then_some(scan)
    }

    /// [`Self::scan`] into `out`, reusing its buffer; false (and `out`
    /// untouched) for a scanner that never scans.
    pub fn scan_into(&mut self, obstacles: &ObstacleWorld, truth: &VehicleTruth, out: &mut Scan) -> bool {
        let Some(t) = self.next_scan_time() else {
            return false;
        };
        let stamp = ScanStamp {
            t,
            scan_counter: self.scans_sent as u32,
            noise_seed: mix(self.seed, self.scans_sent),
        };
        render_scan_into(&self.config, obstacles, truth, stamp, &mut self.scratch, out);
        self.next_k += 1;
        self.scans_sent += 1;
        true
    }

    /// When the next scan falls; `None` for a scanner that never scans.
    pub fn next_scan_time(&self) -> Option<Duration> {
        self.rate_hz.map(|rate_hz| scan_time(self.next_k, rate_hz))
    }
}

/// The seed of scanner `index` in a world seeded with `world_seed`: tagged,
/// so it is neither the GNSS receiver's stream nor the magnetic sensors'.
pub(crate) fn scanner_seed(world_seed: u64, index: usize) -> u64 {
    mix(world_seed ^ 0x4c41_5345_5253_4341, index as u64)
}

/// A seed and a counter, finalised.
fn mix(seed: u64, counter: u64) -> u64 {
    splitmix_finalise(seed ^ counter.rotate_left(29))
}

#[cfg(test)]
mod tests {
    use super::super::obstacles::{MovingObstacle, Shape};
    use super::*;

    fn noiseless() -> SimScannerConfig {
        SimScannerConfig {
            mount_x_m: 0.0,
            range_sigma_m: 0.0,
            dropout_probability: 0.0,
            ..SimScannerConfig::default()
        }
    }

    fn cluttered() -> ObstacleWorld {
        ObstacleWorld::new(
            vec![
                Shape::Box {
                    center: [6.0, 3.0],
                    length_m: 2.0,
                    width_m: 1.0,
                    yaw_rad: 0.4,
                },
                Shape::Polygon {
                    points: vec![[-4.0, -4.0], [-3.0, -8.0], [-6.0, -7.0]],
                },
                // Concave (a U open to the south-west), wound clockwise.
                Shape::Polygon {
                    points: vec![
                        [-2.0, 6.0],
                        [3.0, 6.0],
                        [3.0, 10.0],
                        [-2.0, 10.0],
                        [-2.0, 9.0],
                        [2.0, 9.0],
                        [2.0, 7.0],
                        [-2.0, 7.0],
                    ],
                },
                Shape::Wall {
                    from: [15.0, -30.0],
                    to: [15.0, 30.0],
                    thickness_m: 0.3,
                },
                // Round the scanner: its bounding circle holds the origin.
                Shape::Wall {
                    from: [-19.0, 0.0],
                    to: [19.0, 0.5],
                    thickness_m: 0.0,
                },
            ],
            vec![MovingObstacle {
                name: "walker".to_owned(),
                shape: Shape::Circle {
                    center: [0.0, 0.0],
                    radius_m: 0.25,
                },
                path: vec![[3.0, -6.0], [3.0, 6.0]],
                speed_mps: 1.4,
                start_s: 0.0,
                looped: true,
                vanish_at_end: false,
            }],
        )
    }

    #[test]
    fn the_beam_window_loses_nothing_against_casting_every_beam() {
        let world = cluttered();
        for (k, yaw_deg) in [0.0, 37.0, 179.9, -120.0, 91.0].into_iter().enumerate() {
            let config = SimScannerConfig {
                mount_yaw_rad: 0.3 * k as f64,
                ..noiseless()
            };
            let truth = VehicleTruth {
                north_m: 0.3,
                east_m: -0.2,
                yaw_rad: f64::to_radians(yaw_deg),
                ..VehicleTruth::default()
            };
            let t = Duration::from_millis(1_700 * k as u64);
            let hits = assert_every_beam_as_cast_alone(&config, &world, &truth, t);
            assert!(hits > 100, "{yaw_deg}: {hits}");
        }
        // Inside an obstacle every beam reads 0.
        let crate_around = ObstacleWorld::new(
            vec![Shape::Box {
                center: [0.0, 0.0],
                length_m: 1.0,
                width_m: 1.0,
                yaw_rad: 0.0,
            }],
            Vec::new(),
        );
        let scan = render_scan(
            &noiseless(),
            &crate_around,
            &VehicleTruth::default(),
            Duration::ZERO,
            0,
            1,
        );
        assert!(scan.ranges_m.iter().all(|&r| r == 0.0));
    }

    /// Checks each beam of a scan against a ray cast at every obstacle
    /// alone; returns the beams with an echo.
    fn assert_every_beam_as_cast_alone(
        config: &SimScannerConfig,
        world: &ObstacleWorld,
        truth: &VehicleTruth,
        t: Duration,
    ) -> usize {
        let scan = render_scan(config, world, truth, t, 0, 1);
        assert_eq!(scan.ranges_m.len(), config.beam_count());
        let (origin, forward_rad) = config.scanner_pose(truth);
        let mut hits = 0;
        for (beam, &range_m) in scan.ranges_m.iter().enumerate() {
            let bearing = forward_rad + scan.angle_rad(beam);
            match world.raycast(origin, bearing, config.max_range_m, t.as_secs_f64()) {
                Some(expected_m) => {
                    hits += 1;
                    assert!((f64::from(range_m) - expected_m).abs() < 1e-5, "beam {beam}")
                }
                None => assert!(range_m.is_nan(), "beam {beam}: {range_m}"),
            }
        }
        hits
    }

    /// A fleet side by side: the nearest vehicles hide most of the farther
    /// ones, which are passed over where hidden, in either order; and what
    /// is met first but stands behind is not taken for what hides.
    #[test]
    fn vehicles_hidden_behind_others_read_as_casting_every_beam() {
        let outline = super::super::obstacles::VehicleOutline::default();
        // Staggered, a hand's breadth apart: the farther ones peek out.
        let row: Vec<Shape> = (-6..=6)
            .filter(|&k| k != 0)
            .map(|k| {
                let k = f64::from(k);
                outline
                    .rectangle(0.9 * k, 2.15 * k + 1.2f64.copysign(k), 0.05 * k)
                    .to_shape()
            })
            .collect();
        for (nearest_first, yaw_deg) in [(true, 0.0), (false, 0.0), (true, 180.0), (false, 33.0)] {
            let mut vehicles = row.clone();
            let from_own = |shape: &Shape| shape.bounding_circle().0[1].abs();
            vehicles.sort_by(|a, b| from_own(a).total_cmp(&from_own(b)));
            if !nearest_first {
                vehicles.reverse();
            }
            // A person a tenth of a millimetre in front of a crate's face,
            // met after it: the crate's ranges there are beyond the
            // person's bounding circle by less than that.
            let statics = vec![
                Shape::Box {
                    center: [9.0, 0.0],
                    length_m: 2.0,
                    width_m: 2.0,
                    yaw_rad: 0.0,
                },
                Shape::Circle {
                    center: [8.0 + 0.25 - 1e-4, 0.0],
                    radius_m: 0.25,
                },
            ];
            let world = ObstacleWorld {
                statics,
                vehicles,
                ..ObstacleWorld::default()
            };
            let truth = VehicleTruth {
                yaw_rad: f64::to_radians(yaw_deg),
                ..VehicleTruth::default()
            };
            for mount_yaw_rad in [0.0, PI] {
                let config = SimScannerConfig {
                    mount_yaw_rad,
                    ..noiseless()
                };
                let hits = assert_every_beam_as_cast_alone(&config, &world, &truth, Duration::ZERO);
                assert!(hits > 100, "{yaw_deg}: {hits}");
            }
        }
    }

    #[test]
    fn rendering_into_reused_buffers_matches_a_fresh_render() {
        let world = cluttered();
        let mut scratch = RenderScratch::default();
        let mut out = render_scan(
            &noiseless(),
            &ObstacleWorld::default(),
            &VehicleTruth::default(),
            Duration::ZERO,
            0,
            0,
        );
        for (k, yaw_deg) in [0.0, 91.0, -120.0, 179.9].into_iter().enumerate() {
            // Noise and dropouts on, and a different beam count each time.
            let config = SimScannerConfig {
                fov_rad: (180.0 + 30.0 * k as f64).to_radians(),
                dropout_probability: 0.05,
                ..SimScannerConfig::default()
            };
            let truth = VehicleTruth {
                north_m: -0.4 * k as f64,
                east_m: 0.7,
                yaw_rad: f64::to_radians(yaw_deg),
                ..VehicleTruth::default()
            };
            let stamp = ScanStamp {
                t: Duration::from_millis(900 * k as u64),
                scan_counter: k as u32,
                noise_seed: 40 + k as u64,
            };
            render_scan_into(&config, &world, &truth, stamp, &mut scratch, &mut out);
            let fresh = render_scan(&config, &world, &truth, stamp.t, stamp.scan_counter, stamp.noise_seed);
            assert_eq!(out.ranges_m.len(), fresh.ranges_m.len());
            let same = |a: f32, b: f32| a == b || (a.is_nan() && b.is_nan());
            assert!(out.ranges_m.iter().zip(&fresh.ranges_m).all(|(&a, &b)| same(a, b)));
            assert_eq!(
                (out.t, out.scan_counter, out.start_angle_rad, out.step_rad),
                (fresh.t, fresh.scan_counter, fresh.start_angle_rad, fresh.step_rad)
            );
        }
    }

    /// Each beam with an echo draws its dropout and noise in beam order, as
    /// a plain beam-by-beam pass does, though blocks without one are passed
    /// over: the same seed gives the same scan.
    #[test]
    fn measured_ranges_are_the_plain_beam_by_beam_draws() {
        let config = SimScannerConfig {
            dropout_probability: 0.2,
            ..SimScannerConfig::default()
        };
        let stamp = ScanStamp {
            t: Duration::from_millis(20),
            scan_counter: 1,
            noise_seed: 7,
        };
        let mut scratch = RenderScratch::default();
        let mut scan = render_scan(
            &config,
            &ObstacleWorld::default(),
            &VehicleTruth::default(),
            stamp.t,
            0,
            0,
        );
        render_scan_into(
            &config,
            &cluttered(),
            &VehicleTruth::default(),
            stamp,
            &mut scratch,
            &mut scan,
        );
        let mut rng = ChaCha8Rng::seed_from_u64(stamp.noise_seed);
        let plain: Vec<f32> = (scratch.true_range_m.iter())
            .map(|&range_m| {
                let echo = range_m <= config.max_range_m;
                if !echo || rng.random::<f64>() < config.dropout_probability {
                    return f32::NAN;
                }
                (range_m + config.range_sigma_m * rng.sample::<f64, _>(StandardNormal)).max(0.0) as f32
            })
            .collect();
        let bits = |ranges: &[f32]| ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&scan.ranges_m), bits(&plain));
        // Echoes, dropouts and whole blocks without an echo all occur.
        let echoes = scan.ranges_m.iter().filter(|r| r.is_finite()).count();
        let reached = scratch
            .true_range_m
            .iter()
            .filter(|&&r| r <= config.max_range_m)
            .count();
        assert!(echoes > 20 && echoes < reached, "{echoes} of {reached}");
        assert!((scratch.true_range_m.chunks(BEAM_BLOCK)).any(|b| b.iter().all(|r| r.is_infinite())));
    }

    #[test]
    fn beam_counts_and_validation_follow_the_lms1xx() {
        let config = SimScannerConfig::default();
        assert_eq!(config.beam_count(), 541);
        assert_eq!(config.validate(), Ok(()));
        let fine = SimScannerConfig {
            rate_hz: 25.0,
            step_rad: 0.25f64.to_radians(),
            ..config.clone()
        };
        assert_eq!(fine.beam_count(), 1081);
        assert_eq!(fine.validate(), Ok(()));
        let field = |c: SimScannerConfig| c.validate().err().map(|e| e.field);
        assert_eq!(
            field(SimScannerConfig {
                rate_hz: 40.0,
                ..config.clone()
            }),
            Some("rate_hz")
        );
        assert_eq!(
            field(SimScannerConfig {
                step_rad: 0.0,
                ..config.clone()
            }),
            Some("step_rad")
        );
        assert_eq!(
            field(SimScannerConfig {
                dropout_probability: f64::NAN,
                ..config.clone()
            }),
            Some("dropout_probability")
        );
        let broken = SimScannerConfig {
            step_rad: 1e-9,
            ..config.clone()
        };
        assert_eq!(broken.beam_count(), MAX_BEAMS);
        assert_eq!(field(broken), Some("step_rad"));
        let zero = SimScannerConfig {
            step_rad: f64::NAN,
            ..config
        };
        assert_eq!(zero.beam_count(), 0);
    }

    #[test]
    fn scans_fall_on_the_rate_grid_from_when_the_scanner_starts() {
        let mut scanner = SimScanner::new(SimScannerConfig::default(), 3, Duration::from_millis(30));
        assert_eq!(scanner.next_scan_time(), Some(Duration::from_millis(40)));
        assert_eq!(scanner.due(Duration::from_millis(39)), None);
        let world = ObstacleWorld::default();
        let truth = VehicleTruth::default();
        for k in 0..5u32 {
            let t = scanner.due(Duration::from_secs(1)).unwrap();
            let scan = scanner.scan(&world, &truth).unwrap();
            assert_eq!((scan.t, scan.scan_counter), (t, k));
            assert_eq!(t, Duration::from_millis(40 + 20 * u64::from(k)));
            assert!(scan.ranges_m.iter().all(|r| r.is_nan()));
        }
        for off in [
            SimScannerConfig {
                enabled: false,
                ..SimScannerConfig::default()
            },
            SimScannerConfig {
                rate_hz: f64::NAN,
                ..SimScannerConfig::default()
            },
        ] {
            let mut scanner = SimScanner::new(off, 3, Duration::ZERO);
            assert_eq!(scanner.due(Duration::from_secs(10)), None);
            assert!(scanner.scan(&world, &truth).is_none());
        }
        assert_ne!(scanner_seed(1, 0), scanner_seed(1, 1));
        assert_ne!(scanner_seed(1, 0), scanner_seed(2, 0));
    }
}
