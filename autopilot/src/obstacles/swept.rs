//! The area the vehicle's outline sweeps along the path it is about to
//! drive, and what in the scene it will meet there.
//!
//! # Geometry
//! The vehicle is its [`Footprint`] rectangle about the reference point
//! (the rear axle centre), which is the point that follows the planned path;
//! the body's heading is the path's heading (plus a half turn in reverse).
//! Driven round an arc of radius R, the rectangle's inner side at the rear
//! axle passes at R − w from the centre (the inner rear wheel's cut inside
//! the path of an Ackermann vehicle), its outer front corner at
//! √((R + w)² + front²) and its outer rear corner at √((R + w)² + rear²)
//! (the tail swing of the rear overhang, outside the path on the side away
//! from the turn). Nothing of this is approximated: the swept area is the
//! union of the rectangle placed at poses along the path.
//!
//! # Sampling bound
//! Poses are taken every `ds` metres of path. Between two of them the
//! reference point moves at most `ds` and the heading turns by at most
//! κ·ds, so any point of the outline, at most `reach` = hypot(max(front,
//! rear), w) from the reference point, moves at most `ds·(1 + reach·κ)`;
//! where the path starts off the vehicle's actual pose the offset is blended
//! out over `BLEND_M`, which adds its share per metre (`spread`). `ds` is
//! chosen so that this `step` is at most [`MAX_STEP_M`] (unless more than
//! [`MAX_POSES`] would be needed, in which case `step` grows and is used as
//! such). Every pose between two samples is within `ds/2` of one of them, so
//! every point of the continuous swept area lies within `step/2` of the
//! outline at some sample: an object more than `step/2` beyond the sampled
//! outlines (plus the margin asked for) is clear of the real sweep, and
//! nothing can fit between samples. Queries add `step/2` to their margin,
//! which makes them conservative by at most that.
//!
//! Searching along the samples uses that bound too: an outline point moves
//! at most `spread` per metre of path, so a point `g` beyond the margin at
//! one sample cannot be reached in the next `g/spread` metres, and those
//! samples are skipped (conservative advancement). Far objects cost one
//! distance each.
//!
//! # Collision in time
//! An obstacle moving at its tracked velocity against the vehicle moving
//! along the path at a constant speed v (or getting up to v from a slower
//! speed at a constant acceleration, as it does when it starts: [`Drive`]):
//! the gap between the obstacle's shape and the outline at the pose the
//! vehicle has at time t shrinks at most at `v·spread + |v_obstacle|`, so
//! time advances by the gap over that rate, and at least by
//! 2·[`CONTACT_TOLERANCE_M`] of relative motion (which can hide a dip of at
//! most [`CONTACT_TOLERANCE_M`], added to the margin). The pose at time t is
//! interpolated between the two samples either side of it (position and
//! heading; off by at most the sagitta of a sample step, `ds·step/8`, also
//! added), not the nearest sample taken, so the sampling slack does not
//! widen the margin here: a thing beside the lane just beyond the margin is
//! not stopped for. The first time the gap is within the margin is the
//! collision time (seed 004 §III.C's t_c, for a turning vehicle).
//!
//! # Skipping a sweep
//! A path given as poses from the vehicle's (the tracker's simulated way
//! back onto its leg, `guidance::rejoin`) costs a hundred or more tracker
//! steps to compute, every tick the vehicle is off its leg. Before they are
//! computed, [`SweepReach`] bounds where its queries could find anything.
//! Each step advances the reference point along a chord no longer than
//! `ds`, so after ⌈length/ds⌉ steps every sample, and every pose
//! interpolated between two, lies within `path` = ⌈length/ds⌉·ds of the
//! first reference point `c`; every outline point lies within `reach` of
//! its reference point. So a return `p` farther than path + reach +
//! margin + step/2 from `c` is more than the threshold
//! [`SweptPath::point_entry_m`] compares with (margin + step/2) from every
//! sampled outline, and it finds nothing; a shape reaching `extent` from a
//! centre moving at `v` is, at any time up to the horizon, more than the
//! contact threshold (margin + [`CONTACT_TOLERANCE_M`] + the sagitta) from
//! every outline [`SweptPath::first_contact_driving`] places, when its
//! centre is farther than path + reach + extent + v·horizon + that
//! threshold from `c`. When every return, every track and every standing
//! person remembered out of view (a disc at rest) is that far, the
//! built path would answer every query with nothing, and an empty one
//! ([`SweptPath::clear`]) answers the same without the poses being
//! computed. Anything within the disc, or anything non-finite, and the
//! path is built as before.
//!
//! Sources: docs/references.md §Seed 004.

use super::outline::{Outline, least_length, segment_offset};
use super::{Footprint, Pose};
use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::{LegPath, Piece};

/// Largest motion of any outline point between two samples, m.
pub const MAX_STEP_M: f64 = 0.1;
/// How much nearer than the margin a contact search may let a dip between
/// two of its instants go unseen, m.
pub const CONTACT_TOLERANCE_M: f64 = 0.005;
/// Samples per swept path at most.
pub const MAX_POSES: usize = 1024;
/// Over this much path a vehicle off its path is assumed to rejoin it.
pub const BLEND_M: f64 = 3.0;
/// A point already this much nearer the outline ahead than it is now is
/// approached; one that only stays where it is beside the body is not.
const NEARER_M: f64 = 0.05;

/// The path the vehicle is about to drive.
#[derive(Clone, Copy, Debug)]
pub enum PathAhead<'a> {
    /// A navigator leg, from `along_m` on; a stop leg ends at `stop_at_m`.
    Leg {
        path: &'a LegPath,
        along_m: f64,
        stop_at_m: Option<f64>,
        reverse: bool,
    },
    /// No planned path (or not yet): carry on at a constant curvature of the
    /// direction of travel (1/m, positive turning right).
    Curvature { curvature: f64, reverse: bool },
    /// Turning on the spot about the reference point to this heading. The
    /// distance along it is the arc the outline's farthest corner sweeps
    /// (`reach`·angle), so the sampling bound holds as on a path; the whole
    /// turn is sampled, however short the length asked for.
    Pivot { to_yaw_rad: f64 },
}

/// One sampled pose of the vehicle: reference point and body heading.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sample {
    north_m: f64,
    east_m: f64,
    sin_yaw: f64,
    cos_yaw: f64,
}

impl Sample {
    fn of(pose: &Pose) -> Sample {
        let (sin_yaw, cos_yaw) = pose.yaw_rad.sin_cos();
        Sample {
            north_m: pose.position.north_m,
            east_m: pose.position.east_m,
            sin_yaw,
            cos_yaw,
        }
    }

    /// A local-frame point in this pose's body frame (x forward, y right).
    fn body(&self, north_m: f64, east_m: f64) -> (f64, f64) {
        let (dn, de) = (north_m - self.north_m, east_m - self.east_m);
        (
            dn * self.cos_yaw + de * self.sin_yaw,
            -dn * self.sin_yaw + de * self.cos_yaw,
        )
    }
}

/// What an obstacle is, placed in the local frame.
#[derive(Clone, Copy, Debug)]
pub enum Shape<'a> {
    Disc { centre: Ned, radius_m: f64 },
    Polygon { centre: Ned, outline: &'a Outline },
}

impl Shape<'_> {
    fn centre(&self) -> Ned {
        match self {
            Shape::Disc { centre, .. } | Shape::Polygon { centre, .. } => *centre,
        }
    }

    /// How far the shape reaches from its centre.
    fn extent_m(&self) -> f64 {
        match self {
            Shape::Disc { radius_m, .. } => radius_m.max(0.0),
            Shape::Polygon { outline, .. } => outline.radius_m(),
        }
    }
}

/// Where and when an obstacle first comes within the margin of the outline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    pub time_s: f64,
    /// Path travelled by then.
    pub along_m: f64,
    /// Where the reference point is then.
    pub place: Ned,
    /// Gap between the shape and the outline now (0 when touching).
    pub gap_now_m: f64,
    /// The gap shrinks: contact at a later time, or within the margin now
    /// and getting nearer.
    pub closing: bool,
}

/// The outline swept along the path ahead, as poses every `ds_m`.
#[derive(Clone, Debug, Default)]
pub struct SweptPath {
    samples: Vec<Sample>,
    ds_m: f64,
    spread: f64,
    step_m: f64,
    /// Bounding box of the reference points (north min/max, east min/max).
    bounds: (f64, f64, f64, f64),
    front_m: f64,
    rear_m: f64,
    half_width_m: f64,
    reach_m: f64,
}

impl SweptPath {
    /// Samples `length_m` of the path ahead from the vehicle's pose `now`
    /// (the first sample is `now` itself). Reuses its buffers.
    pub fn build(&mut self, ahead: &PathAhead, now: &Pose, footprint: &Footprint, length_m: f64) {
        self.front_m = footprint.front_m.max(0.0);
        self.rear_m = footprint.rear_m.max(0.0);
        self.half_width_m = footprint.half_width_m.max(0.0);
        self.reach_m = self.front_m.max(self.rear_m).hypot(self.half_width_m);
        let length_m = if length_m.is_finite() { length_m.max(0.0) } else { 0.0 };
        let (curvature, offset_m, offset_rad) = match ahead {
            PathAhead::Leg {
                path, along_m, reverse, ..
            } => {
                let on_path = leg_pose(path, *along_m, *reverse);
                (
                    path.max_curvature(),
                    now.position.distance_to(&on_path.position),
                    wrap_pi(now.yaw_rad - on_path.yaw_rad).abs(),
                )
            }
            PathAhead::Curvature { curvature, .. } => (curvature.abs(), 0.0, 0.0),
            PathAhead::Pivot { .. } => (0.0, 0.0, 0.0),
        };
        let length_m = match ahead {
            PathAhead::Pivot { to_yaw_rad } => length_m.max(self.reach_m * wrap_pi(to_yaw_rad - now.yaw_rad).abs()),
            _ => length_m,
        };
        let curvature = if curvature.is_finite() { curvature } else { 0.0 };
        self.spread = 1.0 + offset_m / BLEND_M + self.reach_m * (curvature + offset_rad / BLEND_M);
        let ideal_ds = MAX_STEP_M / self.spread;
        let count = ((length_m / ideal_ds).ceil() as usize + 1).clamp(1, MAX_POSES);
        self.ds_m = if count > 1 {
            (length_m / (count - 1) as f64).min(ideal_ds)
        } else {
            ideal_ds
        };
        self.step_m = self.ds_m * self.spread;
        self.samples.clear();
        let start = match ahead {
            PathAhead::Leg {
                path, along_m, reverse, ..
            } => leg_pose(path, *along_m, *reverse),
            PathAhead::Curvature { .. } | PathAhead::Pivot { .. } => *now,
        };
        let mut walker = match ahead {
            PathAhead::Leg { path, .. } => Some(LegWalker::new(path)),
            PathAhead::Curvature { .. } | PathAhead::Pivot { .. } => None,
        };
        for i in 0..count {
            let s = i as f64 * self.ds_m;
            let sample = Sample::of(&pose_at(ahead, walker.as_mut(), now, &start, s, self.reach_m));
            self.samples.push(sample);
        }
        self.bounds = bounds_of(&self.samples);
    }

    /// Whether `p` is further than `reach` from every sampled reference
    /// point's bounding box (so from every outline by `reach − reach_m`).
    fn far_from_bounds(&self, p: Ned, reach: f64) -> bool {
        let (n0, n1, e0, e1) = self.bounds;
        p.north_m < n0 - reach || p.north_m > n1 + reach || p.east_m < e0 - reach || p.east_m > e1 + reach
    }

    /// Path covered by the samples.
    pub fn length_m(&self) -> f64 {
        self.ds_m * self.samples.len().saturating_sub(1) as f64
    }

    /// The sampling slack added to every margin: half the step.
    pub fn slack_m(&self) -> f64 {
        0.5 * self.step_m
    }

    pub fn pose_count(&self) -> usize {
        self.samples.len()
    }

    /// The reference point's pose at sample `i` (clamped), for reports.
    pub fn pose(&self, i: usize) -> Option<Pose> {
        let s = self.samples.get(i.min(self.samples.len().checked_sub(1)?))?;
        Some(Pose {
            position: Ned::new(s.north_m, s.east_m),
            yaw_rad: s.sin_yaw.atan2(s.cos_yaw),
        })
    }

    /// Distance from a local point to the outline at sample `i` (0 inside).
    fn point_gap(&self, i: usize, p: Ned) -> f64 {
        let (x, y) = self.samples[i].body(p.north_m, p.east_m);
        rect_gap(self.front_m, self.rear_m, self.half_width_m, x, y)
    }

    /// The gap between the shape (reaching `extent_m` from its centre) and
    /// the outline at sample `i`, or a lower bound of it above
    /// `exact_below` (enough to advance by).
    fn shape_gap(&self, i: usize, shape: &Shape, extent_m: f64, shift: (f64, f64), exact_below: f64) -> f64 {
        self.shape_gap_at(&self.samples[i], shape, extent_m, shift, exact_below)
    }

    /// [`Self::shape_gap`] for the outline at any pose.
    fn shape_gap_at(&self, sample: &Sample, shape: &Shape, extent_m: f64, shift: (f64, f64), exact_below: f64) -> f64 {
        let centre = shape.centre();
        let (cn, ce) = (centre.north_m + shift.0, centre.east_m + shift.1);
        let (x, y) = sample.body(cn, ce);
        let disc_gap = (rect_gap(self.front_m, self.rear_m, self.half_width_m, x, y) - extent_m).max(0.0);
        match shape {
            Shape::Disc { .. } => disc_gap,
            Shape::Polygon { .. } if disc_gap > exact_below => disc_gap,
            Shape::Polygon { outline, .. } => {
                let mut body = [(0.0, 0.0); super::outline::MAX_VERTICES];
                let vertices = outline.vertices();
                for (b, v) in body.iter_mut().zip(vertices) {
                    *b = sample.body(cn + v.0, ce + v.1);
                }
                polygon_rect_gap(&body[..vertices.len()], self.front_m, self.rear_m, self.half_width_m)
            }
        }
    }

    /// How far along the path the outline first comes within `margin_m` of
    /// the point `p`, searching up to `max_m`: the protective and warning
    /// fields ask this of every return. A point outside the margin now
    /// counts as soon as the outline comes within the margin of it, however
    /// gradually (the inner side closing in on a parked car round an arc);
    /// one already within it only once the outline will be `NEARER_M`
    /// nearer still. `None` when it never does: a point the outline keeps
    /// its distance from (a wall beside a straight lane) is not in the way.
    pub fn point_entry_m(&self, p: Ned, margin_m: f64, max_m: f64) -> Option<f64> {
        if self.samples.is_empty() || !(p.north_m.is_finite() && p.east_m.is_finite()) {
            return None;
        }
        if self.far_from_bounds(p, self.reach_m + margin_m.max(0.0) + self.step_m) {
            return None;
        }
        let gap_now = self.point_gap(0, p);
        let margin_m = margin_m.max(0.0) + self.slack_m();
        let threshold = if gap_now > margin_m {
            margin_m
        } else {
            gap_now - NEARER_M
        };
        if threshold <= 0.0 {
            // Inside or against the body now: its own returns, or contact
            // the tracks judge.
            return None;
        }
        let last = self.last_index(max_m);
        let per_sample = self.spread * self.ds_m;
        // Sample 0's gap is `gap_now`, already known.
        let (mut i, mut gap) = (0, gap_now);
        loop {
            if gap <= threshold {
                return Some(i as f64 * self.ds_m);
            }
            // Positive here, so truncating is the floor (without a libm call).
            i += (((gap - threshold) / per_sample) as usize).max(1);
            if i > last {
                return None;
            }
            gap = self.point_gap(i, p);
        }
    }

    /// The last sample within `max_m` of path.
    fn last_index(&self, max_m: f64) -> usize {
        let n = self.samples.len() - 1;
        if self.ds_m <= 0.0 || !max_m.is_finite() {
            return n;
        }
        ((max_m.max(0.0) / self.ds_m).floor() as usize).min(n)
    }

    /// The first time within `horizon_s` the shape, moving at `velocity`
    /// (north, east m/s), comes within `margin_m` of the outline driven
    /// along the path at `speed_mps` (a magnitude; the path knows the
    /// direction). Beyond the sampled length the vehicle is taken to stop
    /// at the last sample. `None` when it does not, or for non-finite input.
    pub fn first_contact(
        &self,
        shape: &Shape,
        velocity: (f64, f64),
        speed_mps: f64,
        margin_m: f64,
        horizon_s: f64,
    ) -> Option<Contact> {
        let drive = Drive {
            from_mps: speed_mps.abs(),
            speed_mps: speed_mps.abs(),
            accel_mps2: 0.0,
        };
        self.first_contact_driving(shape, velocity, &drive, margin_m, horizon_s)
    }

    /// [`Self::first_contact`] for a vehicle that gets up to its speed from
    /// a slower one (a start or a resume): it lingers where it is for the
    /// first seconds, and someone walking up to it from behind or from the
    /// side meets it there, where a vehicle already at speed would be gone.
    pub fn first_contact_driving(
        &self,
        shape: &Shape,
        velocity: (f64, f64),
        drive: &Drive,
        margin_m: f64,
        horizon_s: f64,
    ) -> Option<Contact> {
        let centre = shape.centre();
        let finite = [
            centre.north_m,
            centre.east_m,
            velocity.0,
            velocity.1,
            drive.speed_mps,
            drive.from_mps,
            drive.accel_mps2,
            margin_m,
        ];
        if self.samples.is_empty() || finite.iter().any(|v| !v.is_finite()) || horizon_s.is_nan() {
            return None;
        }
        // The fastest it drives bounds how fast the gap can shrink.
        let speed = drive.speed_mps.abs().max(drive.from_mps.abs());
        let obstacle_mps = velocity.0.hypot(velocity.1);
        let rate = speed * self.spread + obstacle_mps;
        let threshold = margin_m.max(0.0) + CONTACT_TOLERANCE_M + self.sagitta_m();
        let min_dt = if rate > 0.0 {
            2.0 * CONTACT_TOLERANCE_M / rate
        } else {
            f64::INFINITY
        };
        let standing = obstacle_mps == 0.0;
        // Once per query: a polygon's extent is a dozen square roots.
        let extent_m = shape.extent_m();
        if self.beyond_reach(centre, extent_m, obstacle_mps, threshold, horizon_s) {
            return None;
        }
        let mut t = 0.0;
        loop {
            let along_m = drive.along_m(t).min(self.length_m());
            let shift = (velocity.0 * t, velocity.1 * t);
            let sample = self.sample_at(along_m);
            let gap = self.shape_gap_at(&sample, shape, extent_m, shift, threshold);
            if gap <= threshold {
                // Only a contact needs the exact gap now (a polygon's is
                // dozens of distances).
                let gap_now = self.shape_gap(0, shape, extent_m, (0.0, 0.0), f64::INFINITY);
                let closing = t > 0.0 || self.closing_now(shape, extent_m, velocity, speed, gap_now);
                return Some(Contact {
                    time_s: t,
                    along_m,
                    place: Ned::new(sample.north_m, sample.east_m),
                    gap_now_m: gap_now,
                    closing,
                });
            }
            // Nothing moves any more: the vehicle has reached the end of
            // the path and the object stands.
            if rate <= 0.0 || (standing && along_m >= self.length_m()) {
                return None;
            }
            t += ((gap - threshold) / rate).max(min_dt);
            if t > horizon_s {
                return None;
            }
        }
    }

    /// Whether a shape reaching `extent_m` from `centre`, moving at
    /// `obstacle_mps` for `horizon_s`, stays further than `threshold` from
    /// every outline along the path: its centre stays more than reach +
    /// extent + threshold beyond the box of the reference points along one
    /// axis (an interpolated pose's reference point lies in that box too).
    /// The search would find no contact either; this saves its steps for the
    /// tracks far from the path.
    fn beyond_reach(&self, centre: Ned, extent_m: f64, obstacle_mps: f64, threshold: f64, horizon_s: f64) -> bool {
        let moved_m = if obstacle_mps == 0.0 {
            0.0
        } else {
            obstacle_mps * horizon_s.max(0.0)
        };
        // A micrometre for the rounding of the poses and the gaps.
        let reach = self.reach_m + extent_m + moved_m + threshold + 1e-6;
        reach.is_finite() && self.far_from_bounds(centre, reach)
    }

    /// How far an interpolated pose can be off the path: the sagitta of one
    /// sample step.
    fn sagitta_m(&self) -> f64 {
        self.ds_m * self.step_m / 8.0
    }

    /// The pose `along_m` along the path, interpolated between the samples
    /// either side (heading by its unit vector).
    fn sample_at(&self, along_m: f64) -> Sample {
        let n = self.samples.len() - 1;
        if self.ds_m <= 0.0 || n == 0 {
            return self.samples[0];
        }
        let x = (along_m / self.ds_m).max(0.0);
        let i = x.floor() as usize;
        if i >= n {
            return self.samples[n];
        }
        let f = x - i as f64;
        let (a, b) = (&self.samples[i], &self.samples[i + 1]);
        let lerp = |p: f64, q: f64| p + f * (q - p);
        let (sin_yaw, cos_yaw) = (lerp(a.sin_yaw, b.sin_yaw), lerp(a.cos_yaw, b.cos_yaw));
        let norm = sin_yaw.hypot(cos_yaw);
        if norm <= 0.0 {
            return if f < 0.5 { *a } else { *b };
        }
        Sample {
            north_m: lerp(a.north_m, b.north_m),
            east_m: lerp(a.east_m, b.east_m),
            sin_yaw: sin_yaw / norm,
            cos_yaw: cos_yaw / norm,
        }
    }

    /// Whether the gap shrinks over the next stretch of motion.
    fn closing_now(&self, shape: &Shape, extent_m: f64, velocity: (f64, f64), speed: f64, gap_now: f64) -> bool {
        let rate = speed * self.spread + velocity.0.hypot(velocity.1);
        if rate <= 0.0 {
            return false;
        }
        // Long enough to move on by a couple of samples.
        let dt = (2.0 * self.ds_m.max(MAX_STEP_M) / rate).max(0.05);
        self.shape_gap_at(
            &self.sample_at(speed * dt),
            shape,
            extent_m,
            (velocity.0 * dt, velocity.1 * dt),
            f64::INFINITY,
        ) < gap_now
    }
}

/// How the vehicle drives along the path from now: from `from_mps` it gets
/// to `speed_mps` at `accel_mps2` (at once without a positive one), then
/// holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive {
    pub from_mps: f64,
    pub speed_mps: f64,
    pub accel_mps2: f64,
}

impl Drive {
    /// Path driven after `t_s`.
    fn along_m(&self, t_s: f64) -> f64 {
        let (from, to) = (self.from_mps.abs(), self.speed_mps.abs());
        if from >= to || self.accel_mps2 <= 0.0 {
            return to * t_s;
        }
        let ramp_s = (to - from) / self.accel_mps2;
        if t_s <= ramp_s {
            from * t_s + 0.5 * self.accel_mps2 * t_s * t_s
        } else {
            from * ramp_s + 0.5 * self.accel_mps2 * ramp_s * ramp_s + to * (t_s - ramp_s)
        }
    }
}

/// The vehicle's pose on a leg's path at `along_m`.
fn leg_pose(path: &LegPath, along_m: f64, reverse: bool) -> Pose {
    let flip = if reverse { std::f64::consts::PI } else { 0.0 };
    Pose {
        position: path.point_at(along_m),
        yaw_rad: wrap_pi(path.heading_at(along_m) + flip),
    }
}

/// The vehicle's pose after `s` metres along the path ahead.
/// `start`: the path's pose where the vehicle is on it (for a leg), and
/// `walker` the leg's pieces, asked for increasing `s`.
/// `reach_m`: the outline's farthest point from the reference point.
fn pose_at(ahead: &PathAhead, walker: Option<&mut LegWalker>, now: &Pose, start: &Pose, s: f64, reach_m: f64) -> Pose {
    match (ahead, walker) {
        (
            PathAhead::Leg {
                along_m,
                stop_at_m,
                reverse,
                ..
            },
            Some(walker),
        ) => {
            let at = stop_at_m.map_or(along_m + s, |end| (along_m + s).min(end.max(*along_m)));
            let (position, heading) = walker.at(at);
            let flip = if *reverse { std::f64::consts::PI } else { 0.0 };
            let on_path = Pose {
                position,
                yaw_rad: wrap_pi(heading + flip),
            };
            // The offset of the actual pose from the path, blended out.
            let w = (1.0 - s / BLEND_M).max(0.0);
            Pose {
                position: Ned::new(
                    on_path.position.north_m + w * (now.position.north_m - start.position.north_m),
                    on_path.position.east_m + w * (now.position.east_m - start.position.east_m),
                ),
                yaw_rad: wrap_pi(on_path.yaw_rad + w * wrap_pi(now.yaw_rad - start.yaw_rad)),
            }
        }
        (PathAhead::Leg { path, along_m, .. }, None) => leg_pose(path, along_m + s, false),
        (PathAhead::Pivot { to_yaw_rad }, _) => {
            let turn = wrap_pi(to_yaw_rad - now.yaw_rad);
            // A body of no size turns at once.
            let turned = turn.signum() * (s / reach_m.max(1e-6)).min(turn.abs());
            Pose {
                position: now.position,
                yaw_rad: wrap_pi(now.yaw_rad + turned),
            }
        }
        (PathAhead::Curvature { curvature, reverse }, _) => {
            let flip = if *reverse { std::f64::consts::PI } else { 0.0 };
            let heading = now.yaw_rad + flip;
            let k = if curvature.is_finite() { *curvature } else { 0.0 };
            let turned = k * s;
            // Chord of the arc (the straight limit for small turns).
            let chord = if turned.abs() < 1e-9 {
                s
            } else {
                2.0 * (0.5 * turned).sin() / k
            };
            let mid = heading + 0.5 * turned;
            Pose {
                position: Ned::new(
                    now.position.north_m + chord * mid.cos(),
                    now.position.east_m + chord * mid.sin(),
                ),
                yaw_rad: wrap_pi(now.yaw_rad + turned),
            }
        }
    }
}

/// Walks a leg's pieces for increasing distances along it: what
/// [`LegPath::point_at`] and [`LegPath::heading_at`] give (the first piece
/// extended backwards, the last forwards), without searching for the piece
/// and working out a straight's direction again at every sample.
struct LegWalker<'a> {
    pieces: &'a [Piece],
    index: usize,
    start_m: f64,
    /// The current piece when straight: its start, unit direction, heading.
    line: Option<(Ned, (f64, f64), f64)>,
}

impl<'a> LegWalker<'a> {
    fn new(path: &'a LegPath) -> Self {
        let mut walker = LegWalker {
            pieces: path.pieces(),
            index: 0,
            start_m: 0.0,
            line: None,
        };
        walker.enter();
        walker
    }

    fn enter(&mut self) {
        self.line = match self.pieces.get(self.index) {
            Some(Piece::Line(segment)) => Some((segment.start, segment.direction(), segment.bearing_rad())),
            _ => None,
        };
    }

    /// Position and heading of travel at `along_m` (never less than the
    /// previous call's).
    fn at(&mut self, along_m: f64) -> (Ned, f64) {
        while self.index + 1 < self.pieces.len() && along_m >= self.start_m + self.pieces[self.index].length_m() {
            self.start_m += self.pieces[self.index].length_m();
            self.index += 1;
            self.enter();
        }
        let local = along_m - self.start_m;
        match (self.line, self.pieces.get(self.index)) {
            (Some((start, (un, ue), heading)), _) => {
                (Ned::new(start.north_m + un * local, start.east_m + ue * local), heading)
            }
            (None, Some(piece)) => (piece.point_at(local), piece.heading_at(local)),
            (None, None) => (Ned::default(), 0.0),
        }
    }
}

/// Distance from a body-frame point to the rectangle (0 inside).
fn rect_gap(front_m: f64, rear_m: f64, half_width_m: f64, x: f64, y: f64) -> f64 {
    let dx = (x - front_m).max(-rear_m - x).max(0.0);
    let dy = (y.abs() - half_width_m).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

/// Distance between a convex polygon (body frame, either winding, at most
/// [`MAX_VERTICES`](super::outline::MAX_VERTICES) corners) and the
/// rectangle: 0 when they overlap (no separating axis among the rectangle's
/// two and the polygon's edge normals), else the least corner-to-edge
/// distance either way.
fn polygon_rect_gap(polygon: &[(f64, f64)], front_m: f64, rear_m: f64, half_width_m: f64) -> f64 {
    if polygon.is_empty() {
        return f64::INFINITY;
    }
    let corners = [
        (front_m, half_width_m),
        (front_m, -half_width_m),
        (-rear_m, -half_width_m),
        (-rear_m, half_width_m),
    ];
    let from_polygon = polygon
        .iter()
        .map(|&(x, y)| rect_gap(front_m, rear_m, half_width_m, x, y))
        .fold(f64::INFINITY, f64::min);
    if from_polygon == 0.0 {
        return 0.0;
    }
    let n = polygon.len();
    let inv = 1.0 / n as f64;
    let mid = polygon
        .iter()
        .fold((0.0, 0.0), |acc, p| (acc.0 + p.0 * inv, acc.1 + p.1 * inv));
    // Each corner's offset from each edge; the least length is taken once.
    let mut offsets = [(0.0, 0.0); 4 * super::outline::MAX_VERTICES];
    let mut separated = false;
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
        for (o, &c) in offsets[4 * i..4 * i + 4].iter_mut().zip(&corners) {
            *o = segment_offset(a, b, c);
        }
        // Separating axis: an edge's normal with every rectangle corner
        // strictly on the far side from the polygon (for a segment, on
        // one side of it).
        if !separated {
            let normal = (b.1 - a.1, a.0 - b.0);
            let side = |p: (f64, f64)| (p.0 - a.0) * normal.0 + (p.1 - a.1) * normal.1;
            // The vertices' mean is inside a convex polygon.
            let inner = side(mid);
            separated = if n == 2 {
                corners.iter().all(|&c| side(c) > 0.0) || corners.iter().all(|&c| side(c) < 0.0)
            } else {
                inner != 0.0 && corners.iter().all(|&c| side(c) * inner < 0.0)
            };
        }
    }
    // The rectangle's own axes separate whenever a polygon corner's gap is
    // positive along x or y alone; otherwise an edge normal must.
    let axis_separated = polygon.iter().all(|p| p.0 > front_m)
        || polygon.iter().all(|p| p.0 < -rear_m)
        || polygon.iter().all(|p| p.1 > half_width_m)
        || polygon.iter().all(|p| p.1 < -half_width_m);
    if !(axis_separated || separated) && n >= 2 {
        return 0.0;
    }
    from_polygon.min(least_length(&offsets[..4 * n]))
}

/// A path given as poses (the path a vehicle off its leg drives back onto
/// it, simulated: `guidance::rejoin`), rather than one [`PathAhead`] can
/// place. The poses are `ds` apart along a path whose curvature is at most
/// κ, so the module's sampling bound holds with `spread` = 1 + reach·κ and
/// no blend: the simulation itself starts at the vehicle's pose.
impl SweptPath {
    /// The spacing the poses of `length_m` of path, curving at most
    /// `curvature_max`, must have for the sampling bound ([`MAX_STEP_M`],
    /// or coarser where more than [`MAX_POSES`] would be needed).
    pub fn pose_spacing_m(footprint: &Footprint, curvature_max: f64, length_m: f64) -> f64 {
        let reach_m = footprint
            .front_m
            .max(footprint.rear_m)
            .max(0.0)
            .hypot(footprint.half_width_m.max(0.0));
        let curvature = if curvature_max.is_finite() {
            curvature_max.abs()
        } else {
            0.0
        };
        let ideal_ds = MAX_STEP_M / (1.0 + reach_m * curvature);
        let length_m = if length_m.is_finite() { length_m.max(0.0) } else { 0.0 };
        ideal_ds.max(length_m / (MAX_POSES - 1) as f64)
    }

    /// Nothing swept: every query finds nothing (what a path built where
    /// [`SweepReach`] rules out everything in the scene would find).
    pub fn clear(&mut self) {
        self.samples.clear();
        self.bounds = bounds_of(&self.samples);
    }

    /// Takes `poses` (the first the vehicle's own, then every `ds_m` along
    /// a path curving at most `curvature_max`; at most [`MAX_POSES`] used)
    /// as the samples. Reuses its buffers.
    pub fn build_from_poses(
        &mut self,
        poses: impl IntoIterator<Item = Pose>,
        ds_m: f64,
        curvature_max: f64,
        footprint: &Footprint,
    ) {
        self.front_m = footprint.front_m.max(0.0);
        self.rear_m = footprint.rear_m.max(0.0);
        self.half_width_m = footprint.half_width_m.max(0.0);
        let sampling = PoseSampling::new(footprint, ds_m, curvature_max);
        self.reach_m = sampling.reach_m;
        self.spread = sampling.spread;
        self.ds_m = sampling.ds_m;
        self.step_m = sampling.step_m;
        self.samples.clear();
        self.samples
            .extend(poses.into_iter().take(MAX_POSES).map(|pose| Sample::of(&pose)));
        self.bounds = bounds_of(&self.samples);
    }
}

/// The spacing of poses given to [`SweptPath::build_from_poses`] and what
/// follows from it: the outline's reach from the reference point, how far
/// an outline point moves per metre of path (`spread`), the spacing used
/// and the largest motion of an outline point between two poses.
struct PoseSampling {
    reach_m: f64,
    spread: f64,
    ds_m: f64,
    step_m: f64,
}

impl PoseSampling {
    fn new(footprint: &Footprint, ds_m: f64, curvature_max: f64) -> Self {
        let reach_m = footprint
            .front_m
            .max(0.0)
            .max(footprint.rear_m.max(0.0))
            .hypot(footprint.half_width_m.max(0.0));
        let curvature = if curvature_max.is_finite() {
            curvature_max.abs()
        } else {
            0.0
        };
        let spread = 1.0 + reach_m * curvature;
        let ds_m = if ds_m.is_finite() && ds_m > 0.0 {
            ds_m
        } else {
            MAX_STEP_M / spread
        };
        PoseSampling {
            reach_m,
            spread,
            ds_m,
            step_m: ds_m * spread,
        }
    }
}

/// Where the queries of a path given as poses (built by
/// [`SweptPath::build_from_poses`]) could find anything, known before the
/// poses are computed (see the module header, §Skipping a sweep): a disc
/// round the first pose's reference point.
#[derive(Clone, Copy, Debug)]
pub struct SweepReach {
    centre: Ned,
    /// How far any pose's reference point can be from `centre`.
    path_m: f64,
    reach_m: f64,
    slack_m: f64,
    sagitta_m: f64,
}

impl SweepReach {
    /// For poses every `ds_m` from `start` over `length_m` (at most
    /// ⌈`length_m`/`ds_m`⌉ steps of at most `ds_m` each), curving at most
    /// `curvature_max`, with the spacing and slack `build_from_poses` would
    /// use for them.
    pub fn of_poses(start: Ned, ds_m: f64, curvature_max: f64, footprint: &Footprint, length_m: f64) -> Self {
        let sampling = PoseSampling::new(footprint, ds_m, curvature_max);
        let path_m = if length_m.is_finite() {
            (length_m.max(0.0) / sampling.ds_m).ceil() * sampling.ds_m
        } else {
            f64::INFINITY
        };
        SweepReach {
            centre: start,
            path_m,
            reach_m: sampling.reach_m,
            slack_m: 0.5 * sampling.step_m,
            sagitta_m: sampling.ds_m * sampling.step_m / 8.0,
        }
    }

    /// Whether [`SweptPath::point_entry_m`] with `margin_m` could find `p`
    /// (false only when it certainly finds nothing).
    pub fn may_meet_point(&self, p: Ned, margin_m: f64) -> bool {
        let within_m = self.path_m + self.reach_m + margin_m.max(0.0) + self.slack_m;
        !self.beyond(p, within_m)
    }

    /// Whether [`SweptPath::first_contact_driving`] could find a contact
    /// with `shape` moving at `speed_mps` (a magnitude) within `horizon_s`,
    /// at `margin_m` (false only when it certainly finds none).
    pub fn may_meet_shape(&self, shape: &Shape, speed_mps: f64, margin_m: f64, horizon_s: f64) -> bool {
        let moved_m = if speed_mps == 0.0 {
            0.0
        } else {
            speed_mps.abs() * horizon_s.max(0.0)
        };
        let threshold = margin_m.max(0.0) + CONTACT_TOLERANCE_M + self.sagitta_m;
        let within_m = self.path_m + self.reach_m + shape.extent_m() + moved_m + threshold;
        !self.beyond(shape.centre(), within_m)
    }

    /// Whether `p` is certainly more than `within_m` from the centre (not
    /// for anything non-finite); a micrometre allowed for the rounding of
    /// the poses and the gaps.
    fn beyond(&self, p: Ned, within_m: f64) -> bool {
        let within_m = within_m + 1e-6;
        let d2 = (p.north_m - self.centre.north_m).powi(2) + (p.east_m - self.centre.east_m).powi(2);
        within_m.is_finite() && d2 > within_m * within_m
    }
}

/// The north and east extent of the sampled references: (north min, north
/// max, east min, east max).
fn bounds_of(samples: &[Sample]) -> (f64, f64, f64, f64) {
    samples.iter().fold(
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY),
        |b, s| {
            (
                b.0.min(s.north_m),
                b.1.max(s.north_m),
                b.2.min(s.east_m),
                b.3.max(s.east_m),
            )
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The simulator AGV's outline: 3.6 m ahead of the rear axle, 0.8 m
    /// behind it, 2 m wide.
    const AGV: Footprint = Footprint {
        front_m: 3.6,
        rear_m: 0.8,
        half_width_m: 1.0,
    };

    fn north_at_origin() -> Pose {
        Pose {
            position: Ned::default(),
            yaw_rad: 0.0,
        }
    }

    fn arc(curvature: f64, reverse: bool, footprint: &Footprint, length_m: f64) -> SweptPath {
        let mut swept = SweptPath::default();
        swept.build(
            &PathAhead::Curvature { curvature, reverse },
            &north_at_origin(),
            footprint,
            length_m,
        );
        swept
    }

    /// A point at `radius_m` from the centre of a right turn of radius `r`
    /// that starts at the origin heading north, `angle_rad` round it.
    fn round_right_turn(r: f64, radius_m: f64, angle_rad: f64) -> Ned {
        // Centre is east of the origin; the origin is at angle π (west).
        let a = std::f64::consts::PI - angle_rad;
        Ned::new(radius_m * a.sin(), r + radius_m * a.cos())
    }

    #[test]
    fn samples_never_move_the_outline_further_than_the_step() {
        for curvature in [0.0, 0.05, 1.0 / 6.0, -0.4] {
            for reverse in [false, true] {
                let swept = arc(curvature, reverse, &AGV, 12.0);
                assert!(swept.step_m <= MAX_STEP_M + 1e-12);
                assert!(swept.length_m() >= 12.0 - 1e-9);
                let corners = [(3.6, 1.0), (3.6, -1.0), (-0.8, 1.0), (-0.8, -1.0)];
                let world = |s: &Sample, (x, y): (f64, f64)| {
                    (
                        s.north_m + x * s.cos_yaw - y * s.sin_yaw,
                        s.east_m + x * s.sin_yaw + y * s.cos_yaw,
                    )
                };
                for pair in swept.samples.windows(2) {
                    for c in corners {
                        let (a, b) = (world(&pair[0], c), world(&pair[1], c));
                        let moved = (a.0 - b.0).hypot(a.1 - b.1);
                        assert!(
                            moved <= swept.step_m + 1e-9,
                            "κ {curvature}: {moved} > {}",
                            swept.step_m
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn arc_inner_side_reaches_r_minus_half_width_and_no_further() {
        // Right turn of 6 m: the inner side passes 5 m from the centre
        // (the inner rear wheel's cut). Half-way round, a point 4.9 m from
        // the centre is in the sweep; one at 4.8 m minus the slack is not.
        let r = 6.0;
        let swept = arc(1.0 / r, false, &AGV, 10.0);
        let inside = round_right_turn(r, r - 1.0 + 0.1, 0.8);
        let clear = round_right_turn(r, r - 1.0 - 0.2 - swept.slack_m(), 0.8);
        assert!(swept.point_entry_m(inside, 0.0, 10.0).is_some());
        assert!(swept.point_entry_m(clear, 0.0, 10.0).is_none());
        // The same point beside a straight lane ahead is not in the way.
        let straight = arc(0.0, false, &AGV, 10.0);
        assert!(straight.point_entry_m(inside, 0.3, 10.0).is_none(), "{inside:?}");
    }

    #[test]
    fn a_point_the_inner_side_closes_in_on_gradually_counts_once_within_the_margin() {
        // Right turn of 6 m: the inner side is tangent to the 5 m circle at
        // the rear axle. A point 0.6 m ahead of the rear axle, inside that
        // circle, is 1 cm outside the margin now and ends 2.8 cm inside it:
        // less than NEARER_M nearer, yet it enters the margin.
        let r = 6.0;
        let swept = arc(1.0 / r, false, &AGV, 10.0);
        let margin_m = 0.3;
        let edge_m = margin_m + swept.slack_m();
        let ahead_m = 0.6;
        // Gap now 5 − ρ·cos φ with ρ·sin φ = ahead_m; the closest is 5 − ρ.
        let rho = |gap_now_m: f64| (r - 1.0 - gap_now_m).hypot(ahead_m);
        let point = |gap_now_m: f64| {
            let rho = rho(gap_now_m);
            let phi = (ahead_m / rho).asin();
            round_right_turn(r, rho, phi)
        };
        let entering = point(edge_m + 0.01);
        assert!(r - 1.0 - rho(edge_m + 0.01) < edge_m - 0.01);
        assert!(swept.point_entry_m(entering, margin_m, 10.0).is_some());
        // Already within the margin, and approached by less than NEARER_M:
        // beside the body, not in the way.
        let beside = point(edge_m - 0.01);
        assert!(swept.point_entry_m(beside, margin_m, 10.0).is_none());
    }

    #[test]
    fn arc_outer_side_reaches_the_front_corner_radius() {
        let r = 6.0;
        let swept = arc(1.0 / r, false, &AGV, 10.0);
        let corner_radius = ((r + 1.0) * (r + 1.0) + 3.6 * 3.6).sqrt();
        let angle = 1.2;
        assert!(
            swept
                .point_entry_m(round_right_turn(r, corner_radius - 0.05, angle), 0.0, 10.0)
                .is_some()
        );
        let beyond = round_right_turn(r, corner_radius + 0.05 + swept.slack_m(), angle);
        assert!(swept.point_entry_m(beyond, 0.0, 10.0).is_none());
    }

    #[test]
    fn a_turn_on_the_spot_sweeps_the_circle_of_the_farthest_corner() {
        // A skid-steer outline 0.5 m ahead and behind, 0.35 m half-width:
        // its corners sweep a circle of 0.61 m. Turning a quarter right
        // from north, a point 0.55 m east-north-east is hit; a straight run
        // north leaves it alone, and so does a small turn to the left.
        let robot = Footprint {
            front_m: 0.5,
            rear_m: 0.5,
            half_width_m: 0.35,
        };
        let reach = 0.5f64.hypot(0.35);
        let mut swept = SweptPath::default();
        let pivot = |swept: &mut SweptPath, to_yaw_rad: f64| {
            swept.build(&PathAhead::Pivot { to_yaw_rad }, &north_at_origin(), &robot, 0.1);
        };
        pivot(&mut swept, std::f64::consts::FRAC_PI_2);
        assert!((swept.length_m() - reach * std::f64::consts::FRAC_PI_2).abs() < swept.step_m);
        assert!(swept.step_m <= MAX_STEP_M + 1e-12);
        let angle = 60f64.to_radians();
        let point = Ned::new(0.55 * angle.cos(), 0.55 * angle.sin());
        let along = swept.point_entry_m(point, 0.0, 10.0).expect("in the turn's sweep");
        assert!(along < reach * angle, "{along}");
        let last = swept.pose(usize::MAX).unwrap();
        assert!(last.position == Ned::default() && (last.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        // Beyond the corners' circle (with the sampling slack) nothing is hit.
        let beyond = Ned::new(
            (reach + 0.02 + swept.slack_m()) * angle.cos(),
            (reach + 0.02 + swept.slack_m()) * angle.sin(),
        );
        assert!(swept.point_entry_m(beyond, 0.0, 10.0).is_none());
        pivot(&mut swept, -10f64.to_radians());
        assert!(swept.point_entry_m(point, 0.0, 10.0).is_none());
        assert!(arc(0.0, false, &robot, 2.0).point_entry_m(point, 0.0, 10.0).is_none());
    }

    #[test]
    fn tail_swings_out_of_the_turn() {
        // A long rear overhang: turning right, the rear swings left into a
        // point 0.2 m left of the body beside the overhang, which a
        // straight run leaves alone.
        let long_tail = Footprint {
            front_m: 1.0,
            rear_m: 2.0,
            half_width_m: 1.0,
        };
        let beside_tail = Ned::new(-1.0, -1.2);
        let turning = arc(1.0 / 3.0, false, &long_tail, 3.0);
        let along = turning
            .point_entry_m(beside_tail, 0.0, 3.0)
            .expect("the tail swings into it");
        assert!(along < 1.5, "{along}");
        assert!(
            arc(0.0, false, &long_tail, 3.0)
                .point_entry_m(beside_tail, 0.0, 3.0)
                .is_none()
        );
    }

    #[test]
    fn reversing_sweeps_behind() {
        let swept = arc(0.0, true, &AGV, 3.0);
        let behind = Ned::new(-0.8 - 1.0, 0.0);
        let along = swept.point_entry_m(behind, 0.0, 3.0).expect("behind the rear bumper");
        assert!((along - 1.0).abs() <= swept.ds_m + swept.slack_m(), "{along}");
        assert!(swept.point_entry_m(Ned::new(4.0, 0.0), 0.0, 3.0).is_none());
        // Reversing while turning right (steering the rear to the left).
        let turning = arc(0.25, true, &AGV, 3.0);
        assert!(
            turning
                .pose(turning.pose_count())
                .is_some_and(|p| p.position.east_m < -0.5)
        );
    }

    #[test]
    fn a_shape_judged_beyond_reach_never_comes_within_the_threshold() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (mut beyond, mut checked) = (0, 0);
        for _ in 0..400 {
            let curvature = rng.random_range(-0.3..0.3);
            let swept = arc(curvature, rng.random_bool(0.3), &AGV, rng.random_range(0.5..12.0));
            let centre = Ned::new(rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0));
            let radius_m = rng.random_range(0.1..1.0);
            let shape = Shape::Disc { centre, radius_m };
            let velocity: (f64, f64) = (rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5));
            let (speed_mps, horizon_s, threshold) = (rng.random_range(0.0..2.0), 4.0, 0.3);
            let obstacle_mps = velocity.0.hypot(velocity.1);
            if !swept.beyond_reach(centre, radius_m, obstacle_mps, threshold, horizon_s) {
                continue;
            }
            beyond += 1;
            // Every centimetre of the vehicle's or the shape's motion.
            let steps = ((speed_mps + obstacle_mps) * horizon_s / 0.01).ceil() as usize + 1;
            for k in 0..=steps {
                let t = horizon_s * k as f64 / steps as f64;
                let sample = swept.sample_at((speed_mps * t).min(swept.length_m()));
                let shift = (velocity.0 * t, velocity.1 * t);
                let gap = swept.shape_gap_at(&sample, &shape, radius_m, shift, f64::INFINITY);
                assert!(gap > threshold, "{centre:?} at {t} s: {gap}");
                checked += 1;
            }
        }
        assert!(beyond > 100 && checked > 10_000, "{beyond} shapes, {checked} instants");
    }

    #[test]
    fn polygon_gap_matches_faces_and_corners() {
        // A 0.8 m square 0.5 m right of the side, faces parallel.
        let square = [(1.0, 1.5), (1.8, 1.5), (1.8, 2.3), (1.0, 2.3)];
        assert!((polygon_rect_gap(&square, 3.6, 0.8, 1.0) - 0.5).abs() < 1e-12);
        // A diamond whose corner points at the side from 0.3 m.
        let diamond = [(2.0, 1.3), (2.4, 1.7), (2.0, 2.1), (1.6, 1.7)];
        assert!((polygon_rect_gap(&diamond, 3.6, 0.8, 1.0) - 0.3).abs() < 1e-12);
        // Overlapping without a corner inside either: a bar across the body.
        let bar = [(1.0, -3.0), (1.2, -3.0), (1.2, 3.0), (1.0, 3.0)];
        assert_eq!(polygon_rect_gap(&bar, 3.6, 0.8, 1.0), 0.0);
        // Beyond the front corner, diagonally.
        let far = [(4.6, 2.0), (5.0, 2.0), (5.0, 2.4), (4.6, 2.4)];
        assert!((polygon_rect_gap(&far, 3.6, 0.8, 1.0) - 1.0f64.hypot(1.0)).abs() < 1e-12);
    }

    #[test]
    fn a_person_inside_the_turn_is_met_round_the_arc() {
        let r = 6.0;
        let swept = arc(1.0 / r, false, &AGV, 10.0);
        let person = Shape::Disc {
            centre: round_right_turn(r, r - 1.2, 1.0),
            radius_m: 0.25,
        };
        let contact = swept
            .first_contact(&person, (0.0, 0.0), 1.1, 0.3, 10.0)
            .expect("contact");
        assert!(contact.closing && contact.time_s > 0.5, "{contact:?}");
        assert!((contact.time_s - contact.along_m / 1.1).abs() < 0.1, "{contact:?}");
        // Driving straight on, the same person is beside the lane.
        let straight = arc(0.0, false, &AGV, 10.0);
        assert!(straight.first_contact(&person, (0.0, 0.0), 1.1, 0.3, 10.0).is_none());
    }

    #[test]
    fn a_thing_just_beyond_the_margin_is_no_contact_on_a_straight_or_an_arc() {
        // A post of 0.25 m: 0.3 m margin, then 1 cm on either side of it.
        for (curvature, length_m) in [(0.0, 8.0), (1.0 / 6.0, 8.0), (-1.0 / 15.0, 8.0)] {
            let swept = arc(curvature, false, &AGV, length_m);
            for (gap_m, contact) in [(0.29, true), (0.31, false)] {
                // Beside the inner side of the arc half-way along it (on a
                // straight, beside the side at 4 m).
                let post = if curvature == 0.0 {
                    Ned::new(4.0, 1.0 + 0.25 + gap_m)
                } else {
                    let r = 1.0 / curvature.abs();
                    let c = round_right_turn(r, r - 1.0 - 0.25 - gap_m, 0.5 * length_m / r);
                    Ned::new(c.north_m, c.east_m * curvature.signum())
                };
                let shape = Shape::Disc {
                    centre: post,
                    radius_m: 0.25,
                };
                let found = swept.first_contact(&shape, (0.0, 0.0), 2.0, 0.3, 10.0);
                assert_eq!(found.is_some(), contact, "κ {curvature} gap {gap_m}: {found:?}");
            }
        }
    }

    #[test]
    fn someone_catching_up_from_behind_meets_a_vehicle_getting_under_way() {
        let straight = arc(0.0, false, &AGV, 12.0);
        // 1.5 m behind the rear bumper, walking after it at 1.4 m/s.
        let person = Shape::Disc {
            centre: Ned::new(-AGV.rear_m - 1.5 - 0.25, 0.0),
            radius_m: 0.25,
        };
        let at_speed = Drive {
            from_mps: 1.6,
            speed_mps: 1.6,
            accel_mps2: 0.5,
        };
        assert!(
            straight
                .first_contact_driving(&person, (1.4, 0.0), &at_speed, 0.3, 3.0)
                .is_none()
        );
        // From rest at 0.5 m/s² the gap is 1.5 − 1.4t + 0.25t²: within the
        // margin and the sampling slack (0.4 m) after 0.95 s.
        let from_rest = Drive {
            from_mps: 0.0,
            speed_mps: 1.6,
            accel_mps2: 0.5,
        };
        let contact = straight
            .first_contact_driving(&person, (1.4, 0.0), &from_rest, 0.3, 3.0)
            .expect("caught up");
        assert!(contact.time_s > 0.7 && contact.time_s < 1.2, "{contact:?}");
        assert!(contact.along_m < 0.5, "{contact:?}");
    }

    /// The path a vehicle 2 m beside a straight leg drives back onto it,
    /// turned 30° away from it and turning further away as it stopped (a
    /// stop in a corner): simulated from that pose with the default tracker,
    /// forwards or in reverse.
    fn rejoin_sweep(reverse: bool) -> (SweptPath, Vec<crate::guidance::tracker::VehiclePose>) {
        use crate::guidance::path::LegPath;
        use crate::guidance::rejoin::{RejoinLeg, RejoinSpeed, default_tracker_config, max_curvature, rejoin_poses};
        use crate::guidance::tracker::{Direction, TrackerState, VehiclePose};
        let config = default_tracker_config();
        let path = LegPath::new(None, Ned::new(0.0, 0.0), Ned::new(100.0, 0.0), None);
        let direction = if reverse {
            Direction::Reverse
        } else {
            Direction::Forward
        };
        let leg = RejoinLeg {
            path: &path,
            piece: 0,
            direction,
            stop: false,
            min_preview_m: 0.0,
        };
        let travel_rad = 30f64.to_radians();
        let start = VehiclePose {
            position: Ned::new(0.0, 2.0),
            yaw_rad: if reverse {
                wrap_pi(travel_rad + std::f64::consts::PI)
            } else {
                travel_rad
            },
        };
        let speed = RejoinSpeed {
            from_mps: 0.0,
            to_mps: 1.5,
            accel_mps2: 0.5,
        };
        let (length_m, curvature_max) = (10.0, max_curvature(&config));
        let ds_m = SweptPath::pose_spacing_m(&AGV, curvature_max, length_m);
        let mut poses = Vec::new();
        rejoin_poses(
            &config,
            TrackerState::default(),
            &leg,
            start,
            speed,
            (ds_m, length_m),
            &mut poses,
        );
        let mut swept = SweptPath::default();
        let as_poses = poses.iter().map(|p| Pose {
            position: p.position,
            yaw_rad: p.yaw_rad,
        });
        swept.build_from_poses(as_poses, ds_m, curvature_max, &AGV);
        assert!(swept.step_m <= MAX_STEP_M + 1e-12, "step {}", swept.step_m);
        (swept, poses)
    }

    /// Off the leg, the swept area is the way back onto it: a point on the
    /// rejoin curve is met, while the far side of the circle the vehicle was
    /// turning on when it stopped (5.5 m, away from the leg), which the
    /// current-curvature sweep met, is clear. Forwards and in reverse.
    #[test]
    fn off_the_leg_the_sweep_follows_the_way_back_not_the_turn_it_stopped_in() {
        for reverse in [false, true] {
            let (swept, poses) = rejoin_sweep(reverse);
            assert!(swept.pose_count() > 50, "{} poses", swept.pose_count());
            // Towards the leg (2 m off at the start), not away from it.
            let last = poses.last().unwrap();
            assert!(last.position.east_m.abs() < 1.0, "reverse {reverse}: ends {last:?}");
            // A point on the rejoin curve 6 m on, beside the reference point.
            let on_curve = poses[poses.len() * 6 / 10].position;
            let entry = swept.point_entry_m(on_curve, 0.3, swept.length_m());
            assert!(entry.is_some_and(|m| m < 6.0), "reverse {reverse}: {entry:?}");
            // The old sweep: carrying on round a 5.5 m circle away from the leg.
            let start = Pose {
                position: poses[0].position,
                yaw_rad: poses[0].yaw_rad,
            };
            let mut circle = SweptPath::default();
            let turning = PathAhead::Curvature {
                curvature: 1.0 / 5.5,
                reverse,
            };
            circle.build(&turning, &start, &AGV, 10.0);
            // The circle's far side: the reference point after 8 m of it.
            let far_side = circle.pose(circle.pose_count() * 8 / 10).unwrap().position;
            assert!(far_side.east_m > 6.0, "reverse {reverse}: {far_side:?}");
            assert!(circle.point_entry_m(far_side, 0.3, circle.length_m()).is_some());
            let entry = swept.point_entry_m(far_side, 0.3, swept.length_m());
            assert_eq!(entry, None, "reverse {reverse}: the rejoin sweep meets {far_side:?}");
        }
    }

    /// Whatever [`SweepReach`] rules out, the built rejoin path finds
    /// nothing of: returns at the fields' margin, and discs and boxes
    /// moving at up to 2 m/s over the horizon, resuming from rest. Enough of
    /// them are ruled out, and some found, for both answers to be tested.
    #[test]
    fn what_the_reach_rules_out_the_built_rejoin_path_never_finds() {
        use super::super::outline::{FitScratch, Outline};
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
        let square = [(-0.4, -0.4), (0.4, -0.4), (0.4, 0.4), (-0.4, 0.4)].map(|(n, e)| Ned::new(n, e));
        let outline =
            Outline::fit(&mut FitScratch::default(), Ned::default(), &square, (0.0, 0.0), |p| *p).expect("outline");
        let (margin_m, horizon_s) = (0.3, 4.0);
        let resume = Drive {
            from_mps: 0.0,
            speed_mps: 1.5,
            accel_mps2: 0.5,
        };
        let (mut ruled_out, mut found) = (0, 0);
        for reverse in [false, true] {
            let (swept, poses) = rejoin_sweep(reverse);
            let curvature_max =
                crate::guidance::rejoin::max_curvature(&crate::guidance::rejoin::default_tracker_config());
            let reach = SweepReach::of_poses(poses[0].position, swept.ds_m, curvature_max, &AGV, 10.0);
            for k in 0..3000 {
                // Every other one near the path (met), the rest over the
                // whole square round it (mostly near the reach's edge or beyond).
                let p = if k % 2 == 0 {
                    let near = poses[rng.random_range(0..poses.len())].position;
                    Ned::new(
                        near.north_m + rng.random_range(-5.0..5.0),
                        near.east_m + rng.random_range(-5.0..5.0),
                    )
                } else {
                    Ned::new(rng.random_range(-30.0..30.0), rng.random_range(-30.0..30.0))
                };
                let entry = swept.point_entry_m(p, margin_m, f64::INFINITY);
                found += usize::from(entry.is_some());
                if !reach.may_meet_point(p, margin_m) {
                    ruled_out += 1;
                    assert_eq!(entry, None, "reverse {reverse}: {p:?} ruled out, found");
                }
                let velocity = (rng.random_range(-1.4..1.4), rng.random_range(-1.4..1.4));
                let speed_mps = f64::hypot(velocity.0, velocity.1);
                let shapes = [
                    Shape::Disc {
                        centre: p,
                        radius_m: 0.3,
                    },
                    Shape::Polygon {
                        centre: p,
                        outline: &outline,
                    },
                ];
                for shape in &shapes {
                    let contact = swept.first_contact_driving(shape, velocity, &resume, margin_m, horizon_s);
                    found += usize::from(contact.is_some());
                    if !reach.may_meet_shape(shape, speed_mps, margin_m, horizon_s) {
                        ruled_out += 1;
                        assert_eq!(
                            contact, None,
                            "reverse {reverse}: {shape:?} at {velocity:?} ruled out, met"
                        );
                    }
                }
            }
        }
        assert!(ruled_out > 4000 && found > 2000, "{ruled_out} ruled out, {found} found");
    }
}
