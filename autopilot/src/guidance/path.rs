//! Path geometry in the local frame.

use crate::geo::Ned;

/// A straight leg from `start` to `end`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub start: Ned,
    pub end: Ned,
}

/// Where a point lies relative to a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentProjection {
    /// Distance along the leg from `start` (negative before it, beyond
    /// `length_m` past the end).
    pub along_m: f64,
    /// Signed distance from the leg's line: positive to the right of the
    /// direction of the leg.
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

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!((s.bearing_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let pr = s.project(&Ned::new(1.0, 2.0));
        assert!(
            (pr.crosstrack_m + 1.0).abs() < 1e-12,
            "north of an east-going leg is left"
        );
    }
}
