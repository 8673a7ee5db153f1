//! Path geometry in the local frame: straight segments between waypoints and
//! the circular arcs that round a corner the vehicle drives through
//! (docs/architecture.md §Path tracking).
//!
//! Headings are radians from north, clockwise; a curvature is positive for
//! a right turn in the direction of travel; a cross-track error is positive
//! right of the direction of travel.

use crate::geo::{Ned, wrap_pi};

/// A straight leg from `start` to `end`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub start: Ned,
    pub end: Ned,
}

/// Where a point lies relative to a piece of path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentProjection {
    /// Distance along the piece from its start (negative before it, beyond
    /// `length_m` past the end).
    pub along_m: f64,
    /// Signed distance from the piece: positive right of the direction of
    /// travel.
    pub crosstrack_m: f64,
    pub length_m: f64,
}

impl Segment {
    pub fn new(start: Ned, end: Ned) -> Self {
        Segment { start, end }
    }

    pub fn length_m(&self) -> f64 {
        self.start.distance_to(&self.end)
    }

    /// Unit vector along the leg (north, east); north for a zero-length leg.
    pub fn direction(&self) -> (f64, f64) {
        let dn = self.end.north_m - self.start.north_m;
        let de = self.end.east_m - self.start.east_m;
        let len = dn.hypot(de);
        if len < 1e-9 { (1.0, 0.0) } else { (dn / len, de / len) }
    }

    /// Direction of travel along the leg, radians from north.
    pub fn bearing_rad(&self) -> f64 {
        let (un, ue) = self.direction();
        ue.atan2(un)
    }

    pub fn project(&self, p: &Ned) -> SegmentProjection {
        let (un, ue) = self.direction();
        let dn = p.north_m - self.start.north_m;
        let de = p.east_m - self.start.east_m;
        SegmentProjection {
            along_m: dn * un + de * ue,
            // Right of a north-going leg is east: cross = u × d (z down).
            crosstrack_m: un * de - ue * dn,
            length_m: self.length_m(),
        }
    }

    /// The point `along_m` from the start on the leg's (infinite) line.
    pub fn point_at(&self, along_m: f64) -> Ned {
        let (un, ue) = self.direction();
        Ned::new(self.start.north_m + un * along_m, self.start.east_m + ue * along_m)
    }
}

/// Unit vector to the right of heading `h`.
fn right_of(heading_rad: f64) -> (f64, f64) {
    (-heading_rad.sin(), heading_rad.cos())
}

/// A circular arc driven from `start_heading_rad`, turning right
/// (`turn` = +1) or left (−1) through `sweep_rad` (≥ 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    pub center: Ned,
    pub radius_m: f64,
    pub start_heading_rad: f64,
    pub turn: f64,
    pub sweep_rad: f64,
}

impl Arc {
    /// The arc that starts at `start` heading `start_heading_rad`.
    pub fn from_start(start: Ned, start_heading_rad: f64, radius_m: f64, turn: f64, sweep_rad: f64) -> Arc {
        let (rn, re) = right_of(start_heading_rad);
        Arc {
            center: Ned::new(
                start.north_m + turn * radius_m * rn,
                start.east_m + turn * radius_m * re,
            ),
            radius_m,
            start_heading_rad,
            turn,
            sweep_rad,
        }
    }

    pub fn length_m(&self) -> f64 {
        self.radius_m * self.sweep_rad
    }

    pub fn curvature(&self) -> f64 {
        self.turn / self.radius_m
    }

    pub fn heading_at(&self, along_m: f64) -> f64 {
        wrap_pi(self.start_heading_rad + self.turn * along_m / self.radius_m)
    }

    pub fn point_at(&self, along_m: f64) -> Ned {
        let (rn, re) = right_of(self.heading_at(along_m));
        Ned::new(
            self.center.north_m - self.turn * self.radius_m * rn,
            self.center.east_m - self.turn * self.radius_m * re,
        )
    }

    pub fn end(&self) -> Ned {
        self.point_at(self.length_m())
    }

    /// The arc's first `fraction` (0..1) and the rest.
    pub fn split(&self, fraction: f64) -> (Arc, Arc) {
        let first = self.sweep_rad * fraction;
        (
            Arc {
                sweep_rad: first,
                ..*self
            },
            Arc {
                start_heading_rad: self.heading_at(self.radius_m * first),
                sweep_rad: self.sweep_rad - first,
                ..*self
            },
        )
    }

    /// Along-track by the angle about the centre, measured from the arc's
    /// middle so that points a half-turn either side stay continuous.
    pub fn project(&self, p: &Ned) -> SegmentProjection {
        let (dn, de) = (p.north_m - self.center.north_m, p.east_m - self.center.east_m);
        let distance = dn.hypot(de);
        // The centre → point direction is the travel heading −turn·90°.
        let heading_here = de.atan2(dn) + self.turn * std::f64::consts::FRAC_PI_2;
        let middle = self.start_heading_rad + self.turn * 0.5 * self.sweep_rad;
        let from_middle = wrap_pi(heading_here - middle) * self.turn;
        SegmentProjection {
            along_m: self.radius_m * (0.5 * self.sweep_rad + from_middle),
            // The centre is on the side the arc turns to.
            crosstrack_m: self.turn * (self.radius_m - distance),
            length_m: self.length_m(),
        }
    }
}

/// One piece of a leg's path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Piece {
    Line(Segment),
    Arc(Arc),
}

impl Piece {
    pub fn length_m(&self) -> f64 {
        match self {
            Piece::Line(s) => s.length_m(),
            Piece::Arc(a) => a.length_m(),
        }
    }

    pub fn point_at(&self, along_m: f64) -> Ned {
        match self {
            Piece::Line(s) => s.point_at(along_m),
            Piece::Arc(a) => a.point_at(along_m),
        }
    }

    pub fn heading_at(&self, along_m: f64) -> f64 {
        match self {
            Piece::Line(s) => s.bearing_rad(),
            Piece::Arc(a) => a.heading_at(along_m),
        }
    }

    pub fn curvature(&self) -> f64 {
        match self {
            Piece::Line(_) => 0.0,
            Piece::Arc(a) => a.curvature(),
        }
    }

    pub fn project(&self, p: &Ned) -> SegmentProjection {
        match self {
            Piece::Line(s) => s.project(p),
            Piece::Arc(a) => a.project(p),
        }
    }
}

/// Where an arc lies along a path (m from the path's start) and its
/// curvature (1/m, positive turning right).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcSpan {
    pub start_m: f64,
    pub end_m: f64,
    pub curvature: f64,
}

/// A rounded corner: the arc tangent to both legs, and where it leaves and
/// rejoins them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    pub arc: Arc,
    /// Distance from the corner point back along the incoming leg to where
    /// the arc starts (and forward along the outgoing leg to where it ends).
    pub tangent_m: f64,
}

/// Turns smaller than this need no arc.
const MIN_TURN_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// The arc that rounds the corner at `at` between the legs `prev → at` and
/// `at → next`, of `radius_m`, or larger than `min_radius_m` when that does
/// not fit in the room the legs leave (`room_in_m` before the corner,
/// `room_out_m` after it). `None` for a straight-on corner, a reversal, or
/// one that not even the vehicle's tightest usable turn fits.
pub fn fit_corner(
    prev: Ned,
    at: Ned,
    next: Ned,
    radius_m: f64,
    min_radius_m: f64,
    room_in_m: f64,
    room_out_m: f64,
) -> Option<Corner> {
    let incoming = Segment::new(prev, at);
    let outgoing = Segment::new(at, next);
    if incoming.length_m() < 1e-6 || outgoing.length_m() < 1e-6 {
        return None;
    }
    let turn_rad = wrap_pi(outgoing.bearing_rad() - incoming.bearing_rad());
    // A reversal (or nearly) has no tangent arc of finite size.
    if turn_rad.abs() < MIN_TURN_RAD || turn_rad.abs() > 175f64.to_radians() {
        return None;
    }
    let half_tan = (0.5 * turn_rad.abs()).tan();
    let room = room_in_m.min(room_out_m).max(0.0);
    let radius = radius_m.min(room / half_tan);
    if !(radius.is_finite() && radius >= min_radius_m && radius > 0.0) {
        return None;
    }
    let tangent_m = radius * half_tan;
    let start = incoming.point_at(incoming.length_m() - tangent_m);
    Some(Corner {
        arc: Arc::from_start(start, incoming.bearing_rad(), radius, turn_rad.signum(), turn_rad.abs()),
        tangent_m,
    })
}

/// The path of one leg: possibly the second half of the arc that rounded the
/// corner it starts at, the straight, and, when the vehicle drives on
/// through a corner, that corner's whole arc and the next straight, so the
/// preview point can look round the corner. The leg itself ends at
/// [`LegPath::end_m`]: the target point, or the middle of the corner's arc
/// (the closest the path comes to the corner point).
#[derive(Clone, Debug, PartialEq)]
pub struct LegPath {
    pieces: Vec<Piece>,
    end_m: f64,
}

/// Where a point lies relative to a leg's path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathProjection {
    pub piece: usize,
    /// Along the path (negative before its start, beyond
    /// [`LegPath::end_m`] past the leg's end).
    pub along_m: f64,
    pub crosstrack_m: f64,
}

impl LegPath {
    /// `entry`: the rest of the previous corner's arc (it starts where the
    /// previous leg ended); `exit`: the corner at `to` with the next point.
    pub fn new(entry: Option<Arc>, from: Ned, to: Ned, exit: Option<(&Corner, Ned)>) -> LegPath {
        let mut pieces = Vec::with_capacity(4);
        let line_start = match entry {
            Some(arc) if arc.length_m() > 1e-9 => {
                pieces.push(Piece::Arc(arc));
                arc.end()
            }
            _ => from,
        };
        let line_end = match exit {
            Some((corner, _)) => corner.arc.point_at(0.0),
            None => to,
        };
        let line = Segment::new(line_start, line_end);
        // A corner arc that uses the whole leg leaves no straight.
        if line.length_m() > 1e-6 || pieces.is_empty() && exit.is_none() {
            pieces.push(Piece::Line(line));
        }
        let mut end_m: f64 = pieces.iter().map(Piece::length_m).sum();
        if let Some((corner, next)) = exit {
            end_m += 0.5 * corner.arc.length_m();
            pieces.push(Piece::Arc(corner.arc));
            pieces.push(Piece::Line(Segment::new(corner.arc.end(), next)));
        }
        LegPath { pieces, end_m }
    }

    /// A path of given pieces (a manoeuvre's stroke), ending at their end.
    /// Empty, it is a point: a zero-length line there.
    pub fn from_pieces(pieces: Vec<Piece>) -> LegPath {
        let pieces = if pieces.is_empty() {
            vec![Piece::Line(Segment::new(Ned::new(0.0, 0.0), Ned::new(0.0, 0.0)))]
        } else {
            pieces
        };
        let end_m = pieces.iter().map(Piece::length_m).sum();
        LegPath { pieces, end_m }
    }

    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Where the leg ends, along the path.
    pub fn end_m(&self) -> f64 {
        self.end_m
    }

    /// The point the leg ends at.
    pub fn end(&self) -> Ned {
        self.point_at(self.end_m)
    }

    /// The arc the next leg starts with: the rest of this leg's corner.
    pub fn exit_arc_rest(&self) -> Option<Arc> {
        let (i, _) = self.locate(self.end_m);
        match self.pieces[i] {
            Piece::Arc(arc) if self.pieces.len() >= 2 && i == self.pieces.len() - 2 => Some(arc.split(0.5).1),
            _ => None,
        }
    }

    /// Distance along the path where `piece` starts.
    pub fn piece_start_m(&self, piece: usize) -> f64 {
        self.pieces[..piece].iter().map(Piece::length_m).sum()
    }

    /// The piece and the distance into it at `along_m`; before the start the
    /// first piece's extension, past the end the last's.
    fn locate(&self, along_m: f64) -> (usize, f64) {
        let mut start = 0.0;
        for (i, piece) in self.pieces.iter().enumerate() {
            let end = start + piece.length_m();
            if along_m < end || i + 1 == self.pieces.len() {
                return (i, along_m - start);
            }
            start = end;
        }
        unreachable!("a leg path has at least one piece")
    }

    pub fn point_at(&self, along_m: f64) -> Ned {
        let (i, s) = self.locate(along_m);
        self.pieces[i].point_at(s)
    }

    pub fn heading_at(&self, along_m: f64) -> f64 {
        let (i, s) = self.locate(along_m);
        self.pieces[i].heading_at(s)
    }

    pub fn curvature_at(&self, along_m: f64) -> f64 {
        let (i, _) = self.locate(along_m);
        self.pieces[i].curvature()
    }

    /// The mean curvature over `[from_m, to_m]` (the curvature at `from_m`
    /// for an empty interval).
    pub fn mean_curvature(&self, from_m: f64, to_m: f64) -> f64 {
        if to_m - from_m < 1e-9 {
            return self.curvature_at(from_m);
        }
        let mut start = 0.0;
        let mut integral = 0.0;
        let last = self.pieces.len() - 1;
        for (i, piece) in self.pieces.iter().enumerate() {
            // The first piece extends backwards, the last forwards.
            let lo = if i == 0 { f64::NEG_INFINITY } else { start };
            let end = start + piece.length_m();
            let hi = if i == last { f64::INFINITY } else { end };
            let overlap = to_m.min(hi) - from_m.max(lo);
            if overlap > 0.0 {
                integral += overlap * piece.curvature();
            }
            start = end;
        }
        integral / (to_m - from_m)
    }

    /// The largest |curvature| of the path.
    pub fn max_curvature(&self) -> f64 {
        self.pieces.iter().map(|p| p.curvature().abs()).fold(0.0, f64::max)
    }

    /// The path's arcs, in order, for the speed schedule.
    pub fn arcs(&self) -> impl Iterator<Item = ArcSpan> + '_ {
        let mut start = 0.0;
        self.pieces.iter().filter_map(move |piece| {
            let (start_m, length_m) = (start, piece.length_m());
            start += length_m;
            match piece {
                Piece::Arc(a) => Some(ArcSpan {
                    start_m,
                    end_m: start_m + length_m,
                    curvature: a.curvature(),
                }),
                Piece::Line(_) => None,
            }
        })
    }

    /// Projects `p` starting from piece `from_piece`: the vehicle moves on to
    /// the next piece once it is past the end of the current one, never
    /// back, so a path that comes close to itself cannot capture it early.
    pub fn project(&self, p: &Ned, from_piece: usize) -> PathProjection {
        let mut piece = from_piece.min(self.pieces.len() - 1);
        loop {
            let pr = self.pieces[piece].project(p);
            if pr.along_m <= pr.length_m || piece + 1 == self.pieces.len() {
                return PathProjection {
                    piece,
                    along_m: self.piece_start_m(piece) + pr.along_m,
                    crosstrack_m: pr.crosstrack_m,
                };
            }
            piece += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn projection_signs() {
        //   end (10, 0)
        //     ^
        //     |   . p (4, 1): 1 m right of a north-going leg
        //     |
        //   start (0, 0)
        let s = Segment::new(Ned::new(0.0, 0.0), Ned::new(10.0, 0.0));
        let pr = s.project(&Ned::new(4.0, 1.0));
        assert!((pr.along_m - 4.0).abs() < 1e-12);
        assert!((pr.crosstrack_m - 1.0).abs() < 1e-12);
        let pr = s.project(&Ned::new(-2.0, -3.0));
        assert!((pr.along_m + 2.0).abs() < 1e-12);
        assert!((pr.crosstrack_m + 3.0).abs() < 1e-12);
    }

    #[test]
    fn bearing_of_an_east_going_leg() {
        let s = Segment::new(Ned::new(0.0, 0.0), Ned::new(0.0, 5.0));
        assert!((s.bearing_rad() - FRAC_PI_2).abs() < 1e-12);
        let pr = s.project(&Ned::new(1.0, 2.0));
        assert!(
            (pr.crosstrack_m + 1.0).abs() < 1e-12,
            "north of an east-going leg is left"
        );
    }

    #[test]
    fn arc_geometry_right_and_left() {
        // Heading north from the origin, a right quarter turn of radius 5
        // ends at (5, 5) heading east, centre (0, 5).
        let right = Arc::from_start(Ned::new(0.0, 0.0), 0.0, 5.0, 1.0, FRAC_PI_2);
        assert!(close(right.center.east_m, 5.0, 1e-12) && close(right.center.north_m, 0.0, 1e-12));
        let end = right.end();
        assert!(close(end.north_m, 5.0, 1e-9) && close(end.east_m, 5.0, 1e-9), "{end:?}");
        assert!(close(right.heading_at(right.length_m()), FRAC_PI_2, 1e-12));
        // Inside the turn (towards the centre) is right of travel.
        let pr = right.project(&Ned::new(0.0, 0.5));
        assert!(
            close(pr.crosstrack_m, 0.5, 1e-12) && close(pr.along_m, 0.0, 1e-9),
            "{pr:?}"
        );
        // The left quarter turn ends at (5, −5) heading west.
        let left = Arc::from_start(Ned::new(0.0, 0.0), 0.0, 5.0, -1.0, FRAC_PI_2);
        let end = left.end();
        assert!(
            close(end.north_m, 5.0, 1e-9) && close(end.east_m, -5.0, 1e-9),
            "{end:?}"
        );
        assert!(close(left.heading_at(left.length_m()), -FRAC_PI_2, 1e-12));
        let mid = left.point_at(0.5 * left.length_m());
        let pr = left.project(&mid);
        assert!(close(pr.along_m, 0.5 * left.length_m(), 1e-9) && close(pr.crosstrack_m, 0.0, 1e-9));
        // Outside a left turn is right of travel.
        let pr = left.project(&Ned::new(0.0, 0.2));
        assert!(close(pr.crosstrack_m, 0.2, 1e-12), "{pr:?}");
    }

    #[test]
    fn corner_arc_is_tangent_to_both_legs() {
        for (next, turn) in [
            (Ned::new(20.0, 30.0), 1.0),
            (Ned::new(20.0, -30.0), -1.0),
            (Ned::new(35.0, 5.0), 1.0),
        ] {
            let (prev, at) = (Ned::new(0.0, 0.0), Ned::new(20.0, 0.0));
            let c = fit_corner(prev, at, next, 6.0, 5.0, 20.0, 15.0).expect("fits");
            assert_eq!(c.arc.turn, turn);
            assert!(close(c.arc.radius_m, 6.0, 1e-12));
            let start = c.arc.point_at(0.0);
            assert!(close(start.north_m, 20.0 - c.tangent_m, 1e-9) && close(start.east_m, 0.0, 1e-9));
            let out = Segment::new(at, next);
            let end = c.arc.end();
            let pr = out.project(&end);
            assert!(close(pr.crosstrack_m, 0.0, 1e-9) && close(pr.along_m, c.tangent_m, 1e-9));
            assert!(close(
                wrap_pi(c.arc.heading_at(c.arc.length_m()) - out.bearing_rad()),
                0.0,
                1e-12
            ));
        }
    }

    #[test]
    fn corner_shrinks_to_fit_but_never_below_the_minimum() {
        let (prev, at, next) = (Ned::new(0.0, 0.0), Ned::new(10.0, 0.0), Ned::new(10.0, 10.0));
        let c = fit_corner(prev, at, next, 8.0, 5.0, 10.0, 6.0).expect("shrinks to 6 m");
        assert!(close(c.arc.radius_m, 6.0, 1e-12));
        assert!(fit_corner(prev, at, next, 8.0, 5.0, 10.0, 4.0).is_none());
        assert!(
            fit_corner(prev, at, Ned::new(20.0, 0.0), 8.0, 5.0, 10.0, 10.0).is_none(),
            "straight on"
        );
        assert!(
            fit_corner(prev, at, Ned::new(0.0, 0.0), 8.0, 5.0, 10.0, 10.0).is_none(),
            "reversal"
        );
    }

    #[test]
    fn leg_path_runs_through_its_pieces() {
        // North 30 m, then east: the corner at (30, 0) rounded with 6 m.
        let (a, b, c) = (Ned::new(0.0, 0.0), Ned::new(30.0, 0.0), Ned::new(30.0, 30.0));
        let corner = fit_corner(a, b, c, 6.0, 5.0, 30.0, 15.0).unwrap();
        let first = LegPath::new(None, a, b, Some((&corner, c)));
        assert_eq!(first.pieces().len(), 3, "line, arc, next line as look-ahead");
        let expected = 24.0 + 6.0 * PI / 4.0;
        assert!(close(first.end_m(), expected, 1e-9));
        // The leg ends at the middle of the arc, the closest it comes to b.
        let end = first.end();
        assert!(close(end.distance_to(&b), 6.0 * (2f64.sqrt() - 1.0), 1e-9));
        assert!(close(first.heading_at(first.end_m()), PI / 4.0, 1e-6));
        // Past the leg's end the path goes on round the corner.
        let beyond = first.point_at(24.0 + 6.0 * FRAC_PI_2 + 2.0);
        assert!(
            close(beyond.north_m, 30.0, 1e-9) && close(beyond.east_m, 8.0, 1e-9),
            "{beyond:?}"
        );
        let second = LegPath::new(first.exit_arc_rest(), b, c, None);
        assert!(second.point_at(0.0).distance_to(&end) < 1e-9, "continuous");
        assert!(close(second.end_m(), 24.0 + 6.0 * PI / 4.0, 1e-9));
        assert!(second.exit_arc_rest().is_none());
        // Projection moves from piece to piece.
        let pr = first.project(&Ned::new(10.0, -0.3), 0);
        assert_eq!(pr.piece, 0);
        assert!(close(pr.along_m, 10.0, 1e-12) && close(pr.crosstrack_m, -0.3, 1e-12));
        let on_arc = corner.arc.point_at(1.0);
        let pr = first.project(&on_arc, 0);
        assert_eq!(pr.piece, 1);
        assert!(close(pr.along_m, 25.0, 1e-9) && pr.crosstrack_m.abs() < 1e-9);
        assert!(close(first.curvature_at(25.0), 1.0 / 6.0, 1e-12));
        let arc_len = 6.0 * FRAC_PI_2;
        assert!(close(first.mean_curvature(23.0, 25.0), 0.5 / 6.0, 1e-12));
        assert!(close(first.mean_curvature(-5.0, 10.0), 0.0, 1e-12));
        assert!(close(first.mean_curvature(25.0, 26.0), 1.0 / 6.0, 1e-12));
        assert!(close(
            first.mean_curvature(24.0 + arc_len - 1.0, 24.0 + arc_len + 3.0),
            0.25 / 6.0,
            1e-12
        ));
        assert!(close(first.max_curvature(), 1.0 / 6.0, 1e-12));
        let arcs: Vec<_> = first.arcs().collect();
        assert_eq!(
            arcs,
            vec![ArcSpan {
                start_m: 24.0,
                end_m: 24.0 + arc_len,
                curvature: 1.0 / 6.0
            }]
        );
    }
}
