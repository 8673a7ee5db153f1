//! The shape of a tracked object that is not a person walking: a convex
//! polygon fitted to its returns, so clearance is measured to its faces
//! rather than to a disc of half its extent (a box's half-diagonal reaches
//! well past its faces).
//!
//! A scanner sees only the near side of an object. The polygon is the convex
//! hull of the returns together with their mirror image through the
//! object's estimated centre (the cluster's centroid, already pushed away
//! from the scanner for the unseen half): the faces seen (the L of a box's
//! corner, a post's near arc) are kept exactly, and the hidden side is
//! assumed no deeper than the seen one. A hull with more corners than fit is
//! replaced by the polygon of its support lines in `MAX_VERTICES` directions
//! starting along its longest edge: a superset that overshoots a round
//! object by about 1 %.

use crate::geo::Ned;

/// Corners kept per outline.
pub const MAX_VERTICES: usize = 24;
/// Returns used per fit: a near cluster's are thinned to this many, evenly
/// by beam, which keeps its ends (its faces' extremes are what matter).
const MAX_POINTS: usize = 64;

/// A convex polygon, counter-clockwise in (north, east), as offsets from
/// the object's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outline {
    vertices: [(f64, f64); MAX_VERTICES],
    len: usize,
}

impl Outline {
    /// Fits the outline of `points` about `centre`. `None` without points or
    /// with a non-finite one.
    pub fn fit<T>(centre: Ned, points: &[T], position: impl Fn(&T) -> Ned) -> Option<Outline> {
        if points.is_empty() {
            return None;
        }
        let stride = points.len().div_ceil(MAX_POINTS);
        let mut buffer = [(0.0, 0.0); 2 * MAX_POINTS + 2];
        let mut n = 0;
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
            buffer[n] = offset;
            buffer[n + 1] = (-offset.0, -offset.1);
            n += 2;
        }
        let mut hull = [(0.0, 0.0); 2 * MAX_POINTS + 4];
        let hull_len = convex_hull(&mut buffer[..n], &mut hull);
        let hull = &hull[..hull_len];
        let mut outline = if hull.len() <= MAX_VERTICES {
            let mut vertices = [(0.0, 0.0); MAX_VERTICES];
            vertices[..hull.len()].copy_from_slice(hull);
            Outline {
                vertices,
                len: hull.len(),
            }
        } else {
            support_polygon(hull)
        };
        if stride > 1 {
            outline.cover(points.iter().map(|p| {
                let p = position(p);
                (p.north_m - centre.north_m, p.east_m - centre.east_m)
            }));
        }
        Some(outline)
    }

    /// Scales the outline about its centre (inside it: the outline is
    /// symmetric about it) until it holds every offset: the returns a thinned
    /// fit left out.
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

    /// Half the outline's width across the unit direction (north, east):
    /// the radius of the disc a moving object is given.
    pub fn half_width_across(&self, direction: (f64, f64)) -> f64 {
        let normal = (-direction.1, direction.0);
        let (lo, hi) = self
            .vertices()
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                let d = v.0 * normal.0 + v.1 * normal.1;
                (lo.min(d), hi.max(d))
            });
        if lo > hi { 0.0 } else { 0.5 * (hi - lo) }
    }

    /// Largest distance of a corner from the centre.
    pub fn radius_m(&self) -> f64 {
        self.vertices().iter().map(|v| v.0.hypot(v.1)).fold(0.0, f64::max)
    }
}

fn cross(o: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
}

/// Andrew's monotone chain: the hull of `points` (sorted in place) into
/// `out`, counter-clockwise (north as x, east as y), no repeated point.
fn convex_hull(points: &mut [(f64, f64)], out: &mut [(f64, f64)]) -> usize {
    points.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
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

/// The polygon bounded by the hull's support lines in `MAX_VERTICES`
/// directions evenly spaced from its longest edge's outward normal.
fn support_polygon(hull: &[(f64, f64)]) -> Outline {
    let n = hull.len();
    let longest = (0..n)
        .max_by(|&i, &j| {
            let len = |k: usize| {
                let (a, b) = (hull[k], hull[(k + 1) % n]);
                (b.0 - a.0).hypot(b.1 - a.1)
            };
            len(i).total_cmp(&len(j))
        })
        .unwrap_or(0);
    let (a, b) = (hull[longest], hull[(longest + 1) % n]);
    // Counter-clockwise hull: the outward normal of edge a→b is (dy, −dx).
    let start = (a.1 - b.1).atan2(b.0 - a.0) - std::f64::consts::FRAC_PI_2;
    let step = std::f64::consts::TAU / MAX_VERTICES as f64;
    let mut lines = [(0.0, 0.0, 0.0); MAX_VERTICES];
    for (k, line) in lines.iter_mut().enumerate() {
        let (s, c) = (start + step * k as f64).sin_cos();
        let h = hull.iter().map(|v| v.0 * c + v.1 * s).fold(f64::NEG_INFINITY, f64::max);
        *line = (c, s, h);
    }
    let mut vertices = [(0.0, 0.0); MAX_VERTICES];
    for k in 0..MAX_VERTICES {
        let (a1, b1, h1) = lines[k];
        let (a2, b2, h2) = lines[(k + 1) % MAX_VERTICES];
        let det = a1 * b2 - a2 * b1;
        vertices[k] = ((h1 * b2 - h2 * b1) / det, (a1 * h2 - a2 * h1) / det);
    }
    Outline {
        vertices,
        len: MAX_VERTICES,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contains(outline: &Outline, p: (f64, f64)) -> bool {
        let v = outline.vertices();
        (0..v.len()).all(|i| cross(v[i], v[(i + 1) % v.len()], p) >= -1e-9)
    }

    #[test]
    fn an_l_of_a_box_gives_its_faces() {
        // The corner of a 0.8 m box at the origin, faces along north and east,
        // centre at (0.4, 0.4): the L's returns and their mirror are the box.
        let mut points = Vec::new();
        for i in 0..=16 {
            points.push(Ned::new(0.05 * f64::from(i), 0.0));
            points.push(Ned::new(0.0, 0.05 * f64::from(i)));
        }
        let outline = Outline::fit(Ned::new(0.4, 0.4), &points, |p| *p).expect("outline");
        assert_eq!(outline.vertices().len(), 4, "{outline:?}");
        for v in outline.vertices() {
            assert!(
                (v.0.abs() - 0.4).abs() < 1e-9 && (v.1.abs() - 0.4).abs() < 1e-9,
                "{v:?}"
            );
        }
        assert!((outline.half_width_across((1.0, 0.0)) - 0.4).abs() < 1e-9);
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
        let outline = Outline::fit(Ned::default(), &points, |p| *p).expect("outline");
        assert!(outline.vertices().len() <= MAX_VERTICES);
        for p in &points {
            assert!(contains(&outline, (p.north_m, p.east_m)), "{p:?} outside");
        }
        assert!(outline.radius_m() < r * 1.01, "{}", outline.radius_m());
    }

    #[test]
    fn non_finite_points_fit_nothing() {
        assert!(Outline::fit(Ned::default(), &[Ned::new(f64::NAN, 0.0)], |p| *p).is_none());
        assert!(Outline::fit(Ned::default(), &[], |p: &Ned| *p).is_none());
    }
}
