//! The obstacles of the SITL world: static shapes and obstacles that walk or
//! drive along a path at constant speed (docs/architecture.md §Obstacles).
//!
//! Points are `[north, east]` metres about home; bearings are radians from
//! north, clockwise. Time is simulation seconds (`f64`), passed in: nothing
//! here keeps a clock. All obstacles are solid: a ray that starts inside one
//! hits it at range 0, and a vehicle outline inside one has clearance 0.

use std::f64::consts::TAU;

/// A 2-D obstacle outline in the home NED frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Circle {
        center: [f64; 2],
        radius_m: f64,
    },
    /// A rectangle `length_m` along `yaw_rad` (0 = the length points north)
    /// and `width_m` across it.
    Box {
        center: [f64; 2],
        length_m: f64,
        width_m: f64,
        yaw_rad: f64,
    },
    /// A simple polygon (either winding); the last point joins the first.
    Polygon {
        points: Vec<[f64; 2]>,
    },
    /// A rectangle centred on the segment `from`–`to`, `thickness_m` across
    /// it, with square ends flush with `from` and `to`. Thickness 0 is a line.
    Wall {
        from: [f64; 2],
        to: [f64; 2],
        thickness_m: f64,
    },
}

/// The vehicle's outline, or any oriented rectangle: `half_length_m` along
/// `yaw_rad`, `half_width_m` across.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    pub center: [f64; 2],
    pub yaw_rad: f64,
    pub half_length_m: f64,
    pub half_width_m: f64,
}

/// The vehicle's outline about its reference point (the rear axle centre):
/// from `rear_m` behind it to `front_m` ahead, `half_width_m` either side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehicleOutline {
    pub front_m: f64,
    pub rear_m: f64,
    pub half_width_m: f64,
}

impl Default for VehicleOutline {
    /// The bench vehicle with its load (the autopilot's `VEH_LEN_FRONT`,
    /// `VEH_LEN_REAR`, `VEH_WIDTH` defaults).
    fn default() -> Self {
        Self {
            front_m: 3.6,
            rear_m: 0.8,
            half_width_m: 1.0,
        }
    }
}

impl VehicleOutline {
    /// The outline for the reference point at (`north_m`, `east_m`) heading `yaw_rad`.
    pub fn rectangle(&self, north_m: f64, east_m: f64, yaw_rad: f64) -> Rectangle {
        let ahead_m = (self.front_m - self.rear_m) / 2.0;
        let (sin, cos) = yaw_rad.sin_cos();
        Rectangle {
            center: [north_m + ahead_m * cos, east_m + ahead_m * sin],
            yaw_rad,
            half_length_m: (self.front_m + self.rear_m) / 2.0,
            half_width_m: self.half_width_m,
        }
    }
}

impl Rectangle {
    /// Corners in order round the outline.
    pub fn corners(&self) -> [[f64; 2]; 4] {
        oriented_corners(self.center, self.yaw_rad, self.half_length_m, self.half_width_m)
    }

    /// The same rectangle as an obstacle.
    pub fn to_shape(&self) -> Shape {
        Shape::Box {
            center: self.center,
            length_m: 2.0 * self.half_length_m,
            width_m: 2.0 * self.half_width_m,
            yaw_rad: self.yaw_rad,
        }
    }
}

/// The parts of an outline that a ray from a point outside can meet first.
pub(crate) enum FacingOutline<'a> {
    Circle {
        center: [f64; 2],
        radius_m: f64,
    },
    /// The edges whose outer side faces the point (all of them for an
    /// outline without area, e.g. a wall of thickness 0).
    Edges(FacingEdges<'a>),
}

/// The facing edges of a polygonal outline, picked as they are iterated
/// (a scanner asks for them every scan: nothing is collected).
pub(crate) struct FacingEdges<'a> {
    outline: Outline<'a>,
    origin: [f64; 2],
    /// Positive for anticlockwise in (north, east) axes: the inside is then
    /// to the left of each edge.
    twice_area: f64,
}

impl FacingEdges<'_> {
    fn new(outline: Outline<'_>, origin: [f64; 2]) -> FacingEdges<'_> {
        let twice_area = edges(outline.points()).map(|(a, b)| cross(a, b)).sum();
        FacingEdges {
            outline,
            origin,
            twice_area,
        }
    }

    pub(crate) fn iter(&self) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        let (origin, twice_area) = (self.origin, self.twice_area);
        edges(self.outline.points())
            .filter(move |&(a, b)| twice_area == 0.0 || cross(sub(b, a), sub(origin, a)) * twice_area < 0.0)
    }
}

/// The outline as the geometry routines see it.
#[derive(Clone, Copy)]
pub(crate) enum Outline<'a> {
    Circle { center: [f64; 2], radius_m: f64 },
    Quad([[f64; 2]; 4]),
    Polygon(&'a [[f64; 2]]),
}

impl<'a> Outline<'a> {
    /// The corners of a polygonal outline (none for a circle).
    fn points(&self) -> &[[f64; 2]] {
        match self {
            Outline::Circle { .. } => &[],
            Outline::Quad(corners) => corners,
            Outline::Polygon(points) => points,
        }
    }

    /// See [`Shape::bounding_circle`].
    pub(crate) fn bounding_circle(&self) -> ([f64; 2], f64) {
        match self {
            Outline::Circle { center, radius_m } => (*center, *radius_m),
            Outline::Quad(corners) => enclosing_circle(corners),
            Outline::Polygon(points) => enclosing_circle(points),
        }
    }

    /// See [`Shape::contains`].
    pub(crate) fn contains(&self, point: [f64; 2]) -> bool {
        match self {
            Outline::Circle { center, radius_m } => distance(point, *center) <= *radius_m,
            Outline::Quad(corners) => polygon_contains(corners, point),
            Outline::Polygon(points) => polygon_contains(points, point),
        }
    }

    /// What a ray from `origin`, outside the shape, can hit first: a ray
    /// entering an outline crosses an edge whose outer side holds the origin,
    /// so the edges facing away never give the nearest hit.
    pub(crate) fn facing(self, origin: [f64; 2]) -> FacingOutline<'a> {
        match self {
            Outline::Circle { center, radius_m } => FacingOutline::Circle { center, radius_m },
            polygonal => FacingOutline::Edges(FacingEdges::new(polygonal, origin)),
        }
    }
}

impl Shape {
    /// The outline placed in the local frame (a box's or a wall's corners
    /// cost a sin_cos, a wall's an atan2 and a hypot too: a caller asking
    /// several questions of a shape places it once).
    pub(crate) fn outline(&self) -> Outline<'_> {
        match self {
            Shape::Circle { center, radius_m } => Outline::Circle {
                center: *center,
                radius_m: radius_m.max(0.0),
            },
            Shape::Box {
                center,
                length_m,
                width_m,
                yaw_rad,
            } => Outline::Quad(oriented_corners(*center, *yaw_rad, length_m / 2.0, width_m / 2.0)),
            Shape::Polygon { points } => Outline::Polygon(points),
            Shape::Wall { from, to, thickness_m } => {
                let center = [(from[0] + to[0]) / 2.0, (from[1] + to[1]) / 2.0];
                let (dn, de) = (to[0] - from[0], to[1] - from[1]);
                Outline::Quad(oriented_corners(
                    center,
                    de.atan2(dn),
                    dn.hypot(de) / 2.0,
                    thickness_m.max(0.0) / 2.0,
                ))
            }
        }
    }

    /// The same shape moved by `offset` (north, east metres).
    pub fn translated(&self, offset: [f64; 2]) -> Shape {
        let shift = |p: &[f64; 2]| [p[0] + offset[0], p[1] + offset[1]];
        match self {
            Shape::Circle { center, radius_m } => Shape::Circle {
                center: shift(center),
                radius_m: *radius_m,
            },
            Shape::Box {
                center,
                length_m,
                width_m,
                yaw_rad,
            } => Shape::Box {
                center: shift(center),
                length_m: *length_m,
                width_m: *width_m,
                yaw_rad: *yaw_rad,
            },
            Shape::Polygon { points } => Shape::Polygon {
                points: points.iter().map(shift).collect(),
            },
            Shape::Wall { from, to, thickness_m } => Shape::Wall {
                from: shift(from),
                to: shift(to),
                thickness_m: *thickness_m,
            },
        }
    }

    /// A circle (centre, radius) that contains the whole shape: a cheap
    /// first test before the exact geometry. Radius 0 for an empty polygon.
    pub fn bounding_circle(&self) -> ([f64; 2], f64) {
        self.outline().bounding_circle()
    }

    /// Whether `point` is inside or on the outline.
    pub fn contains(&self, point: [f64; 2]) -> bool {
        self.outline().contains(point)
    }

    /// Range to the first point of the outline along the ray from `origin`
    /// at `bearing_rad`, if within `max_range_m`.
    pub fn raycast(&self, origin: [f64; 2], bearing_rad: f64, max_range_m: f64) -> Option<f64> {
        self.ray_hit_m(origin, bearing_unit(bearing_rad))
            .filter(|&range_m| range_m <= max_range_m)
    }

    /// Unbounded ray along the unit vector `dir`.
    pub(crate) fn ray_hit_m(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<f64> {
        if self.contains(origin) {
            return Some(0.0);
        }
        self.ray_from_outside_m(origin, dir)
    }

    /// [`Self::ray_hit_m`] for an `origin` known to be outside: a scan tests
    /// that once, not once a beam.
    pub(crate) fn ray_from_outside_m(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<f64> {
        match self.outline() {
            Outline::Circle { center, radius_m } => ray_circle_m(origin, dir, center, radius_m),
            Outline::Quad(corners) => ray_edges_m(origin, dir, &corners),
            Outline::Polygon(points) => ray_edges_m(origin, dir, points),
        }
    }

    /// Gap between the outline and `rect`; 0 when they touch or overlap (the
    /// depth of an overlap is not measured). Infinite for an empty polygon.
    pub fn distance_to_rectangle_m(&self, rect: &Rectangle) -> f64 {
        let corners = rect.corners();
        match self.outline() {
            Outline::Circle { center, radius_m } => (point_polygon_distance(center, &corners) - radius_m).max(0.0),
            Outline::Quad(quad) => polygon_distance(&quad, &corners),
            Outline::Polygon(points) => polygon_distance(points, &corners),
        }
    }
}

/// Something that moves along a polyline at constant speed, carrying `shape`
/// with it. The shape is given about the moving reference point (a person is
/// a circle of radius 0.25 m at the origin) and is translated, not rotated:
/// a box keeps its yaw whichever way it goes.
///
/// Before `start_s` it stands at the first point; then it walks the path at
/// `speed_mps`. At the end it stays at the last point, or vanishes for good
/// (`vanish_at_end`), or, when `looped`, walks back to the first point along
/// a closing leg and goes round again. A single-point path ends at `start_s`.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingObstacle {
    pub name: String,
    pub shape: Shape,
    pub path: Vec<[f64; 2]>,
    pub speed_mps: f64,
    pub start_s: f64,
    pub looped: bool,
    pub vanish_at_end: bool,
}

impl MovingObstacle {
    /// The legs walked, including the closing one of a looped path.
    fn legs(&self) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
        let closing = (self.looped && self.path.len() > 1)
            .then(|| (self.path[self.path.len() - 1], self.path[0]))
            .into_iter();
        self.path.windows(2).map(|w| (w[0], w[1])).chain(closing)
    }

    /// Length of one pass (one lap when looped).
    pub fn path_length_m(&self) -> f64 {
        self.legs().map(|(a, b)| distance(a, b)).sum()
    }

    /// True position and velocity (north, east) at `t_s`; `None` once it
    /// has vanished or if it has no path.
    pub fn state_at(&self, t_s: f64) -> Option<([f64; 2], [f64; 2])> {
        let first = *self.path.first()?;
        let last = *self.path.last()?;
        let elapsed_s = t_s - self.start_s;
        // NaN time counts as not started.
        let started = elapsed_s >= 0.0;
        if !started {
            return Some((first, [0.0, 0.0]));
        }
        let speed_mps = if self.speed_mps.is_finite() {
            self.speed_mps.max(0.0)
        } else {
            0.0
        };
        let length_m = self.path_length_m();
        let mut along_m = elapsed_s * speed_mps;
        if self.looped {
            if length_m.is_nan() || length_m <= 0.0 {
                return Some((first, [0.0, 0.0]));
            }
            along_m = along_m.rem_euclid(length_m);
        } else if along_m >= length_m {
            return (!self.vanish_at_end).then_some((last, [0.0, 0.0]));
        }
        let mut at_end = None;
        for (a, b) in self.legs() {
            let leg_m = distance(a, b);
            if leg_m <= 0.0 {
                continue;
            }
            let dir = [(b[0] - a[0]) / leg_m, (b[1] - a[1]) / leg_m];
            let velocity = [dir[0] * speed_mps, dir[1] * speed_mps];
            if along_m < leg_m {
                return Some(([a[0] + dir[0] * along_m, a[1] + dir[1] * along_m], velocity));
            }
            along_m -= leg_m;
            at_end = Some((b, velocity));
        }
        // Rounding left it a hair past the last leg: it is at that leg's end.
        at_end.or(Some((last, [0.0, 0.0])))
    }

    /// The shape placed at `t_s`, unless it has vanished.
    pub fn shape_at(&self, t_s: f64) -> Option<Shape> {
        self.state_at(t_s).map(|(position, _)| self.shape.translated(position))
    }
}

/// Everything a scanner can see and a vehicle can hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObstacleWorld {
    pub statics: Vec<Shape>,
    pub movers: Vec<MovingObstacle>,
    /// The other vehicles of a fleet, placed where they are now (their
    /// outlines as boxes; the fleet moves them before every step).
    pub vehicles: Vec<Shape>,
}

impl ObstacleWorld {
    pub fn new(statics: Vec<Shape>, movers: Vec<MovingObstacle>) -> Self {
        Self {
            statics,
            movers,
            vehicles: Vec::new(),
        }
    }

    /// Every obstacle present at `t_s`, placed: the statics, the other
    /// vehicles, then the movers that have not vanished.
    pub fn shapes_at(&self, t_s: f64) -> Vec<Shape> {
        let movers = self.movers.iter().filter_map(|m| m.shape_at(t_s));
        self.statics
            .iter()
            .chain(&self.vehicles)
            .cloned()
            .chain(movers)
            .collect()
    }

    /// [`Self::shapes_at`] one by one, without copying the statics.
    pub(crate) fn for_each_shape_at(&self, t_s: f64, mut visit: impl FnMut(&Shape)) {
        self.statics.iter().for_each(&mut visit);
        self.vehicles.iter().for_each(&mut visit);
        for mover in &self.movers {
            if let Some(shape) = mover.shape_at(t_s) {
                visit(&shape);
            }
        }
    }

    /// True position and velocity of mover `index` at `t_s` (for measuring
    /// tracking error); `None` for no such mover or once it has vanished.
    pub fn mover_state(&self, index: usize, t_s: f64) -> Option<([f64; 2], [f64; 2])> {
        self.movers.get(index)?.state_at(t_s)
    }

    /// Range to the nearest obstacle along the ray from `origin` at
    /// `bearing_rad` (from north, clockwise), if within `max_range_m`. Taking
    /// the nearest hit over all shapes is what makes near obstacles occlude
    /// far ones.
    pub fn raycast(&self, origin: [f64; 2], bearing_rad: f64, max_range_m: f64, t_s: f64) -> Option<f64> {
        nearest_hit_m(&self.shapes_at(t_s), origin, bearing_unit(bearing_rad)).filter(|&r| r <= max_range_m)
    }

    /// Smallest gap between `rect` and any obstacle at `t_s`: ≤ 0 (in fact
    /// exactly 0) means they touch or overlap, i.e. a collision. Infinite
    /// when there is nothing.
    pub fn clearance_m(&self, rect: &Rectangle, t_s: f64) -> f64 {
        self.shapes_at(t_s)
            .iter()
            .map(|shape| shape.distance_to_rectangle_m(rect))
            .fold(f64::INFINITY, f64::min)
    }
}

pub(crate) fn nearest_hit_m(shapes: &[Shape], origin: [f64; 2], dir: [f64; 2]) -> Option<f64> {
    shapes
        .iter()
        .filter_map(|shape| shape.ray_hit_m(origin, dir))
        .min_by(f64::total_cmp)
}

/// Unit vector (north, east) of a bearing from north, clockwise.
pub(crate) fn bearing_unit(bearing_rad: f64) -> [f64; 2] {
    let (sin, cos) = bearing_rad.sin_cos();
    [cos, sin]
}

fn oriented_corners(center: [f64; 2], yaw_rad: f64, half_length_m: f64, half_width_m: f64) -> [[f64; 2]; 4] {
    let (sin, cos) = yaw_rad.sin_cos();
    // Body (x along yaw, y to its right) to (north, east).
    let place = |x: f64, y: f64| [center[0] + x * cos - y * sin, center[1] + x * sin + y * cos];
    [
        place(half_length_m, half_width_m),
        place(half_length_m, -half_width_m),
        place(-half_length_m, -half_width_m),
        place(-half_length_m, half_width_m),
    ]
}

fn enclosing_circle(points: &[[f64; 2]]) -> ([f64; 2], f64) {
    if points.is_empty() {
        return ([0.0, 0.0], 0.0);
    }
    let n = points.len() as f64;
    let center = [
        points.iter().map(|p| p[0]).sum::<f64>() / n,
        points.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    // One square root for the farthest point, not a hypot per point: a
    // scanner asks this of every obstacle in every scan.
    let squared_m2 = |p: &[f64; 2]| (p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2);
    let radius_m = points.iter().map(squared_m2).fold(0.0, f64::max).sqrt();
    (center, radius_m)
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The closed polygon's edges.
fn edges(points: &[[f64; 2]]) -> impl Iterator<Item = ([f64; 2], [f64; 2])> + '_ {
    let n = points.len();
    (0..n).map(move |i| (points[i], points[(i + 1) % n]))
}

pub(crate) fn ray_circle_m(origin: [f64; 2], dir: [f64; 2], center: [f64; 2], radius_m: f64) -> Option<f64> {
    let oc = sub(origin, center);
    let b = dot(oc, dir);
    let c = dot(oc, oc) - radius_m * radius_m;
    if c <= 0.0 {
        return Some(0.0);
    }
    let discriminant = b * b - c;
    if discriminant < 0.0 {
        return None;
    }
    // Outside the circle both roots have the same sign: the nearer one.
    let t = -b - discriminant.sqrt();
    (t >= 0.0).then_some(t)
}

/// Where the ray crosses segment a–b; parallel rays (and zero-length
/// segments) miss, their neighbours' end points catch them.
pub(crate) fn ray_segment_m(origin: [f64; 2], dir: [f64; 2], a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let edge = sub(b, a);
    let denominator = cross(dir, edge);
    if denominator == 0.0 {
        return None;
    }
    let to_a = sub(a, origin);
    let t = cross(to_a, edge) / denominator;
    let u = cross(to_a, dir) / denominator;
    (t >= 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

fn ray_edges_m(origin: [f64; 2], dir: [f64; 2], points: &[[f64; 2]]) -> Option<f64> {
    edges(points)
        .filter_map(|(a, b)| ray_segment_m(origin, dir, a, b))
        .min_by(f64::total_cmp)
}

/// Even–odd rule, with points on an edge counted inside.
fn polygon_contains(points: &[[f64; 2]], p: [f64; 2]) -> bool {
    if points.len() < 3 {
        return false;
    }
    let mut inside = false;
    for (a, b) in edges(points) {
        if point_segment_distance(p, a, b) == 0.0 {
            return true;
        }
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let n_cross = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < n_cross {
                inside = !inside;
            }
        }
    }
    inside
}

pub(crate) fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let edge = sub(b, a);
    let length2 = dot(edge, edge);
    let s = if length2 > 0.0 {
        (dot(sub(p, a), edge) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    distance(p, [a[0] + s * edge[0], a[1] + s * edge[1]])
}

/// 0 inside the polygon, else the distance to its nearest edge.
fn point_polygon_distance(p: [f64; 2], points: &[[f64; 2]]) -> f64 {
    if polygon_contains(points, p) {
        return 0.0;
    }
    edges(points)
        .map(|(a, b)| point_segment_distance(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

fn segments_cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    // Only proper crossings: touching and collinear overlaps put an end point
    // on the other segment, which the end-point distances already catch.
    let side = |p, q, r| cross(sub(q, p), sub(r, p));
    side(a, b, c) * side(a, b, d) < 0.0 && side(c, d, a) * side(c, d, b) < 0.0
}

fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if segments_cross(a, b, c, d) {
        return 0.0;
    }
    point_segment_distance(a, c, d)
        .min(point_segment_distance(b, c, d))
        .min(point_segment_distance(c, a, b))
        .min(point_segment_distance(d, a, b))
}

/// 0 when the polygons overlap (edges cross, or one holds the other).
fn polygon_distance(p: &[[f64; 2]], q: &[[f64; 2]]) -> f64 {
    let (Some(&p0), Some(&q0)) = (p.first(), q.first()) else {
        return f64::INFINITY;
    };
    if polygon_contains(q, p0) || polygon_contains(p, q0) {
        return 0.0;
    }
    let mut best = f64::INFINITY;
    for (a, b) in edges(p) {
        for (c, d) in edges(q) {
            best = best.min(segment_distance(a, b, c, d));
        }
    }
    best
}

/// Angle wrapped into [0, 2π).
pub(crate) fn wrap_two_pi(angle_rad: f64) -> f64 {
    // In range already (the same value `rem_euclid` gives), without its
    // libm `fmod` call: the scanners wrap a few angles per obstacle per scan.
    if (0.0..TAU).contains(&angle_rad) {
        return angle_rad;
    }
    angle_rad.rem_euclid(TAU)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    fn person(path: Vec<[f64; 2]>, speed_mps: f64) -> MovingObstacle {
        MovingObstacle {
            name: "person".to_owned(),
            shape: Shape::Circle {
                center: [0.0, 0.0],
                radius_m: 0.25,
            },
            path,
            speed_mps,
            start_s: 2.0,
            looped: false,
            vanish_at_end: false,
        }
    }

    /// An axis-aligned vehicle outline from `north0`..`north1`, `east0`..`east1`.
    fn aligned(north0: f64, north1: f64, east0: f64, east1: f64) -> Rectangle {
        Rectangle {
            center: [(north0 + north1) / 2.0, (east0 + east1) / 2.0],
            yaw_rad: 0.0,
            half_length_m: (north1 - north0) / 2.0,
            half_width_m: (east1 - east0) / 2.0,
        }
    }

    #[test]
    fn circle_ray_hits_the_near_side_and_tangents_graze() {
        let c = Shape::Circle {
            center: [10.0, 0.0],
            radius_m: 1.0,
        };
        assert!(close(c.raycast([0.0, 0.0], 0.0, 20.0).unwrap(), 9.0));
        // From the east, looking west (bearing −90°).
        assert!(close(c.raycast([10.0, 5.0], -FRAC_PI_2, 20.0).unwrap(), 4.0));
        // Tangent at 1 m off the centre line.
        let tangent = (1.0f64 / 10.0).asin();
        assert!(c.raycast([0.0, 0.0], tangent - 1e-6, 20.0).is_some());
        assert!(c.raycast([0.0, 0.0], tangent + 1e-6, 20.0).is_none());
        // Behind, beyond range, inside.
        assert!(c.raycast([0.0, 0.0], PI, 20.0).is_none());
        assert!(c.raycast([0.0, 0.0], 0.0, 8.9).is_none());
        assert_eq!(c.raycast([10.5, 0.0], 1.0, 20.0), Some(0.0));
    }

    #[test]
    fn box_ray_hits_the_face_it_meets() {
        // 4 m along north-east, 2 m across, centred at (10, 10).
        let b = Shape::Box {
            center: [10.0, 10.0],
            length_m: 4.0,
            width_m: 2.0,
            yaw_rad: FRAC_PI_4,
        };
        // Along the diagonal from home: meets the short face, 2 m before the centre.
        let d = 200f64.sqrt();
        assert!(close(b.raycast([0.0, 0.0], FRAC_PI_4, 30.0).unwrap(), d - 2.0));
        // Across it from 5 m off its left (north-west) side: centre to face = 1 m.
        let origin = [10.0 + 5.0 * FRAC_PI_4.cos(), 10.0 - 5.0 * FRAC_PI_4.sin()];
        assert!(close(b.raycast(origin, 3.0 * FRAC_PI_4, 30.0).unwrap(), 4.0));
        assert!(b.contains([10.0, 10.0]) && !b.contains([10.0, 12.0]));
        let unrotated = Shape::Box {
            center: [5.0, 0.0],
            length_m: 2.0,
            width_m: 6.0,
            yaw_rad: 0.0,
        };
        assert!(close(unrotated.raycast([0.0, 2.9], 0.0, 30.0).unwrap(), 4.0));
        assert!(unrotated.raycast([0.0, 3.1], 0.0, 30.0).is_none());
    }

    #[test]
    fn polygon_ray_takes_the_nearest_edge_of_a_concave_outline() {
        // A U open to the south: walls at east 0..1 and 3..4, base at north 4..5.
        let u = Shape::Polygon {
            points: vec![
                [0.0, 0.0],
                [5.0, 0.0],
                [5.0, 4.0],
                [0.0, 4.0],
                [0.0, 3.0],
                [4.0, 3.0],
                [4.0, 1.0],
                [0.0, 1.0],
            ],
        };
        // Up the mouth of the U: the base at north 4.
        assert!(close(u.raycast([-2.0, 2.0], 0.0, 30.0).unwrap(), 6.0));
        // Up the left arm: its near end at north 0.
        assert!(close(u.raycast([-2.0, 0.5], 0.0, 30.0).unwrap(), 2.0));
        assert!(u.contains([2.0, 0.5]) && !u.contains([2.0, 2.0]));
        // From inside the mouth, looking east: the right arm's inner face.
        assert!(close(u.raycast([2.0, 2.0], FRAC_PI_2, 30.0).unwrap(), 1.0));
        assert!(u.raycast([-2.0, 5.0], 0.0, 30.0).is_none());
    }

    #[test]
    fn wall_ray_sees_its_face_and_a_thin_wall_is_a_line() {
        let wall = Shape::Wall {
            from: [5.0, -10.0],
            to: [5.0, 10.0],
            thickness_m: 0.2,
        };
        assert!(close(wall.raycast([0.0, 0.0], 0.0, 30.0).unwrap(), 4.9));
        // 45° to the right: 4.9 m north → 4.9·√2 along the ray.
        assert!(close(
            wall.raycast([0.0, 0.0], FRAC_PI_4, 30.0).unwrap(),
            4.9 * 2f64.sqrt()
        ));
        // Past its end.
        assert!(wall.raycast([0.0, 10.5], 0.0, 30.0).is_none());
        let line = Shape::Wall {
            from: [5.0, -10.0],
            to: [5.0, 10.0],
            thickness_m: 0.0,
        };
        assert!(close(line.raycast([0.0, 3.0], 0.0, 30.0).unwrap(), 5.0));
        assert!(close(line.raycast([8.0, 3.0], PI, 30.0).unwrap(), 3.0));
    }

    #[test]
    fn clearance_is_the_gap_to_each_shape_and_zero_on_contact() {
        let car = aligned(0.0, 4.0, -1.0, 1.0);
        let circle = Shape::Circle {
            center: [7.0, 0.0],
            radius_m: 1.0,
        };
        assert!(close(circle.distance_to_rectangle_m(&car), 2.0));
        // Off a corner: (4, 1) to (7, 5) is 5 m, less the radius.
        let corner = Shape::Circle {
            center: [7.0, 5.0],
            radius_m: 1.0,
        };
        assert!(close(corner.distance_to_rectangle_m(&car), 4.0));
        let boxed = Shape::Box {
            center: [2.0, 4.0],
            length_m: 1.0,
            width_m: 2.0,
            yaw_rad: 0.0,
        };
        assert!(close(boxed.distance_to_rectangle_m(&car), 2.0));
        // A diamond whose tip points at the car's side.
        let diamond = Shape::Polygon {
            points: vec![[2.0, 1.5], [3.0, 2.5], [2.0, 3.5], [1.0, 2.5]],
        };
        assert!(close(diamond.distance_to_rectangle_m(&car), 0.5));
        let wall = Shape::Wall {
            from: [-3.0, -3.0],
            to: [-3.0, 3.0],
            thickness_m: 1.0,
        };
        assert!(close(wall.distance_to_rectangle_m(&car), 2.5));
        // Crossing edges, one inside the other, touching.
        let crossing = Shape::Wall {
            from: [2.0, -5.0],
            to: [2.0, 5.0],
            thickness_m: 0.0,
        };
        assert_eq!(crossing.distance_to_rectangle_m(&car), 0.0);
        let inside = Shape::Circle {
            center: [2.0, 0.0],
            radius_m: 0.1,
        };
        assert_eq!(inside.distance_to_rectangle_m(&car), 0.0);
        let engulfing = Shape::Box {
            center: [2.0, 0.0],
            length_m: 20.0,
            width_m: 20.0,
            yaw_rad: 0.3,
        };
        assert_eq!(engulfing.distance_to_rectangle_m(&car), 0.0);
        let touching = Shape::Box {
            center: [5.0, 0.0],
            length_m: 2.0,
            width_m: 1.0,
            yaw_rad: 0.0,
        };
        assert!(touching.distance_to_rectangle_m(&car).abs() < 1e-12);
    }

    #[test]
    fn the_outline_sits_on_the_rear_axle_reference_point() {
        let outline = VehicleOutline {
            front_m: 3.0,
            rear_m: 1.0,
            half_width_m: 0.5,
        };
        // Heading east: the front bumper is 3 m east of the reference point.
        let rect = outline.rectangle(10.0, 0.0, FRAC_PI_2);
        let post = |east_m: f64| Shape::Circle {
            center: [10.0, east_m],
            radius_m: 0.0,
        };
        assert!(close(post(5.0).distance_to_rectangle_m(&rect), 2.0));
        assert!(close(post(-3.0).distance_to_rectangle_m(&rect), 2.0));
    }

    #[test]
    fn a_mover_waits_walks_and_stops_at_the_end() {
        let p = person(vec![[0.0, 0.0], [0.0, 3.0], [4.0, 3.0]], 1.0);
        assert_eq!(p.state_at(0.0), Some(([0.0, 0.0], [0.0, 0.0])));
        let (pos, vel) = p.state_at(3.5).unwrap();
        assert!(close(pos[1], 1.5) && close(vel[1], 1.0) && close(vel[0], 0.0));
        let (pos, vel) = p.state_at(7.0).unwrap();
        assert!(close(pos[0], 2.0) && close(pos[1], 3.0) && close(vel[0], 1.0));
        assert_eq!(p.state_at(9.0), Some(([4.0, 3.0], [0.0, 0.0])));
        assert_eq!(p.state_at(100.0), Some(([4.0, 3.0], [0.0, 0.0])));
        let shape = p.shape_at(3.5).unwrap();
        assert_eq!(
            shape,
            Shape::Circle {
                center: [0.0, 1.5],
                radius_m: 0.25
            }
        );
    }

    #[test]
    fn a_vanishing_mover_leaves_at_the_end_and_a_looped_one_goes_round() {
        let vanishing = MovingObstacle {
            vanish_at_end: true,
            ..person(vec![[0.0, 0.0], [0.0, 3.0]], 1.5)
        };
        assert!(vanishing.state_at(3.9).is_some());
        assert!(vanishing.state_at(4.0).is_none());
        let square = MovingObstacle {
            looped: true,
            vanish_at_end: true,
            ..person(vec![[0.0, 0.0], [0.0, 2.0], [2.0, 2.0], [2.0, 0.0]], 2.0)
        };
        assert!(close(square.path_length_m(), 8.0));
        // 7.5 s walked = 15 m = one lap and 7 m: half-way down the closing leg.
        let (pos, vel) = square.state_at(2.0 + 7.5).unwrap();
        assert!(close(pos[0], 1.0) && close(pos[1], 0.0), "{pos:?}");
        assert!(close(vel[0], -2.0) && close(vel[1], 0.0), "{vel:?}");
        // 6.5 s = 13 m: on the third leg, going west.
        let (pos, vel) = square.state_at(2.0 + 6.5).unwrap();
        assert!(close(pos[0], 2.0) && close(pos[1], 1.0), "{pos:?}");
        assert!(close(vel[0], 0.0) && close(vel[1], -2.0), "{vel:?}");
        // A looped single point stands still; an empty path is nowhere.
        let post = MovingObstacle {
            looped: true,
            ..person(vec![[1.0, 1.0]], 1.0)
        };
        assert_eq!(post.state_at(50.0), Some(([1.0, 1.0], [0.0, 0.0])));
        assert!(person(Vec::new(), 1.0).state_at(0.0).is_none());
    }

    #[test]
    fn the_nearest_hit_occludes_and_vanished_movers_are_gone() {
        let walker = MovingObstacle {
            vanish_at_end: true,
            ..person(vec![[10.0, -3.0], [10.0, 3.0]], 1.0)
        };
        let world = ObstacleWorld::new(
            vec![Shape::Wall {
                from: [20.0, -10.0],
                to: [20.0, 10.0],
                thickness_m: 0.0,
            }],
            vec![walker],
        );
        // Standing at the start, off the ray: the wall.
        assert!(close(world.raycast([0.0, 0.0], 0.0, 30.0, 0.0).unwrap(), 20.0));
        // At t = 5 s it is on the ray and hides the wall.
        assert!(close(world.raycast([0.0, 0.0], 0.0, 30.0, 5.0).unwrap(), 9.75));
        assert!(world.raycast([0.0, 0.0], 0.0, 15.0, 0.0).is_none());
        assert_eq!(world.shapes_at(5.0).len(), 2);
        assert_eq!(world.shapes_at(8.0).len(), 1);
        assert!(world.mover_state(0, 8.0).is_none() && world.mover_state(1, 0.0).is_none());
        let car = aligned(5.0, 9.0, -1.0, 1.0);
        // (10, −3) is 1 m north and 2 m east of the car's corner (9, −1).
        assert!(close(world.clearance_m(&car, 0.0), 5f64.sqrt() - 0.25));
        assert!(close(world.clearance_m(&car, 5.0), 0.75));
        assert_eq!(ObstacleWorld::default().clearance_m(&car, 0.0), f64::INFINITY);
    }

    #[test]
    fn bounding_circles_contain_their_shapes() {
        let shapes = [
            Shape::Box {
                center: [3.0, -2.0],
                length_m: 4.0,
                width_m: 1.0,
                yaw_rad: 0.7,
            },
            Shape::Wall {
                from: [0.0, 0.0],
                to: [3.0, 4.0],
                thickness_m: 0.5,
            },
            Shape::Polygon {
                points: vec![[0.0, 0.0], [6.0, 0.0], [0.0, 1.0]],
            },
        ];
        for shape in &shapes {
            let (center, radius_m) = shape.bounding_circle();
            // Rays from far away in 360 directions never hit outside the circle.
            for k in 0..360 {
                let bearing = f64::from(k).to_radians();
                let origin = [center[0] - 50.0 * bearing.cos(), center[1] - 50.0 * bearing.sin()];
                for offset_m in [-1.0, -0.3, 0.0, 0.3, 1.0] {
                    let across = [-bearing.sin() * offset_m, bearing.cos() * offset_m];
                    let o = [origin[0] + across[0], origin[1] + across[1]];
                    if let Some(range_m) = shape.raycast(o, bearing, 100.0) {
                        let dir = bearing_unit(bearing);
                        let hit = [o[0] + dir[0] * range_m, o[1] + dir[1] * range_m];
                        assert!(distance(hit, center) <= radius_m + 1e-9, "{shape:?}");
                    }
                }
            }
        }
        assert!(close(wrap_two_pi(-FRAC_PI_2), 1.5 * PI));
    }
}
