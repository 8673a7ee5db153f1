//! An edge's `trajectory` (§6.6.6): a NURBS curve in the map frame,
//! checked, evaluated, and turned into the chords the navigator drives
//! (each a leg driven through, round a corner arc, onto the next).
//!
//! Evaluation is de Boor's algorithm on the control points in homogeneous
//! coordinates (x·w, y·w, w), which gives the rational curve exactly
//! (Piegl & Tiller, The NURBS Book, A4.1 with A2.1's span search).
//!
//! Pure; no clock.

use std::cmp::Ordering;

use vda5050::common::Trajectory;

use crate::obstacles::outline::segment_distance;

/// Beyond these the factsheet's protocol limits refuse a trajectory.
pub const MAX_CONTROL_POINTS: usize = 100;
pub const MAX_DEGREE: u32 = 10;
/// The chords stay within this of the curve (m).
pub const CHORD_TOLERANCE_M: f64 = 0.01;
/// The curve is first sampled this many times between two knots, so that
/// no bend between two samples goes unseen, then split where needed.
const SAMPLES_PER_SPAN: usize = 4;
/// A chord is split at most this many times over.
const MAX_SPLIT_DEPTH: u32 = 12;
/// The radius of curvature is measured through this many points per knot
/// span (plenty for a span of degree 10, which bends at most 9 times).
const RADIUS_SAMPLES_PER_SPAN: usize = 64;

/// A checked NURBS curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Nurbs {
    degree: usize,
    knots: Vec<f64>,
    /// (x·w, y·w, w).
    weighted: Vec<[f64; 3]>,
}

impl Nurbs {
    /// Checks `trajectory`: at least degree + 1 control points, a knot
    /// vector of control points + degree + 1 non-decreasing knots with a
    /// non-empty domain, finite coordinates and positive weights (a weight
    /// of 0 the schema allows would divide by zero). The error says what is
    /// wrong.
    pub fn new(trajectory: &Trajectory) -> Result<Nurbs, String> {
        let degree = trajectory.degree;
        let points = &trajectory.control_points;
        let knots = &trajectory.knot_vector;
        if degree == 0 || degree > MAX_DEGREE {
            return Err(format!("degree {degree} is not from 1 to {MAX_DEGREE}"));
        }
        let degree = degree as usize;
        if points.len() < degree + 1 || points.len() > MAX_CONTROL_POINTS {
            return Err(format!(
                "{} control points: degree {degree} needs {} to {MAX_CONTROL_POINTS}",
                points.len(),
                degree + 1
            ));
        }
        if knots.len() != points.len() + degree + 1 {
            return Err(format!(
                "{} knots: {} control points of degree {degree} need {}",
                knots.len(),
                points.len(),
                points.len() + degree + 1
            ));
        }
        let in_order = |a: f64, b: f64| a.partial_cmp(&b).is_some_and(|o| o != Ordering::Greater);
        if let Some(i) = knots.windows(2).position(|w| !in_order(w[0], w[1])) {
            return Err(format!("knotVector decreases at index {}", i + 1));
        }
        if knots[degree].partial_cmp(&knots[points.len()]) != Some(Ordering::Less) {
            return Err("knotVector leaves the curve no domain".into());
        }
        let mut weighted = Vec::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            let w = p.weight.unwrap_or(1.0);
            if !(p.x.is_finite() && p.y.is_finite() && w.is_finite() && w > 0.0) {
                return Err(format!("control point {i} needs finite x, y and a weight above 0"));
            }
            weighted.push([p.x * w, p.y * w, w]);
        }
        Ok(Nurbs {
            degree,
            knots: knots.clone(),
            weighted,
        })
    }

    /// The parameter range the curve is defined on.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.weighted.len()])
    }

    /// The knot span holding `u`: the last one with a non-zero length
    /// takes the domain's end.
    fn span(&self, u: f64) -> usize {
        let last = self.weighted.len() - 1;
        if u >= self.knots[last + 1] {
            return (self.degree..=last)
                .rev()
                .find(|&k| self.knots[k] < self.knots[k + 1])
                .unwrap_or(last);
        }
        let mut k = self.degree;
        while k < last && u >= self.knots[k + 1] {
            k += 1;
        }
        k
    }

    /// The curve's point at parameter `u` (clamped to the domain).
    pub fn point(&self, u: f64) -> (f64, f64) {
        let (lo, hi) = self.domain();
        let u = u.clamp(lo, hi);
        let p = self.degree;
        let k = self.span(u);
        let mut d: Vec<[f64; 3]> = self.weighted[k - p..=k].to_vec();
        for r in 1..=p {
            for j in (r..=p).rev() {
                let left = self.knots[j + k - p];
                let right = self.knots[j + 1 + k - r];
                let alpha = if right > left { (u - left) / (right - left) } else { 0.0 };
                let (before, here) = (d[j - 1], d[j]);
                d[j] = std::array::from_fn(|c| (1.0 - alpha) * before[c] + alpha * here[c]);
            }
        }
        let [x, y, w] = d[p];
        (x / w, y / w)
    }

    /// The tightest radius of curvature along the curve (m; infinite for a
    /// straight one), measured as the radius of the circle through three
    /// neighbouring points, within each knot span: there the curve is
    /// smooth. At a knot where the curve has a corner (degree 1, or a knot
    /// repeated `degree` times) the navigator rounds it as it rounds the
    /// corner between two edges, so a corner is not a turn asked for.
    pub fn min_radius_m(&self) -> f64 {
        let (lo, hi) = self.domain();
        let mut knots: Vec<f64> = self.knots.iter().copied().filter(|k| *k >= lo && *k <= hi).collect();
        knots.dedup();
        let mut tightest = f64::INFINITY;
        for span in knots.windows(2) {
            let (start, end) = (span[0], span[1]);
            let at = |i: usize| self.point(start + (end - start) * i as f64 / RADIUS_SAMPLES_PER_SPAN as f64);
            let (mut a, mut b) = (at(0), at(1));
            for i in 2..=RADIUS_SAMPLES_PER_SPAN {
                let c = at(i);
                tightest = tightest.min(circumradius(a, b, c));
                (a, b) = (b, c);
            }
        }
        tightest
    }

    /// Points along the curve, first to last, whose chords stay within
    /// `tolerance_m` of it (half for the splitting, half for dropping the
    /// points a straight stretch does not need). Every knot is a sample:
    /// between knots the curve is one smooth rational piece (of degree 1,
    /// a straight line), however unevenly the weights pace it.
    pub fn chords(&self, tolerance_m: f64) -> Vec<(f64, f64)> {
        let tolerance_m = 0.5 * tolerance_m;
        let (lo, hi) = self.domain();
        let mut points = vec![self.point(lo)];
        let mut knots: Vec<f64> = self.knots.iter().copied().filter(|k| *k > lo && *k < hi).collect();
        knots.dedup();
        knots.push(hi);
        let mut start = lo;
        for end in knots {
            for i in 1..=SAMPLES_PER_SPAN {
                let u0 = start + (end - start) * (i - 1) as f64 / SAMPLES_PER_SPAN as f64;
                let u1 = start + (end - start) * i as f64 / SAMPLES_PER_SPAN as f64;
                self.split(u0, u1, tolerance_m, MAX_SPLIT_DEPTH, &mut points);
            }
            start = end;
        }
        simplify(&points, tolerance_m)
    }

    /// Appends the points of [u0, u1] after u0's.
    fn split(&self, u0: f64, u1: f64, tolerance_m: f64, depth: u32, points: &mut Vec<(f64, f64)>) {
        let (a, b) = (self.point(u0), self.point(u1));
        let off = [0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875]
            .iter()
            .map(|f| segment_distance(a, b, self.point(u0 + f * (u1 - u0))))
            .fold(0.0, f64::max);
        if off > tolerance_m && depth > 0 {
            let mid = 0.5 * (u0 + u1);
            self.split(u0, mid, tolerance_m, depth - 1, points);
            self.split(mid, u1, tolerance_m, depth - 1, points);
        } else {
            points.push(b);
        }
    }
}

/// The radius of the circle through three points: infinite when they are
/// in a line, or when two of them coincide (a pause in the parameter's
/// pace says nothing of the bend).
fn circumradius(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    let (ab, bc, ca) = (
        (b.0 - a.0).hypot(b.1 - a.1),
        (c.0 - b.0).hypot(c.1 - b.1),
        (a.0 - c.0).hypot(a.1 - c.1),
    );
    let twice_area = ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).abs();
    if ab.min(bc) < 1e-9 || twice_area < 1e-15 {
        return f64::INFINITY;
    }
    ab * bc * ca / (2.0 * twice_area)
}

/// Drops the points the chords would pass within `tolerance_m` of anyway
/// (a straight stretch sampled many times is one chord).
fn simplify(points: &[(f64, f64)], tolerance_m: f64) -> Vec<(f64, f64)> {
    let Some(&first) = points.first() else {
        return Vec::new();
    };
    let mut kept = vec![first];
    let mut anchor = 0;
    for i in 1..points.len() {
        let next = points.get(i + 1);
        let keep = match next {
            None => true,
            Some(&after) => points[anchor + 1..=i]
                .iter()
                .any(|&p| segment_distance(points[anchor], after, p) > tolerance_m),
        };
        if keep {
            kept.push(points[i]);
            anchor = i;
        }
    }
    kept.dedup_by(|a, b| (a.0 - b.0).hypot(a.1 - b.1) < 1e-9);
    kept
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_1_SQRT_2;

    use vda5050::common::ControlPoint;

    use super::*;

    fn trajectory(degree: u32, knots: &[f64], points: &[(f64, f64, Option<f64>)]) -> Trajectory {
        Trajectory {
            degree,
            knot_vector: knots.to_vec(),
            control_points: points
                .iter()
                .map(|&(x, y, weight)| ControlPoint { x, y, weight })
                .collect(),
        }
    }

    /// A quarter circle of radius 5 about the origin, exactly (rational
    /// quadratic, middle weight 1/√2).
    fn quarter_circle() -> Nurbs {
        let t = trajectory(
            2,
            &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            &[(5.0, 0.0, None), (5.0, 5.0, Some(FRAC_1_SQRT_2)), (0.0, 5.0, None)],
        );
        Nurbs::new(&t).expect("valid")
    }

    #[test]
    fn a_rational_quadratic_is_a_circle_and_its_chords_stay_on_it() {
        let curve = quarter_circle();
        for i in 0..=100 {
            let (x, y) = curve.point(f64::from(i) / 100.0);
            assert!((x.hypot(y) - 5.0).abs() < 1e-12, "({x}, {y})");
        }
        assert_eq!(curve.point(0.0), (5.0, 0.0));
        assert_eq!(curve.point(1.0), (0.0, 5.0));
        let chords = curve.chords(CHORD_TOLERANCE_M);
        // Split at half the tolerance: sagitta r(1 − cos(θ/2)) ≤ 5 mm for
        // r = 5 m is θ ≤ 0.09 rad, so at least 18 chords for the quarter.
        assert!(chords.len() >= 19 && chords.len() < 60, "{}", chords.len());
        for w in chords.windows(2) {
            for f in [0.25, 0.5, 0.75] {
                let p = (w[0].0 + f * (w[1].0 - w[0].0), w[0].1 + f * (w[1].1 - w[0].1));
                assert!(5.0 - p.0.hypot(p.1) <= CHORD_TOLERANCE_M + 1e-9, "{p:?}");
            }
        }
        assert_eq!(chords.first(), Some(&(5.0, 0.0)));
        assert_eq!(chords.last(), Some(&(0.0, 5.0)));
    }

    #[test]
    fn the_tightest_radius_is_the_circle_s_and_a_polyline_s_corners_are_not_turns() {
        let radius = quarter_circle().min_radius_m();
        assert!((radius - 5.0).abs() < 1e-6, "{radius}");
        let t = trajectory(
            1,
            &[0.0, 0.0, 0.5, 1.0, 1.0],
            &[(0.0, 0.0, None), (4.0, 0.0, None), (4.0, 3.0, None)],
        );
        assert_eq!(Nurbs::new(&t).expect("valid").min_radius_m(), f64::INFINITY);
        // An S of two quarter circles, 5 m then 2 m: the tighter one counts.
        let t = trajectory(
            2,
            &[0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0],
            &[
                (5.0, 0.0, None),
                (5.0, 5.0, Some(FRAC_1_SQRT_2)),
                (0.0, 5.0, None),
                (-2.0, 5.0, Some(FRAC_1_SQRT_2)),
                (-2.0, 7.0, None),
            ],
        );
        let radius = Nurbs::new(&t).expect("valid").min_radius_m();
        assert!((radius - 2.0).abs() < 1e-6, "{radius}");
    }

    #[test]
    fn degree_one_is_the_polyline_of_its_control_points() {
        let t = trajectory(
            1,
            &[0.0, 0.0, 0.25, 0.5, 1.0, 1.0],
            &[
                (0.0, 0.0, None),
                (4.0, 0.0, None),
                (4.0, 3.0, Some(2.0)),
                (8.0, 3.0, None),
            ],
        );
        let curve = Nurbs::new(&t).expect("valid");
        assert_eq!(curve.point(0.25), (4.0, 0.0));
        assert_eq!(curve.point(0.5), (4.0, 3.0));
        let (x, y) = curve.point(0.125);
        assert!((x - 2.0).abs() < 1e-12 && y.abs() < 1e-12);
        let chords = curve.chords(CHORD_TOLERANCE_M);
        assert_eq!(chords, [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (8.0, 3.0)]);
    }

    #[test]
    fn a_clamped_cubic_starts_and_ends_on_its_end_points_and_interpolates_a_straight_line() {
        // Control points on one line, evenly: the curve is that line.
        let points: Vec<(f64, f64, Option<f64>)> = (0..6).map(|i| (2.0 * f64::from(i), 1.0, None)).collect();
        let t = trajectory(3, &[0.0, 0.0, 0.0, 0.0, 0.33, 0.66, 1.0, 1.0, 1.0, 1.0], &points);
        let curve = Nurbs::new(&t).expect("valid");
        assert_eq!(curve.point(0.0), (0.0, 1.0));
        let end = curve.point(1.0);
        assert!((end.0 - 10.0).abs() < 1e-12 && (end.1 - 1.0).abs() < 1e-12);
        let mut last_x = -1.0;
        for i in 0..=50 {
            let (x, y) = curve.point(f64::from(i) / 50.0);
            assert!((y - 1.0).abs() < 1e-12 && x > last_x);
            last_x = x;
        }
        assert_eq!(curve.chords(CHORD_TOLERANCE_M).len(), 2, "one chord for a line");
    }

    #[test]
    fn malformed_curves_are_refused_with_the_reason() {
        let refuse = |t: Trajectory, says: &str| {
            let e = Nurbs::new(&t).expect_err("refused");
            assert!(e.contains(says), "{e:?} should say {says:?}");
        };
        let three = [(0.0, 0.0, None), (1.0, 1.0, None), (2.0, 0.0, None)];
        refuse(trajectory(2, &[0.0, 0.0, 0.0, 1.0, 1.0], &three), "need 6");
        refuse(
            trajectory(2, &[0.0, 0.0, 0.5, 0.4, 1.0, 1.0], &three),
            "decreases at index 3",
        );
        refuse(trajectory(3, &[0.0; 7], &three), "degree 3 needs 4");
        refuse(trajectory(2, &[0.5; 6], &three), "no domain");
        refuse(trajectory(0, &[0.0, 1.0, 1.0], &three[..1]), "degree 0");
        let zero_weight = [(0.0, 0.0, None), (1.0, 1.0, Some(0.0)), (2.0, 0.0, None)];
        refuse(
            trajectory(2, &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0], &zero_weight),
            "weight above 0",
        );
        let nan = [(0.0, 0.0, None), (f64::NAN, 1.0, None), (2.0, 0.0, None)];
        refuse(trajectory(2, &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0], &nan), "finite");
    }

    proptest::proptest! {
        /// Any valid curve: every point is a convex combination of the
        /// control points (inside their bounding box), and the chords are
        /// near the curve at the parameters sampled (within twice the
        /// tolerance: a chord is checked at seven points, not everywhere).
        #[test]
        fn points_stay_in_the_hull_and_chords_near_the_curve(
            degree in 1u32..=4,
            raw in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0, 0.1f64..10.0), 5..12),
            cuts in proptest::collection::vec(0.0f64..1.0, 12),
        ) {
            let n = raw.len();
            let p = degree as usize;
            let mut inner: Vec<f64> = cuts[..n - p - 1].to_vec();
            inner.sort_by(f64::total_cmp);
            let mut knots = vec![0.0; p + 1];
            knots.extend(inner);
            knots.extend(vec![1.0; p + 1]);
            let points: Vec<(f64, f64, Option<f64>)> = raw.iter().map(|&(x, y, w)| (x, y, Some(w))).collect();
            let curve = Nurbs::new(&trajectory(degree, &knots, &points)).expect("valid");
            let (min_x, max_x) = raw.iter().fold((f64::MAX, f64::MIN), |(a, b), r| (a.min(r.0), b.max(r.0)));
            let (min_y, max_y) = raw.iter().fold((f64::MAX, f64::MIN), |(a, b), r| (a.min(r.1), b.max(r.1)));
            for i in 0..=200 {
                let (x, y) = curve.point(f64::from(i) / 200.0);
                proptest::prop_assert!(x >= min_x - 1e-9 && x <= max_x + 1e-9 && y >= min_y - 1e-9 && y <= max_y + 1e-9);
            }
            let chords = curve.chords(CHORD_TOLERANCE_M);
            proptest::prop_assert_eq!(chords.first().copied(), Some(curve.point(0.0)));
            for i in 0..=400 {
                let q = curve.point(f64::from(i) / 400.0);
                let nearest = chords
                    .windows(2)
                    .map(|w| segment_distance(w[0], w[1], q))
                    .fold(f64::MAX, f64::min);
                proptest::prop_assert!(nearest <= 2.0 * CHORD_TOLERANCE_M, "{:?} is {} m from the chords", q, nearest);
            }
        }
    }
}
