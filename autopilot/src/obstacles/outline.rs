//! The shape of a tracked object that is not a person walking: a convex
//! polygon fitted to its returns, so clearance is measured to its faces
//! rather than to a disc of half its extent (a box's half-diagonal reaches
//! well past its faces).
//!
//! A scanner sees only the near side of an object. The polygon is the convex
//! hull of the returns together with the same returns moved away from the
//! scanner by `depth` (the hidden side assumed no deeper than the object is
//! wide): the faces seen (the L of a box's corner, a post's near arc) are
//! kept exactly, nothing is added on the scanner's side, and the unseen
//! back is covered. A hull with more corners than fit is
//! replaced by the polygon of its support lines in `MAX_VERTICES` directions
//! starting along its longest edge: a superset that overshoots a round
//! object by at most 1/cos(15°) − 1, 3.5 % (9 mm on a person).

use crate::geo::Ned;

/// Corners kept per outline.
pub const MAX_VERTICES: usize = 12;
/// Returns used per fit: a near cluster's are thinned to this many, evenly
/// by beam, which keeps its ends (its faces' extremes are what matter).
const MAX_POINTS: usize = 64;

/// The working buffers of [`Outline::fit`], kept by its caller between
/// fits: a fit then neither allocates nor clears two arrays sized for the
/// largest cluster (4 kB) for the few returns a person gives.
#[derive(Clone, Debug)]
pub struct FitScratch {
    points: Vec<(f64, f64)>,
    sorted: Vec<(f64, f64)>,
    hull: Vec<(f64, f64)>,
}

impl Default for FitScratch {
    fn default() -> Self {
        FitScratch {
            points: Vec::with_capacity(2 * MAX_POINTS + 2),
            sorted: Vec::with_capacity(2 * MAX_POINTS + 2),
            hull: Vec::with_capacity(2 * MAX_POINTS + 4),
        }
    }
}

/// A convex polygon, counter-clockwise in (north, east), as offsets from
/// the object's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outline {
    vertices: [(f64, f64); MAX_VERTICES],
    len: usize,
}

impl Outline {
    /// Fits the outline of `points` about `centre`, extended by `away`
    /// (north, east, m: the direction from the scanner times the depth).
    /// `None` without points or with a non-finite one.
    pub fn fit<T>(
        scratch: &mut FitScratch,
        centre: Ned,
        points: &[T],
        away: (f64, f64),
        position: impl Fn(&T) -> Ned,
    ) -> Option<Outline> {
        if points.is_empty() {
            return None;
        }
        let stride = points.len().div_ceil(MAX_POINTS);
        let FitScratch {
            points: buffer,
            sorted,
            hull,
        } = scratch;
        buffer.clear();
        let last = points.len() - 1;
        for (i, p) in points.iter().enumerate() {
            if i % stride != 0 && i != last {
                continue;
            }
            let p = position(p);
            let offset = (p.north_m - centre.north_m, p.east_m - centre.east_m);
            if !(offset.0.is_finite() && offset.1.is_finite()) {
                return None;
            }
            buffer.push(offset);
        }
        sort_with_moved(buffer, away, sorted);
        // The monotone chain writes at most one more corner than it is given.
        hull.clear();
        hull.resize(sorted.len() + 2, (0.0, 0.0));
        let hull_len = convex_hull_of_sorted(sorted, hull);
        let simplified = hull_len > MAX_VERTICES;
        let mut outline = simplify(&mut hull[..hull_len]);
        if stride > 1 || simplified {
            let offsets = points.iter().map(|p| {
                let p = position(p);
                (p.north_m - centre.north_m, p.east_m - centre.east_m)
            });
            let moved = offsets.clone().map(|o| (o.0 + away.0, o.1 + away.1));
            outline.cover(offsets.chain(moved));
        }
        Some(outline)
    }

    /// Scales the outline about its centre (inside it: the centre lies
    /// between the returns and their moved copies) until it holds every
    /// offset: the returns a thinned or simplified fit left out.
    fn cover(&mut self, offsets: impl Iterator<Item = (f64, f64)>) {
        let n = self.len;
        if n < 3 {
            return;
        }
        let mut scale: f64 = 1.0;
        for p in offsets {
            for i in 0..n {
                let (a, b) = (self.vertices[i], self.vertices[(i + 1) % n]);
                // Outward normal of a counter-clockwise edge, and the edge's
                // distance from the centre along it.
                let normal = (b.1 - a.1, a.0 - b.0);
                let edge = a.0 * normal.0 + a.1 * normal.1;
                if edge > 0.0 {
                    scale = scale.max((p.0 * normal.0 + p.1 * normal.1) / edge);
                }
            }
        }
        for v in &mut self.vertices[..n] {
            *v = (v.0 * scale, v.1 * scale);
        }
    }

    /// The corners, counter-clockwise with north as x and east as y.
    pub fn vertices(&self) -> &[(f64, f64)] {
        &self.vertices[..self.len]
    }

    /// The same outline about a centre `(north, east)` metres away from the
    /// one it was fitted about.
    pub fn shifted(&self, north_m: f64, east_m: f64) -> Outline {
        let mut moved = *self;
        for v in &mut moved.vertices[..self.len] {
            *v = (v.0 + north_m, v.1 + east_m);
        }
        moved
    }

    /// How far `p` (an offset from the centre, like the corners) lies
    /// outside the polygon, m: 0 on or inside it.
    pub fn distance_outside_m(&self, p: (f64, f64)) -> f64 {
        let v = self.vertices();
        match v.len() {
            0 => f64::INFINITY,
            1 => (p.0 - v[0].0).hypot(p.1 - v[0].1),
            n => {
                let inside = n >= 3 && (0..n).all(|i| cross(v[i], v[(i + 1) % n], p) >= 0.0);
                if inside {
                    return 0.0;
                }
                let mut offsets = [(0.0, 0.0); MAX_VERTICES];
                for (i, o) in offsets.iter_mut().enumerate().take(n) {
                    *o = segment_offset(v[i], v[(i + 1) % n], p);
                }
                least_length(&offsets[..n])
            }
        }
    }

    /// Largest distance of a corner from the centre: the `hypot` of the
    /// corners whose squared length is within 1e-9 of the largest only
    /// (the same value, as in [`least_length`], squares rounded to
    /// sub-normals included; every prediction asks it of every track's
    /// outline).
    pub fn radius_m(&self) -> f64 {
        let squared = |v: &(f64, f64)| v.0 * v.0 + v.1 * v.1;
        let vertices = self.vertices();
        let most_sq = vertices.iter().map(squared).fold(0.0, f64::max);
        let near_sq = most_sq * (1.0 - 1e-9) - f64::MIN_POSITIVE;
        vertices
            .iter()
            // A NaN length is kept, as the plain fold would see it.
            .filter(|v| {
                let sq = squared(v);
                sq >= near_sq || sq.is_nan()
            })
            .map(|v| v.0.hypot(v.1))
            .fold(0.0, f64::max)
    }
}

fn cross(o: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
}

/// Distance from `p` to the segment from `a` to `b` (plane coordinates).
pub(crate) fn segment_distance(a: (f64, f64), b: (f64, f64), p: (f64, f64)) -> f64 {
    let (x, y) = segment_offset(a, b, p);
    x.hypot(y)
}

/// The vector from the segment's nearest point to `p`.
pub(crate) fn segment_offset(a: (f64, f64), b: (f64, f64), p: (f64, f64)) -> (f64, f64) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len_sq = dx * dx + dy * dy;
    let t = if len_sq > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len_sq).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * dx, p.1 - a.1 - t * dy)
}

/// The least `hypot` of the vectors, with `hypot` (a libm call tens of
/// nanoseconds long) taken only of those whose squared length is within
/// 1e-9 of the least: the same value as the least `hypot` of them all,
/// since a squared length is within a few ulp of the true one.
pub(crate) fn least_length(vectors: &[(f64, f64)]) -> f64 {
    least_length_of(vectors.iter().copied())
}

/// [`least_length`] of vectors an iterator gives (walked twice).
pub(crate) fn least_length_of(vectors: impl Iterator<Item = (f64, f64)> + Clone) -> f64 {
    let squared = |v: &(f64, f64)| v.0 * v.0 + v.1 * v.1;
    let least_sq = vectors.clone().map(|v| squared(&v)).fold(f64::INFINITY, f64::min);
    let near_sq = least_sq * (1.0 + 1e-9) + f64::MIN_POSITIVE;
    vectors
        // A NaN length is kept, as the plain fold would see it.
        .filter(|v| {
            let sq = squared(v);
            sq <= near_sq || sq.is_nan()
        })
        .map(|v| v.0.hypot(v.1))
        .fold(f64::INFINITY, f64::min)
}

/// The order the monotone chain takes its points in: by north, then east.
fn lexicographic(a: &(f64, f64), b: &(f64, f64)) -> std::cmp::Ordering {
    a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1))
}

/// The returns' offsets (`returns`, sorted in place) and the same moved by
/// `away`, all sorted into `out`. The moved copies keep the returns' order
/// (unless rounding ties two of them: then they are sorted again), so two
/// sorted halves are merged instead of twice the points sorted: that sort
/// was most of a fit. Any sort gives the one order (points equal in it are
/// equal to the bit).
fn sort_with_moved(returns: &mut Vec<(f64, f64)>, away: (f64, f64), out: &mut Vec<(f64, f64)>) {
    returns.sort_unstable_by(lexicographic);
    let n = returns.len();
    for i in 0..n {
        let o = returns[i];
        returns.push((o.0 + away.0, o.1 + away.1));
    }
    let (own, moved) = returns.split_at_mut(n);
    if moved.windows(2).any(|w| lexicographic(&w[0], &w[1]).is_gt()) {
        moved.sort_unstable_by(lexicographic);
    }
    out.clear();
    let (mut i, mut j) = (0, 0);
    while i < own.len() && j < moved.len() {
        if lexicographic(&own[i], &moved[j]).is_gt() {
            out.push(moved[j]);
            j += 1;
        } else {
            out.push(own[i]);
            i += 1;
        }
    }
    out.extend_from_slice(&own[i..]);
    out.extend_from_slice(&moved[j..]);
}

/// Andrew's monotone chain: the hull of `points` (sorted by
/// [`lexicographic`]) into `out`, counter-clockwise (north as x, east as
/// y), no repeated point.
fn convex_hull_of_sorted(points: &[(f64, f64)], out: &mut [(f64, f64)]) -> usize {
    if points.len() < 3 {
        out[..points.len()].copy_from_slice(points);
        return points.len();
    }
    let mut k = 0;
    for &p in points.iter() {
        while k >= 2 && cross(out[k - 2], out[k - 1], p) <= 0.0 {
            k -= 1;
        }
        out[k] = p;
        k += 1;
    }
    let lower = k + 1;
    for &p in points.iter().rev().skip(1) {
        while k >= lower && cross(out[k - 2], out[k - 1], p) <= 0.0 {
            k -= 1;
        }
        out[k] = p;
        k += 1;
    }
    k - 1
}

/// Drops the corners that stick out least from the chord of their
/// neighbours until `MAX_VERTICES` are left, into an outline (inside the
/// hull by at most the largest deviation dropped: the caller scales it back
/// over the returns).
fn simplify(hull: &mut [(f64, f64)]) -> Outline {
    let mut n = hull.len();
    while n > MAX_VERTICES {
        let deviation = |i: usize| {
            let (a, p, b) = (hull[(i + n - 1) % n], hull[i], hull[(i + 1) % n]);
            let chord = (b.0 - a.0).hypot(b.1 - a.1);
            if chord > 0.0 { cross(a, b, p).abs() / chord } else { 0.0 }
        };
        let least = (0..n)
            .min_by(|&i, &j| deviation(i).total_cmp(&deviation(j)))
            .unwrap_or(0);
        hull.copy_within(least + 1..n, least);
        n -= 1;
    }
    let mut vertices = [(0.0, 0.0); MAX_VERTICES];
    vertices[..n].copy_from_slice(&hull[..n]);
    Outline { vertices, len: n }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_merged_sort_is_the_whole_sort() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for case in 0..5000 {
            let n = rng.random_range(1..=40);
            // A grid, so that ties and equal coordinates happen.
            let step = if rng.random_bool(0.5) { 0.01 } else { 0.1 };
            let returns: Vec<(f64, f64)> = (0..n)
                .map(|_| {
                    (
                        step * f64::from(rng.random_range(-20..20)),
                        step * f64::from(rng.random_range(-20..20)),
                    )
                })
                .collect();
            let away = (rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6));
            let mut whole: Vec<(f64, f64)> = returns
                .iter()
                .flat_map(|&o| [o, (o.0 + away.0, o.1 + away.1)])
                .collect();
            whole.sort_unstable_by(lexicographic);
            let (mut buffer, mut merged) = (returns.clone(), Vec::new());
            sort_with_moved(&mut buffer, away, &mut merged);
            let bits = |v: &[(f64, f64)]| v.iter().map(|p| (p.0.to_bits(), p.1.to_bits())).collect::<Vec<_>>();
            assert_eq!(bits(&merged), bits(&whole), "case {case}");
        }
    }

    #[test]
    fn radius_is_the_greatest_hypot_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for case in 0..2000 {
            let n = rng.random_range(1..=MAX_VERTICES);
            let mut vertices = [(0.0, 0.0); MAX_VERTICES];
            for v in vertices.iter_mut().take(n) {
                // Near-ties too: equal lengths in other directions.
                let r: f64 = if rng.random_bool(0.3) {
                    0.5
                } else {
                    rng.random_range(0.0..2.0)
                };
                let a: f64 = rng.random_range(-3.2..3.2);
                *v = (r * a.cos(), r * a.sin());
            }
            let outline = Outline { vertices, len: n };
            let every = outline.vertices().iter().map(|v| v.0.hypot(v.1)).fold(0.0, f64::max);
            assert_eq!(outline.radius_m().to_bits(), every.to_bits(), "case {case}");
        }
        let empty = Outline {
            vertices: [(0.0, 0.0); MAX_VERTICES],
            len: 0,
        };
        assert_eq!(empty.radius_m(), 0.0);
    }

    #[test]
    fn least_length_is_the_least_hypot_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..20_000 {
            let n = rng.random_range(1..=48);
            // Many nearly equal lengths (a point facing two edges alike),
            // and every scale from micrometres to kilometres.
            let scale = 10f64.powi(rng.random_range(-6..=3));
            let base: (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let vectors: Vec<(f64, f64)> = (0..n)
                .map(|_| {
                    let wobble = if rng.random_bool(0.5) { 1e-15 } else { 0.3 };
                    (
                        scale * (base.0 + wobble * rng.random_range(-1.0..1.0)),
                        scale * (base.1 + wobble * rng.random_range(-1.0..1.0)),
                    )
                })
                .collect();
            let every = vectors.iter().map(|v| v.0.hypot(v.1)).fold(f64::INFINITY, f64::min);
            assert_eq!(least_length(&vectors).to_bits(), every.to_bits(), "case {case}");
        }
        assert_eq!(least_length(&[]), f64::INFINITY);
        assert_eq!(least_length(&[(f64::NAN, 1.0), (3.0, 4.0)]), 5.0);
    }

    fn contains(outline: &Outline, p: (f64, f64)) -> bool {
        let v = outline.vertices();
        (0..v.len()).all(|i| cross(v[i], v[(i + 1) % v.len()], p) >= -1e-9)
    }

    #[test]
    fn an_l_of_a_box_gives_its_faces() {
        // The corner of a 0.8 m box at the origin, faces along north and east,
        // centre at (0.4, 0.4), seen from the south-west: the L's returns
        // moved 0.8 m north-east cover the box, and its seen faces stay put.
        let mut points = Vec::new();
        for i in 0..=16 {
            points.push(Ned::new(0.05 * f64::from(i), 0.0));
            points.push(Ned::new(0.0, 0.05 * f64::from(i)));
        }
        let outline = Outline::fit(
            &mut FitScratch::default(),
            Ned::new(0.4, 0.4),
            &points,
            (0.8, 0.8),
            |p| *p,
        )
        .expect("outline");
        let v = outline.vertices();
        let least = |f: fn(&(f64, f64)) -> f64| v.iter().map(f).fold(f64::INFINITY, f64::min);
        // The seen faces (south and west) are exactly where they are.
        assert!((least(|p| p.0) + 0.4).abs() < 1e-9, "{v:?}");
        assert!((least(|p| p.1) + 0.4).abs() < 1e-9, "{v:?}");
        for corner in [(-0.4, -0.4), (0.4, -0.4), (0.4, 0.4), (-0.4, 0.4)] {
            assert!(contains(&outline, corner), "{corner:?} outside {v:?}");
        }
    }

    #[test]
    fn a_dense_arc_becomes_a_tight_superset() {
        let r = 0.25;
        let points: Vec<Ned> = (0..=200)
            .map(|i| {
                let a = std::f64::consts::PI * f64::from(i) / 200.0;
                Ned::new(r * a.sin() - 0.0, r * a.cos())
            })
            .collect();
        let outline =
            Outline::fit(&mut FitScratch::default(), Ned::default(), &points, (0.0, 0.0), |p| *p).expect("outline");
        assert!(outline.vertices().len() <= MAX_VERTICES);
        for p in &points {
            assert!(contains(&outline, (p.north_m, p.east_m)), "{p:?} outside");
        }
        assert!(outline.radius_m() < r * 1.036, "{}", outline.radius_m());
    }

    #[test]
    fn distance_outside_is_zero_inside_and_to_the_nearest_face_beyond() {
        let square = [
            Ned::new(-0.5, -0.5),
            Ned::new(0.5, -0.5),
            Ned::new(0.5, 0.5),
            Ned::new(-0.5, 0.5),
        ];
        let outline =
            Outline::fit(&mut FitScratch::default(), Ned::default(), &square, (0.0, 0.0), |p| *p).expect("outline");
        assert_eq!(outline.distance_outside_m((0.2, -0.3)), 0.0);
        assert_eq!(outline.distance_outside_m((0.5, 0.0)), 0.0);
        assert!((outline.distance_outside_m((0.8, 0.1)) - 0.3).abs() < 1e-12);
        assert!((outline.distance_outside_m((0.8, 0.9)) - 0.5).abs() < 1e-12);
        assert!((outline.distance_outside_m((-0.5, -1.5)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn non_finite_points_fit_nothing() {
        assert!(
            Outline::fit(
                &mut FitScratch::default(),
                Ned::default(),
                &[Ned::new(f64::NAN, 0.0)],
                (0.0, 0.0),
                |p| *p
            )
            .is_none()
        );
        assert!(
            Outline::fit(
                &mut FitScratch::default(),
                Ned::default(),
                &[],
                (0.0, 0.0),
                |p: &Ned| *p
            )
            .is_none()
        );
    }
}
