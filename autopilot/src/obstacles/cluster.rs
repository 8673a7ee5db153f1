//! Scan → points in the local frame → clusters (seed 004 §III.A, eq. 1–2,
//! with the corrections below).
//!
//! # Points (eq. 1–2, corrected)
//! The seed writes a return as `O_i = d_i(cos θ_i, sin θ_i)` (eq. 1) and moves
//! it to the plant frame with `O = A + R(γ)·O_i + D(cos γ, sin γ)` (eq. 2).
//! What is wrong with that for a real vehicle, and what is done here:
//! - Its `θ_i` is measured from the scanner's horizontal x axis of a 0°–180°
//!   field, so straight ahead is θ = 90°, yet eq. 2 rotates by the vehicle
//!   heading γ alone, which turns every point by 90° unless the scanner's 0°
//!   happens to point along the heading. Our [`Scan`] angles are from the
//!   scanner's forward axis, and the scanner's own yaw on the vehicle
//!   ([`ScannerMount::yaw_rad`]) is added before anything else:
//!   body angle `φ = ψ_mount + α_i`.
//! - The offset `D(cos γ, sin γ)` puts the scanner on the heading line only.
//!   A real mount sits at `(x, y)` in the body frame (forward, right) and the
//!   offset turns with the whole body: `R(ψ)·(x, y)`. The reference point `A`
//!   is our rear axle centre, not a NAV-200 reflector scanner.
//! - Our yaw ψ is clockwise from north and points are (north, east). With that
//!   pair of conventions `R(ψ) = [[cos ψ, −sin ψ], [sin ψ, cos ψ]]` maps body
//!   (x forward, y right) to (north, east) — the matrix printed in eq. 2 —
//!   but it is only right for this axis order: with (east, north) components
//!   and a clockwise yaw the signs of the sines flip.
//!
//! So `body = (x_m, y_m) + ρ(cos φ, sin φ)` and
//! `local = position + R(ψ)·body`; the beam's bearing from north is `ψ + φ`.
//!
//! # Clusters
//! Beams are walked in order; a new cluster starts where two neighbouring
//! returns are further apart than a range-dependent gap or where a beam
//! between them had no echo. See [`cluster_points`] for the centroid
//! correction a one-sided view of a round object needs.
//!
//! Sources: docs/references.md §Seed 004.

use std::f64::consts::FRAC_PI_4;

use drivers::scanner::Scan;

use super::outline::{FitScratch, Outline};
use super::{Pose, ScannerMount};
use crate::geo::{Ned, wrap_pi};

/// Returns nearer than this are the scanner's own window or dirt on it.
pub const MIN_RANGE_M: f64 = 0.05;

/// One echo, in the local frame and in the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanPoint {
    pub position: Ned,
    pub range_m: f64,
    /// Bearing of the beam in the local frame: from north, clockwise.
    pub bearing_rad: f64,
    /// The same point in the vehicle body frame (x forward, y right), from
    /// the reference point.
    pub body_x_m: f64,
    pub body_y_m: f64,
    /// The beam's index in its scan: a jump in indices between neighbours
    /// means the beams between them saw nothing (or were refused).
    pub beam: usize,
}

/// Fills `out` (cleared first) with the scan's usable returns in beam order
/// and returns the scanner's position in the local frame. Beams with no echo
/// (NaN), nearer than [`MIN_RANGE_M`], beyond `max_range_m`, or that would
/// give a non-finite point (bad pose or angles) are skipped.
pub fn scan_points(
    scan: &Scan,
    pose: &Pose,
    mount: &ScannerMount,
    max_range_m: f64,
    angles: &mut BeamAngles,
    out: &mut Vec<ScanPoint>,
) -> Ned {
    out.clear();
    let beam_sin_cos = angles.of(scan, mount.yaw_rad);
    // Room for every beam at once: a reused buffer then never grows when
    // more of the scan starts to echo.
    out.reserve(scan.ranges_m.len());
    let (sin_yaw, cos_yaw) = pose.yaw_rad.sin_cos();
    let to_local = |x_m: f64, y_m: f64| {
        Ned::new(
            pose.position.north_m + x_m * cos_yaw - y_m * sin_yaw,
            pose.position.east_m + x_m * sin_yaw + y_m * cos_yaw,
        )
    };
    let sensor = to_local(mount.x_m, mount.y_m);
    for (beam, &range) in scan.ranges_m.iter().enumerate() {
        let range_m = f64::from(range);
        // Written so that NaN fails both comparisons.
        if !(range_m >= MIN_RANGE_M && range_m <= max_range_m) {
            continue;
        }
        let body_angle_rad = mount.yaw_rad + scan.angle_rad(beam);
        let (sin_a, cos_a) = beam_sin_cos[beam];
        let body_x_m = mount.x_m + range_m * cos_a;
        let body_y_m = mount.y_m + range_m * sin_a;
        let position = to_local(body_x_m, body_y_m);
        let bearing_rad = wrap_pi(pose.yaw_rad + body_angle_rad);
        if !(position.north_m.is_finite() && position.east_m.is_finite() && bearing_rad.is_finite()) {
            continue;
        }
        out.push(ScanPoint {
            position,
            range_m,
            bearing_rad,
            body_x_m,
            body_y_m,
            beam,
        });
    }
    sensor
}

/// The sine and cosine of every beam's body angle (the mount's yaw plus
/// the beam's angle in the scan), kept from scan to scan: a scanner's beam
/// angles stay the same, and a sin_cos per return each scan was a large
/// part of the core's time. Recomputed when the angles change.
#[derive(Clone, Debug, Default)]
pub struct BeamAngles {
    /// Mount yaw, start angle and step (their bits) and beam count.
    angles_of: Option<(u64, u64, u64, usize)>,
    sin_cos: Vec<(f64, f64)>,
}

impl BeamAngles {
    /// The (sin, cos) of each of the scan's beams seen from a mount at
    /// `mount_yaw_rad`: the values `(mount_yaw_rad + scan.angle_rad(beam)).sin_cos()`.
    fn of(&mut self, scan: &Scan, mount_yaw_rad: f64) -> &[(f64, f64)] {
        let beams = scan.ranges_m.len();
        let key = (
            mount_yaw_rad.to_bits(),
            scan.start_angle_rad.to_bits(),
            scan.step_rad.to_bits(),
            beams,
        );
        if self.angles_of != Some(key) {
            self.sin_cos.clear();
            self.sin_cos
                .extend((0..beams).map(|beam| (mount_yaw_rad + scan.angle_rad(beam)).sin_cos()));
            self.angles_of = Some(key);
        }
        &self.sin_cos
    }
}

/// How returns are grouped into objects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterConfig {
    /// Neighbouring returns further apart than this (m) start a new cluster…
    pub gap_m: f64,
    /// …or than this many metres per metre of range, whichever is larger:
    /// neighbouring beams at range r are r·|step| apart, so far away a fixed
    /// gap would cut one object into pieces. About 3·|step| (0.026 for a
    /// 0.5° scanner: 0.39 m at 15 m, where beams are 0.13 m apart and a
    /// round object's flanks spread its returns further in depth).
    pub gap_per_m: f64,
    /// Fewer returns than this are noise, not an object.
    pub min_points: usize,
    /// Clusters larger than this (m) are structure (walls, parked cars) and
    /// are not tracked.
    pub max_track_extent_m: f64,
    /// A cluster at least this long (m) whose returns all lie within
    /// `straight_tolerance_m` of its chord is structure too (a wall piece).
    pub straight_min_extent_m: f64,
    pub straight_tolerance_m: f64,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            gap_m: 0.15,
            gap_per_m: 0.026,
            min_points: 2,
            max_track_extent_m: 1.2,
            straight_min_extent_m: 0.3,
            straight_tolerance_m: 0.04,
        }
    }
}

/// A cluster whose chord lies within 25° of the beam is a surface seen
/// edge-on (cos 25°).
const EDGE_ON_COS: f64 = 0.906;

/// Shorter chords are judged neither way: two returns a few centimetres
/// apart can point anywhere after range noise (σ ≈ 2 cm).
const EDGE_ON_MIN_EXTENT_M: f64 = 0.08;

/// One group of neighbouring returns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// The object's estimated centre (see [`cluster_points`]); for structure,
    /// the plain mean of the returns.
    pub centroid: Ned,
    /// The return nearest the scanner.
    pub nearest: Ned,
    /// The returns of the first and last beam (the object's edges as seen).
    pub first: Ned,
    pub last: Ned,
    /// Largest distance from either edge return to any return, m.
    pub extent_m: f64,
    /// Estimated radius of the object, m.
    pub radius_m: f64,
    pub points: usize,
    /// Index of its first return in the points it was grouped from (its
    /// returns are the `points` from there on).
    pub first_point: usize,
    pub is_structure: bool,
    /// The object's shape fitted to its returns about `centroid` (not for
    /// structure, which is not tracked).
    pub outline: Option<Outline>,
    /// The beam just beyond one of its edges saw something nearer: part of
    /// the object may be hidden behind it, so its extent, radius and
    /// centroid are those of a sliver, not of the object.
    pub occluded: bool,
    /// It reaches the first or last beam of its scan: the edge of the field
    /// of view may cut it, and its extent and radius are a sliver's (see
    /// [`mark_field_edges`]).
    pub cut_by_field_edge: bool,
}

/// Groups `points` (one scanner's, in beam order, as [`scan_points`] gives
/// them) into clusters in `out` (cleared first). Clusters with fewer than
/// `min_points` returns are dropped. A scanner's first and last beams are
/// never joined (a 360° scanner's seam splits an object there).
///
/// # Centroid of a round object
/// A scanner sees only the near side of a person (or a leg, a post): the
/// returns lie on the front half-circle, spaced evenly in angle, so — seen
/// from a few radii away — evenly across the beam. The mean of
/// `√(R² − y²)` for `y` uniform in `[−R, R]` is `πR/4`: the mean of the
/// returns is 0.785·R nearer the scanner than the centre (not the R/2 often
/// quoted, nor the arc-length mean 2R/π, since the beams sample the arc
/// evenly in angle, not in length). That bias would not matter if it were
/// constant, but it depends on how much of the object is visible, which
/// changes as it moves. So non-structure clusters get their mean pushed
/// away from the scanner by `πR̂/4` along the scanner→mean bearing, with `R̂`
/// the estimated radius: half of (the visible extent plus one beam
/// spacing), since the true edges lie on average half a beam spacing
/// beyond the outermost returns.
pub fn cluster_points(points: &[ScanPoint], config: &ClusterConfig, fit: &mut FitScratch, out: &mut Vec<Cluster>) {
    out.clear();
    let mut start: usize = 0;
    for i in 1..=points.len() {
        if i == points.len() || splits(&points[i - 1], &points[i], config) {
            let before = start.checked_sub(1).and_then(|j| points.get(j));
            if let Some(mut cluster) = make_cluster(&points[start..i], config, fit) {
                cluster.first_point = start;
                cluster.occluded = hides(before, &points[start]) || hides(points.get(i), &points[i - 1]);
                out.push(cluster);
            }
            start = i;
        }
    }
}

/// Marks the clusters that reach the first or the last of a scan's `beams`
/// beams: the edge of the field of view may cut them. Whatever lies beyond
/// it is unseen, so such a cluster can be a sliver of its object: someone
/// walking into the blind zone beside the body shows only their edge on
/// the last beam, and that edge, taken for the whole person, shrinks the
/// track to a few centimetres that stay where the field ends (so the
/// person seems to stand still).
pub fn mark_field_edges(clusters: &mut [Cluster], points: &[ScanPoint], beams: usize) {
    let last_beam = beams.saturating_sub(1);
    for cluster in clusters.iter_mut() {
        let first = points.get(cluster.first_point);
        let last = (cluster.first_point + cluster.points)
            .checked_sub(1)
            .and_then(|i| points.get(i));
        if first.is_some_and(|p| p.beam == 0) || last.is_some_and(|p| p.beam >= last_beam) {
            cluster.cut_by_field_edge = true;
        }
    }
}

/// Whether two returns of successive usable beams belong to different objects.
///
/// One beam without an echo between two returns that are close enough for
/// the two beam steps between them is a dropout (dust, a dark patch), not a
/// gap between objects: splitting there would cut a person in two, and the
/// half off the track's gate would give birth to a second track.
fn splits(a: &ScanPoint, b: &ScanPoint, config: &ClusterConfig) -> bool {
    let steps = match b.beam.checked_sub(a.beam) {
        Some(1) => 1.0,
        Some(2) => 2.0,
        _ => return true,
    };
    // The nearer range: where a near object stands in front of a far one,
    // the gap that separates them must be the near object's.
    let range_m = a.range_m.min(b.range_m);
    let gap_m = steps * config.gap_m.max(config.gap_per_m * range_m);
    // A NaN distance splits.
    !at_most(squared_distance(&a.position, &b.position), gap_m * gap_m)
}

fn squared_distance(a: &Ned, b: &Ned) -> f64 {
    let (dn, de) = (b.north_m - a.north_m, b.east_m - a.east_m);
    dn * dn + de * de
}

/// `value ≤ limit`, false when either is NaN.
fn at_most(value: f64, limit: f64) -> bool {
    value <= limit
}

/// Whether `neighbour`, a return of the beam next to `edge`'s, stands in
/// front of it. A missing echo beside an edge hides nothing.
fn hides(neighbour: Option<&ScanPoint>, edge: &ScanPoint) -> bool {
    neighbour.is_some_and(|n| n.beam.abs_diff(edge.beam) == 1 && n.range_m < edge.range_m)
}

fn make_cluster(points: &[ScanPoint], config: &ClusterConfig, fit: &mut FitScratch) -> Option<Cluster> {
    let (first, last) = (points.first()?, points.last()?);
    if points.len() < config.min_points {
        return None;
    }
    // Every return knows its beam: the scanner is where the beam started.
    let (sin_b, cos_b) = first.bearing_rad.sin_cos();
    let sensor = Ned::new(
        first.position.north_m - first.range_m * cos_b,
        first.position.east_m - first.range_m * sin_b,
    );
    let Returns {
        mean,
        mean_range_m,
        nearest,
        extent_m,
    } = summarise(points, first, last);
    let beams = (last.beam - first.beam) as f64;
    let beam_spacing_m = if beams > 0.0 {
        mean_range_m * wrap_pi(last.bearing_rad - first.bearing_rad).abs() / beams
    } else {
        0.0
    };
    let radius_m = 0.5 * (extent_m + beam_spacing_m);
    // Once per cluster, for every test and fit below: an atan2 and a sin_cos
    // per use were a good share of the scan's cost.
    let chord_m = first.position.distance_to(&last.position);
    let towards_mean = sensor.bearing_to(&mean).sin_cos();
    // A straight run of returns is a piece of wall or a box's face, not a
    // person or a post (a body seen by a scanner shows a curved near side):
    // tracking it would turn the pieces a moving scanner sees of one wall
    // into objects that seem to move with the vehicle.
    let straight = is_straight(points, (extent_m, chord_m), config);
    // A surface seen edge-on (a car's rear face or a wall end as the
    // scanner passes its plane) returns points strung out along the beam;
    // a body's near side faces the scanner, its returns spread across the
    // beam. Such slivers change with every metre the vehicle drives and
    // would look like objects sliding sideways.
    let edge_on = is_edge_on(points, (extent_m, chord_m), towards_mean);
    let is_structure = extent_m > config.max_track_extent_m || straight || edge_on;
    let centroid = if is_structure {
        mean
    } else {
        body_centre(mean, towards_mean, radius_m)
    };
    Some(Cluster {
        centroid,
        nearest: nearest.position,
        first: first.position,
        last: last.position,
        extent_m,
        radius_m,
        points: points.len(),
        first_point: 0,
        is_structure,
        outline: if is_structure {
            None
        } else {
            let (sin_m, cos_m) = towards_mean;
            Outline::fit(fit, centroid, points, (extent_m * cos_m, extent_m * sin_m), |p| {
                p.position
            })
        },
        occluded: false,
        cut_by_field_edge: false,
    })
}

/// What a cluster's returns add up to.
struct Returns<'a> {
    mean: Ned,
    mean_range_m: f64,
    nearest: &'a ScanPoint,
    /// The longest distance from a return to either edge return.
    extent_m: f64,
}

fn summarise<'a>(points: &'a [ScanPoint], first: &'a ScanPoint, last: &'a ScanPoint) -> Returns<'a> {
    let n = points.len() as f64;
    let (mut sum_n, mut sum_e, mut sum_range) = (0.0, 0.0, 0.0);
    let mut nearest = first;
    // The farthest (return, edge) pair by squared distance, one root at the
    // end: a root per return was a good share of the scan's cost.
    let (mut farthest_sq, mut farthest) = (0.0, (first, first));
    for p in points {
        sum_n += p.position.north_m;
        sum_e += p.position.east_m;
        sum_range += p.range_m;
        if p.range_m < nearest.range_m {
            nearest = p;
        }
        // Both edges: an L-shaped return (a corner) is longer than its chord.
        for edge in [first, last] {
            let d_sq = squared_distance(&p.position, &edge.position);
            if d_sq > farthest_sq {
                (farthest_sq, farthest) = (d_sq, (p, edge));
            }
        }
    }
    Returns {
        mean: Ned::new(sum_n / n, sum_e / n),
        mean_range_m: sum_range / n,
        nearest,
        extent_m: farthest.0.position.distance_to(&farthest.1.position),
    }
}

/// A body's centre lies behind its visible near side: the returns' mean
/// pushed away from the scanner by π/4 of the radius (`towards_mean`: the
/// sine and cosine of the bearing from the scanner to the mean).
fn body_centre(mean: Ned, towards_mean: (f64, f64), radius_m: f64) -> Ned {
    let push_m = FRAC_PI_4 * radius_m;
    let (sin_m, cos_m) = towards_mean;
    Ned::new(mean.north_m + push_m * cos_m, mean.east_m + push_m * sin_m)
}

/// Whether the returns lie on a straight line (within the tolerance) over
/// at least the straight run's minimum extent (`chord_m`: the distance
/// between the first and the last return).
fn is_straight(points: &[ScanPoint], (extent_m, chord_m): (f64, f64), config: &ClusterConfig) -> bool {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return false;
    };
    extent_m >= config.straight_min_extent_m && {
        let (dn, de) = (
            last.position.north_m - first.position.north_m,
            last.position.east_m - first.position.east_m,
        );
        chord_m > 0.0
            && points.iter().all(|p| {
                let (pn, pe) = (
                    p.position.north_m - first.position.north_m,
                    p.position.east_m - first.position.east_m,
                );
                ((pn * de - pe * dn) / chord_m).abs() <= config.straight_tolerance_m
            })
    }
}

/// Whether the returns are strung out along the beam from the scanner to
/// their mean (`towards_mean`: the sine and cosine of its bearing) rather
/// than across it.
fn is_edge_on(points: &[ScanPoint], (extent_m, chord_m): (f64, f64), towards_mean: (f64, f64)) -> bool {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return false;
    };
    points.len() >= 2 && extent_m > EDGE_ON_MIN_EXTENT_M && {
        let (dn, de) = (
            last.position.north_m - first.position.north_m,
            last.position.east_m - first.position.east_m,
        );
        let (sin_b, cos_b) = towards_mean;
        chord_m > 0.0 && ((dn * cos_b + de * sin_b) / chord_m).abs() > EDGE_ON_COS
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, PI};
    use std::time::Duration;

    use super::*;

    const STEP_RAD: f64 = 0.5 * PI / 180.0;

    /// A 270° scan from a scanner at the origin looking north, of circles
    /// `(north, east, radius)` and of one optional wall segment.
    fn ray_cast(circles: &[(f64, f64, f64)], wall: Option<(Ned, Ned)>) -> Scan {
        let start = -0.75 * PI;
        let beams = (1.5 * PI / STEP_RAD).round() as usize + 1;
        let ranges_m = (0..beams)
            .map(|i| {
                let a = start + i as f64 * STEP_RAD;
                let (dn, de) = (a.cos(), a.sin());
                let mut best = f64::INFINITY;
                for &(cn, ce, r) in circles {
                    // |t·d − c|² = r², nearest positive root.
                    let b = dn * cn + de * ce;
                    let disc = b * b - (cn * cn + ce * ce - r * r);
                    if disc >= 0.0 && b - disc.sqrt() > 0.0 {
                        best = best.min(b - disc.sqrt());
                    }
                }
                if let Some((p, q)) = wall {
                    let (un, ue) = (q.north_m - p.north_m, q.east_m - p.east_m);
                    let den = dn * ue - de * un;
                    if den.abs() > 1e-12 {
                        let t = (p.north_m * ue - p.east_m * un) / den;
                        let s = (p.north_m * de - p.east_m * dn) / den;
                        if t > 0.0 && (0.0..=1.0).contains(&s) {
                            best = best.min(t);
                        }
                    }
                }
                if best <= 20.0 { best as f32 } else { f32::NAN }
            })
            .collect();
        Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad: start,
            step_rad: STEP_RAD,
            ranges_m,
        }
    }

    fn clusters_of(scan: &Scan) -> Vec<Cluster> {
        points_and_clusters(scan).1
    }

    fn points_and_clusters(scan: &Scan) -> (Vec<ScanPoint>, Vec<Cluster>) {
        let mut points = Vec::new();
        scan_points(
            scan,
            &Pose::default(),
            &ScannerMount::default(),
            20.0,
            &mut BeamAngles::default(),
            &mut points,
        );
        let mut clusters = Vec::new();
        cluster_points(
            &points,
            &ClusterConfig::default(),
            &mut FitScratch::default(),
            &mut clusters,
        );
        (points, clusters)
    }

    #[test]
    fn mount_offset_and_yaw_and_vehicle_yaw() {
        // Vehicle at (10, −5) facing east; scanner 1 m ahead of the axle and
        // 0.5 m to the right, turned to look right. Its forward beam at 2 m
        // looks south from a scanner 1 m east and 0.5 m south of the axle.
        let pose = Pose {
            position: Ned::new(10.0, -5.0),
            yaw_rad: FRAC_PI_2,
        };
        let mount = ScannerMount {
            x_m: 1.0,
            y_m: 0.5,
            yaw_rad: FRAC_PI_2,
        };
        let scan = Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad: 0.0,
            step_rad: FRAC_PI_2,
            ranges_m: vec![2.0, 3.0],
        };
        let mut out = Vec::new();
        let sensor = scan_points(&scan, &pose, &mount, 20.0, &mut BeamAngles::default(), &mut out);
        assert!(sensor.distance_to(&Ned::new(9.5, -4.0)) < 1e-12, "{sensor:?}");
        assert_eq!(out.len(), 2);
        let p = out[0];
        assert!(p.position.distance_to(&Ned::new(7.5, -4.0)) < 1e-12, "{p:?}");
        assert!((p.bearing_rad.abs() - PI).abs() < 1e-12);
        assert!((p.body_x_m - 1.0).abs() < 1e-12 && (p.body_y_m - 2.5).abs() < 1e-12);
        // The next beam is 90° further clockwise: west, i.e. behind the vehicle.
        let q = out[1];
        assert!(q.position.distance_to(&Ned::new(9.5, -7.0)) < 1e-12, "{q:?}");
        assert!((q.bearing_rad + FRAC_PI_2).abs() < 1e-12);
        assert!((q.body_x_m + 2.0).abs() < 1e-12 && (q.body_y_m - 0.5).abs() < 1e-12);
        // The seed's eq. 2 (offset along the heading only, no mount yaw)
        // would put the first point 1.5 m away from where it is.
        let seed = Ned::new(10.0 + 0.0, -5.0 + 1.0 + 2.0);
        assert!(seed.distance_to(&p.position) > 1.0);
    }

    #[test]
    fn every_point_is_at_its_range_and_bearing_from_the_sensor() {
        let pose = Pose {
            position: Ned::new(-3.0, 7.0),
            yaw_rad: -2.4,
        };
        let mount = ScannerMount {
            x_m: -0.4,
            y_m: -0.3,
            yaw_rad: PI,
        };
        let scan = Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad: 1.2,
            step_rad: -0.3,
            ranges_m: vec![1.0, 2.5, 4.0, 7.5, 12.0],
        };
        let mut out = Vec::new();
        let sensor = scan_points(&scan, &pose, &mount, 20.0, &mut BeamAngles::default(), &mut out);
        for p in &out {
            assert!((sensor.distance_to(&p.position) - p.range_m).abs() < 1e-9);
            assert!(wrap_pi(sensor.bearing_to(&p.position) - p.bearing_rad).abs() < 1e-9);
            // Body → local by the vehicle pose alone gives the same point.
            let back = Ned::new(
                pose.position.north_m + p.body_x_m * pose.yaw_rad.cos() - p.body_y_m * pose.yaw_rad.sin(),
                pose.position.east_m + p.body_x_m * pose.yaw_rad.sin() + p.body_y_m * pose.yaw_rad.cos(),
            );
            assert!(back.distance_to(&p.position) < 1e-9);
        }
    }

    #[test]
    fn kept_beam_angles_give_the_points_fresh_ones_give_when_the_mount_or_scan_changes() {
        let pose = Pose {
            position: Ned::new(1.0, -2.0),
            yaw_rad: 0.7,
        };
        let scan = |start_angle_rad: f64, step_rad: f64, beams: usize| Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad,
            step_rad,
            ranges_m: (0..beams).map(|i| 1.0 + 0.5 * i as f32).collect(),
        };
        let mount = |yaw_rad: f64| ScannerMount {
            x_m: 0.3,
            y_m: 0.1,
            yaw_rad,
        };
        let mut kept = BeamAngles::default();
        let (mut with_kept, mut with_fresh) = (Vec::new(), Vec::new());
        for (scan, mount) in [
            (scan(-1.0, 0.25, 9), mount(0.0)),
            (scan(-1.0, 0.25, 9), mount(0.0)),
            (scan(-1.0, 0.25, 9), mount(PI)),
            (scan(-0.5, 0.25, 9), mount(PI)),
            (scan(-0.5, 0.125, 9), mount(PI)),
            (scan(-0.5, 0.125, 12), mount(PI)),
        ] {
            let a = scan_points(&scan, &pose, &mount, 20.0, &mut kept, &mut with_kept);
            let b = scan_points(&scan, &pose, &mount, 20.0, &mut BeamAngles::default(), &mut with_fresh);
            assert_eq!(a, b);
            assert_eq!(with_kept, with_fresh);
            assert_eq!(with_kept.len(), scan.ranges_m.len());
        }
    }

    #[test]
    fn skips_missing_near_and_far_returns() {
        let scan = Scan {
            t: Duration::ZERO,
            scan_counter: 0,
            start_angle_rad: 0.0,
            step_rad: 0.01,
            ranges_m: vec![f32::NAN, 0.04, 0.06, 19.0, 21.0, f32::INFINITY, 5.0],
        };
        let mut out = vec![];
        scan_points(
            &scan,
            &Pose::default(),
            &ScannerMount::default(),
            20.0,
            &mut BeamAngles::default(),
            &mut out,
        );
        let beams: Vec<usize> = out.iter().map(|p| p.beam).collect();
        assert_eq!(beams, vec![2, 3, 6]);
    }

    #[test]
    fn two_people_half_a_metre_apart_are_two_clusters() {
        // Radius 0.25 each, 0.5 m of free space between them, 3 m ahead.
        let clusters = clusters_of(&ray_cast(&[(3.0, -0.5, 0.25), (3.0, 0.5, 0.25)], None));
        assert_eq!(clusters.len(), 2, "{clusters:?}");
        for (c, east) in clusters.iter().zip([-0.5, 0.5]) {
            assert!(!c.is_structure);
            assert!(c.centroid.distance_to(&Ned::new(3.0, east)) < 0.03, "{c:?}");
            assert!((c.radius_m - 0.25).abs() < 0.03, "{c:?}");
        }
    }

    #[test]
    fn a_person_in_front_of_a_wall_is_not_merged_with_it() {
        let wall = (Ned::new(4.0, -4.0), Ned::new(4.0, 4.0));
        let clusters = clusters_of(&ray_cast(&[(3.0, 0.0, 0.25)], Some(wall)));
        let people: Vec<_> = clusters.iter().filter(|c| !c.is_structure).collect();
        assert_eq!(people.len(), 1, "{clusters:?}");
        assert!(people[0].centroid.distance_to(&Ned::new(3.0, 0.0)) < 0.03);
        // The wall is cut in two by the person's shadow; both halves are structure.
        assert_eq!(clusters.iter().filter(|c| c.is_structure).count(), 2);
    }

    #[test]
    fn a_person_partly_behind_another_is_occluded() {
        // The near one hides the right half of the far one.
        let clusters = clusters_of(&ray_cast(&[(3.0, 0.0, 0.25), (5.0, 0.3, 0.25)], None));
        assert_eq!(clusters.len(), 2, "{clusters:?}");
        // The scanner is at the origin.
        let range_m = |c: &Cluster| c.centroid.distance_to(&Ned::default());
        let (near, far) = if range_m(&clusters[0]) < range_m(&clusters[1]) {
            (clusters[0], clusters[1])
        } else {
            (clusters[1], clusters[0])
        };
        assert!(!near.occluded && far.occluded, "{clusters:?}");
        assert!(far.radius_m < 0.2, "{far:?}");
        // Apart, neither is.
        let clusters = clusters_of(&ray_cast(&[(3.0, 0.0, 0.25), (5.0, 1.3, 0.25)], None));
        assert!(clusters.iter().all(|c| !c.occluded), "{clusters:?}");
    }

    #[test]
    fn a_person_cut_by_the_field_edge_is_marked() {
        // 270° from north: the last beam looks 135° right, south-east. A
        // person astride it shows only the part before the edge.
        let scan = ray_cast(&[(-2.0, 2.0, 0.25), (3.0, 0.0, 0.25)], None);
        let (points, mut clusters) = points_and_clusters(&scan);
        assert!(clusters.iter().all(|c| !c.cut_by_field_edge), "{clusters:?}");
        mark_field_edges(&mut clusters, &points, scan.ranges_m.len());
        let cut: Vec<_> = clusters.iter().filter(|c| c.cut_by_field_edge).collect();
        assert_eq!(cut.len(), 1, "{clusters:?}");
        assert!(cut[0].centroid.distance_to(&Ned::new(-2.0, 2.0)) < 0.5, "{cut:?}");
        assert!(cut[0].radius_m < 0.2, "only a sliver is seen: {cut:?}");
    }

    #[test]
    fn a_wall_is_one_structure_cluster() {
        let clusters = clusters_of(&ray_cast(&[], Some((Ned::new(4.0, -3.0), Ned::new(4.0, 3.0)))));
        assert_eq!(clusters.len(), 1, "{clusters:?}");
        let wall = clusters[0];
        assert!(wall.is_structure);
        assert!((wall.extent_m - 6.0).abs() < 0.1, "{wall:?}");
        assert!(wall.nearest.distance_to(&Ned::new(4.0, 0.0)) < 0.04);
    }

    #[test]
    fn a_wall_seen_at_a_grazing_angle_is_structure_to_its_far_tip() {
        // A corridor wall 1.6 m to the left: far along it the beams hit so
        // obliquely that it breaks into fragments of a few returns.
        let wall = (Ned::new(0.5, -1.6), Ned::new(19.0, -1.6));
        let mut scan = ray_cast(&[], Some(wall));
        // A scanner's range noise (about ±2 cm, deterministic here) bends
        // the short fragments so that they are not straight runs.
        for (i, r) in scan.ranges_m.iter_mut().enumerate() {
            *r += 0.02 * (i as f32 * 1.7).sin();
        }
        let mut points = Vec::new();
        scan_points(
            &scan,
            &Pose::default(),
            &ScannerMount::default(),
            20.0,
            &mut BeamAngles::default(),
            &mut points,
        );
        let config = ClusterConfig::default();
        let breaks = points.windows(2).filter(|w| splits(&w[0], &w[1], &config)).count();
        assert!(breaks > 3, "the wall does break up ({breaks} breaks)");
        let clusters = clusters_of(&scan);
        let loose: Vec<_> = clusters.iter().filter(|c| !c.is_structure).collect();
        assert!(loose.is_empty(), "{loose:?}");
        // A person standing 0.6 m off that wall is still a person.
        let clusters = clusters_of(&ray_cast(&[(8.0, -0.75, 0.25)], Some(wall)));
        let people: Vec<_> = clusters.iter().filter(|c| !c.is_structure).collect();
        assert_eq!(people.len(), 1, "{clusters:?}");
        assert!(
            people[0].centroid.distance_to(&Ned::new(8.0, -0.75)) < 0.1,
            "{people:?}"
        );
    }

    #[test]
    fn a_surface_seen_edge_on_is_structure() {
        // Three returns of neighbouring beams strung 6 cm apart along the
        // beam (a car's rear face seen almost along its plane): too short
        // to be judged straight, yet no body returns such a sliver.
        let along = |ranges: &[f64], step_rad: f64| -> Vec<ScanPoint> {
            ranges
                .iter()
                .enumerate()
                .map(|(beam, &range_m)| {
                    let bearing_rad = -1.2 + beam as f64 * step_rad;
                    let position = Ned::new(range_m * bearing_rad.cos(), range_m * bearing_rad.sin());
                    ScanPoint {
                        position,
                        range_m,
                        bearing_rad,
                        body_x_m: position.north_m,
                        body_y_m: position.east_m,
                        beam,
                    }
                })
                .collect()
        };
        let mut out = Vec::new();
        cluster_points(
            &along(&[3.0, 3.06, 3.12], STEP_RAD),
            &ClusterConfig::default(),
            &mut FitScratch::default(),
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert!(out[0].is_structure, "{out:?}");
        // Returns spread across the beam (a body's near side) are not.
        cluster_points(
            &along(&[3.0, 2.98, 3.0], 0.04),
            &ClusterConfig::default(),
            &mut FitScratch::default(),
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert!(!out[0].is_structure, "{out:?}");
    }

    #[test]
    fn a_person_at_fifteen_metres_is_one_cluster() {
        // Beams are 15 · 0.5° = 0.131 m apart there, and the flanks add depth.
        for k in 0..20 {
            // Slide across the beams so every phase of the sampling is tried.
            let east = k as f64 * 0.0065;
            let clusters = clusters_of(&ray_cast(&[(15.0, east, 0.25)], None));
            assert_eq!(clusters.len(), 1, "at {east}: {clusters:?}");
            assert!(!clusters[0].is_structure);
            assert!(clusters[0].centroid.distance_to(&Ned::new(15.0, east)) < 0.1);
        }
    }

    #[test]
    fn the_centroid_correction_removes_the_near_side_bias() {
        let (mut raw_err, mut corrected_err) = (0.0f64, 0.0f64);
        for k in 0..20 {
            let centre = Ned::new(2.0 + 0.2 * k as f64, -0.3 + 0.031 * k as f64);
            let clusters = clusters_of(&ray_cast(&[(centre.north_m, centre.east_m, 0.25)], None));
            assert_eq!(clusters.len(), 1);
            let c = clusters[0];
            let push = FRAC_PI_4 * c.radius_m;
            raw_err = raw_err.max((c.centroid.distance_to(&centre) - push).abs());
            corrected_err = corrected_err.max(c.centroid.distance_to(&centre));
        }
        // The raw mean is ~0.2 m short; corrected, the centre is within 3 cm
        // (what is left comes from where the edge beams happen to fall).
        assert!(raw_err > 0.15, "{raw_err}");
        assert!(corrected_err < 0.03, "{corrected_err}");
    }

    #[test]
    fn a_dropout_joins_two_missing_beams_split_and_tiny_clusters_are_dropped() {
        let mut scan = ray_cast(&[(3.0, 0.0, 0.25)], None);
        let hits: Vec<usize> = (0..scan.ranges_m.len())
            .filter(|&i| scan.ranges_m[i].is_finite())
            .collect();
        let middle = hits[hits.len() / 2];
        scan.ranges_m[middle] = f32::NAN;
        // An isolated single return elsewhere is noise.
        scan.ranges_m[0] = 5.0;
        let clusters = clusters_of(&scan);
        assert_eq!(
            clusters.len(),
            1,
            "one dropout does not cut the person in two: {clusters:?}"
        );
        assert!((clusters[0].centroid.north_m - 3.0).abs() < 0.05, "{clusters:?}");
        scan.ranges_m[middle + 1] = f32::NAN;
        let clusters = clusters_of(&scan);
        assert_eq!(clusters.len(), 2, "two missing beams are a gap: {clusters:?}");
        let mut out = vec![];
        cluster_points(&[], &ClusterConfig::default(), &mut FitScratch::default(), &mut out);
        assert!(out.is_empty());
    }
}
