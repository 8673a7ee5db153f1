//! Reeds–Shepp curves: the shortest paths of a car that can drive forwards
//! and backwards with a bounded turning radius (Reeds & Shepp 1990).
//!
//! The formulas work in a normalised frame: the start pose at the origin
//! facing +x, y to the left, angles anticlockwise, the turning radius 1.
//! Each family's base formula (8.1–8.11 of the paper, as OMPL writes them:
//! CSC, CCC, CCCC, CCSC, CCSCC) is applied to the goal as it is,
//! time-flipped (every gear reversed), reflected (left and right swapped)
//! and both, and CCC and CCSC also to the goal's path driven backwards;
//! together they reach every goal pose.
//!
//! [`to_strokes`] turns a word into path pieces in the local frame
//! (radians from north, clockwise), grouped into strokes of one gear.

use std::f64::consts::PI;

use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::{Arc, Piece, Segment};
use crate::guidance::tracker::Direction;

/// Lengths within this of zero count as zero (and as non-negative).
const ZERO: f64 = 1e-9;

/// How a segment steers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Steer {
    Left,
    Straight,
    Right,
}

/// One segment of a word: how it steers and its signed length in turning
/// radii (an arc's length is its angle): positive forwards.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub steer: Steer,
    pub length: f64,
}

/// A Reeds–Shepp word: up to five motions.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    pub motions: Vec<Motion>,
}

impl Word {
    /// Total length in turning radii.
    pub fn length(&self) -> f64 {
        self.motions.iter().map(|m| m.length.abs()).sum()
    }

    /// Changes of gear between motions that are driven (non-zero).
    pub fn direction_changes(&self) -> usize {
        let gears: Vec<bool> = self
            .motions
            .iter()
            .filter(|m| m.length.abs() > ZERO)
            .map(|m| m.length > 0.0)
            .collect();
        gears.windows(2).filter(|w| w[0] != w[1]).count()
    }
}

/// `x` wrapped to (−π, π].
fn mod2pi(x: f64) -> f64 {
    wrap_pi(x)
}

fn polar(x: f64, y: f64) -> (f64, f64) {
    (x.hypot(y), y.atan2(x))
}

type Lengths = (f64, f64, f64);

/// 8.1: L+S+L+.
fn lp_sp_lp(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (u, t) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    let v = mod2pi(phi - t);
    (t >= -ZERO && v >= -ZERO).then_some((t, u, v))
}

/// 8.2: L+S+R+.
fn lp_sp_rp(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (u1, t1) = polar(x + phi.sin(), y - 1.0 - phi.cos());
    let u1 = u1 * u1;
    if u1 < 4.0 {
        return None;
    }
    let u = (u1 - 4.0).sqrt();
    let theta = 2f64.atan2(u);
    let t = mod2pi(t1 + theta);
    let v = mod2pi(t - phi);
    (t >= -ZERO && v >= -ZERO).then_some((t, u, v))
}

/// 8.3/8.4: L+R−L.
fn lp_rm_l(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (u1, theta) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    if u1 > 4.0 {
        return None;
    }
    let u = -2.0 * (0.25 * u1).asin();
    let t = mod2pi(theta + 0.5 * u + PI);
    let v = mod2pi(phi - t + u);
    (t >= -ZERO && u <= ZERO).then_some((t, u, v))
}

/// The last two angles of a CCCC word (the paper's τ and ω).
fn tau_omega(u: f64, v: f64, xi: f64, eta: f64, phi: f64) -> (f64, f64) {
    let delta = mod2pi(u - v);
    let a = u.sin() - delta.sin();
    let b = u.cos() - delta.cos() - 1.0;
    let t1 = (eta * a - xi * b).atan2(xi * a + eta * b);
    let t2 = 2.0 * (delta.cos() - v.cos() - u.cos()) + 3.0;
    let tau = if t2 < 0.0 { mod2pi(t1 + PI) } else { mod2pi(t1) };
    (tau, mod2pi(tau - u + v - phi))
}

/// 8.7: L+R+L−R−.
fn lp_rup_lum_rm(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let rho = 0.25 * (2.0 + xi.hypot(eta));
    if rho > 1.0 {
        return None;
    }
    let u = rho.acos();
    let (t, v) = tau_omega(u, -u, xi, eta, phi);
    (t >= -ZERO && v <= ZERO).then_some((t, u, v))
}

/// 8.8: L+R−L−R+.
fn lp_rum_lum_rp(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let rho = (20.0 - xi * xi - eta * eta) / 16.0;
    if !(0.0..=1.0).contains(&rho) {
        return None;
    }
    let u = -rho.acos();
    if u < -0.5 * PI {
        return None;
    }
    let (t, v) = tau_omega(u, u, xi, eta, phi);
    (t >= -ZERO && v >= -ZERO).then_some((t, u, v))
}

/// 8.9: L+R−(π/2)S−L−.
fn lp_rm_sm_lm(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (rho, theta) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    if rho < 2.0 {
        return None;
    }
    let r = (rho * rho - 4.0).sqrt();
    let u = 2.0 - r;
    let t = mod2pi(theta + r.atan2(-2.0));
    let v = mod2pi(phi - 0.5 * PI - t);
    (t >= -ZERO && u <= ZERO && v <= ZERO).then_some((t, u, v))
}

/// 8.10: L+R−(π/2)S−R−.
fn lp_rm_sm_rm(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let (rho, theta) = polar(-eta, xi);
    if rho < 2.0 {
        return None;
    }
    let (t, u) = (theta, 2.0 - rho);
    let v = mod2pi(t + 0.5 * PI - phi);
    (t >= -ZERO && u <= ZERO && v <= ZERO).then_some((t, u, v))
}

/// 8.11 (with the paper's typo corrected, as OMPL has it):
/// L+R−(π/2)S−L−(π/2)R+.
fn lp_rm_s_lm_rp(x: f64, y: f64, phi: f64) -> Option<Lengths> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let (rho, _) = polar(xi, eta);
    if rho < 2.0 {
        return None;
    }
    let u = 4.0 - (rho * rho - 4.0).sqrt();
    if u > ZERO {
        return None;
    }
    let t = mod2pi(((4.0 - u) * xi - 2.0 * eta).atan2(-2.0 * xi + (u - 4.0) * eta));
    let v = mod2pi(t - phi);
    (t >= -ZERO && v >= -ZERO).then_some((t, u, v))
}

type Formula = fn(f64, f64, f64) -> Option<Lengths>;

/// One family: its base formula, the steering of its motions and their
/// lengths from the formula's (t, u, v).
struct Family {
    formula: Formula,
    steers: &'static [Steer],
    lengths: fn(Lengths) -> Vec<f64>,
    /// Solved for the goal's path driven backwards (CCC, CCSC).
    backwards: bool,
}

const FAMILIES: [Family; 10] = {
    use Steer::{Left as L, Right as R, Straight as S};
    const HALF_PI: f64 = 0.5 * PI;
    [
        Family {
            formula: lp_sp_lp,
            steers: &[L, S, L],
            lengths: |(t, u, v)| vec![t, u, v],
            backwards: false,
        },
        Family {
            formula: lp_sp_rp,
            steers: &[L, S, R],
            lengths: |(t, u, v)| vec![t, u, v],
            backwards: false,
        },
        Family {
            formula: lp_rm_l,
            steers: &[L, R, L],
            lengths: |(t, u, v)| vec![t, u, v],
            backwards: false,
        },
        Family {
            formula: lp_rm_l,
            steers: &[L, R, L],
            lengths: |(t, u, v)| vec![t, u, v],
            backwards: true,
        },
        Family {
            formula: lp_rup_lum_rm,
            steers: &[L, R, L, R],
            lengths: |(t, u, v)| vec![t, u, -u, v],
            backwards: false,
        },
        Family {
            formula: lp_rum_lum_rp,
            steers: &[L, R, L, R],
            lengths: |(t, u, v)| vec![t, u, u, v],
            backwards: false,
        },
        Family {
            formula: lp_rm_sm_lm,
            steers: &[L, R, S, L],
            lengths: |(t, u, v)| vec![t, -HALF_PI, u, v],
            backwards: false,
        },
        Family {
            formula: lp_rm_sm_rm,
            steers: &[L, R, S, R],
            lengths: |(t, u, v)| vec![t, -HALF_PI, u, v],
            backwards: false,
        },
        Family {
            formula: lp_rm_sm_lm,
            steers: &[L, R, S, L],
            lengths: |(t, u, v)| vec![t, -HALF_PI, u, v],
            backwards: true,
        },
        Family {
            formula: lp_rm_sm_rm,
            steers: &[L, R, S, R],
            lengths: |(t, u, v)| vec![t, -HALF_PI, u, v],
            backwards: true,
        },
    ]
};

/// 8.11 on its own: it has no backwards form.
const CCSCC: Family = {
    use Steer::{Left as L, Right as R, Straight as S};
    Family {
        formula: lp_rm_s_lm_rp,
        steers: &[L, R, S, L, R],
        lengths: |(t, u, v)| vec![t, -0.5 * PI, u, -0.5 * PI, v],
        backwards: false,
    }
};

fn swap(steer: Steer) -> Steer {
    match steer {
        Steer::Left => Steer::Right,
        Steer::Right => Steer::Left,
        Steer::Straight => Steer::Straight,
    }
}

/// Every Reeds–Shepp word (CSC, CCC, CCCC, CCSC, CCSCC) from the origin
/// (facing +x, unit radius) to (`x`, `y`, `phi`) in the normalised frame.
pub fn words(x: f64, y: f64, phi: f64) -> Vec<Word> {
    let mut out = Vec::with_capacity(48);
    for family in FAMILIES.iter().chain(std::iter::once(&CCSCC)) {
        push_transforms(&mut out, family, x, y, phi);
    }
    out
}

/// The family's formula as given, time-flipped (every gear reversed),
/// reflected (left and right swapped), and both.
fn push_transforms(out: &mut Vec<Word>, family: &Family, x: f64, y: f64, phi: f64) {
    let (x, y) = if family.backwards {
        (x * phi.cos() + y * phi.sin(), x * phi.sin() - y * phi.cos())
    } else {
        (x, y)
    };
    for (sx, sy, sphi, reflect) in [
        (1.0, 1.0, 1.0, false),
        (-1.0, 1.0, -1.0, false),
        (1.0, -1.0, -1.0, true),
        (-1.0, -1.0, 1.0, true),
    ] {
        let Some(base) = (family.formula)(sx * x, sy * y, sphi * phi) else {
            continue;
        };
        // Time-flipping negates x: every motion's gear reverses.
        let gear = sx;
        let mut motions: Vec<Motion> = (family.lengths)(base)
            .into_iter()
            .zip(family.steers)
            .map(|(length, &steer)| Motion {
                steer: if reflect { swap(steer) } else { steer },
                length: gear * length,
            })
            .collect();
        if family.backwards {
            motions.reverse();
        }
        out.push(Word { motions });
    }
}

/// A pose in the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub position: Ned,
    /// Radians from north, clockwise: where the vehicle's nose points.
    pub yaw_rad: f64,
}

/// The goal as the formulas want it: relative to the start, in turning
/// radii, y to the left, angles anticlockwise.
pub fn normalise(start: &Pose, goal: &Pose, radius_m: f64) -> (f64, f64, f64) {
    let dn = goal.position.north_m - start.position.north_m;
    let de = goal.position.east_m - start.position.east_m;
    let (s, c) = start.yaw_rad.sin_cos();
    let forward = dn * c + de * s;
    let right = -dn * s + de * c;
    (
        forward / radius_m,
        -right / radius_m,
        -wrap_pi(goal.yaw_rad - start.yaw_rad),
    )
}

/// A run of pieces driven in one gear.
#[derive(Clone, Debug, PartialEq)]
pub struct Stroke {
    pub direction: Direction,
    /// In the direction of travel (a reverse stroke's headings are the
    /// vehicle's yaw + π).
    pub pieces: Vec<Piece>,
    /// The vehicle's pose at the stroke's end.
    pub end: Pose,
}

impl Stroke {
    pub fn length_m(&self) -> f64 {
        self.pieces.iter().map(Piece::length_m).sum()
    }
}

/// Drives `motion` from `pose` with turning radius `radius_m`: the piece
/// in the direction of travel and the pose it ends in.
pub fn drive(pose: &Pose, motion: &Motion, radius_m: f64) -> (Piece, Pose) {
    let direction = if motion.length >= 0.0 {
        Direction::Forward
    } else {
        Direction::Reverse
    };
    let flip = if direction == Direction::Reverse { PI } else { 0.0 };
    let travel = wrap_pi(pose.yaw_rad + flip);
    let distance = motion.length.abs() * radius_m;
    let piece = match motion.steer {
        Steer::Straight => {
            let end = Ned::new(
                pose.position.north_m + distance * travel.cos(),
                pose.position.east_m + distance * travel.sin(),
            );
            Piece::Line(Segment::new(pose.position, end))
        }
        // The centre is on the steered side of the vehicle; reversing, that
        // is the other side of the direction of travel.
        steer => {
            let side = if steer == Steer::Right { 1.0 } else { -1.0 };
            Piece::Arc(Arc::from_start(
                pose.position,
                travel,
                radius_m,
                side * direction.sign(),
                motion.length.abs(),
            ))
        }
    };
    let end = Pose {
        position: piece.point_at(piece.length_m()),
        yaw_rad: match piece {
            Piece::Line(_) => pose.yaw_rad,
            Piece::Arc(a) => wrap_pi(a.heading_at(a.length_m()) - flip),
        },
    };
    (piece, end)
}

/// The word driven from `start`, as strokes of one gear each (zero-length
/// motions dropped).
pub fn to_strokes(start: &Pose, word: &Word, radius_m: f64) -> Vec<Stroke> {
    let mut strokes: Vec<Stroke> = Vec::new();
    let mut pose = *start;
    for motion in word.motions.iter().filter(|m| m.length.abs() * radius_m > 1e-6) {
        let (piece, end) = drive(&pose, motion, radius_m);
        let direction = if motion.length >= 0.0 {
            Direction::Forward
        } else {
            Direction::Reverse
        };
        match strokes.last_mut() {
            Some(stroke) if stroke.direction == direction => {
                stroke.pieces.push(piece);
                stroke.end = end;
            }
            _ => strokes.push(Stroke {
                direction,
                pieces: vec![piece],
                end,
            }),
        }
        pose = end;
    }
    strokes
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn end_of(start: &Pose, word: &Word, radius_m: f64) -> Pose {
        to_strokes(start, word, radius_m).last().map_or(*start, |s| s.end)
    }

    #[test]
    fn a_goal_straight_ahead_is_one_straight_and_behind_one_reverse() {
        let start = Pose {
            position: Ned::new(0.0, 0.0),
            yaw_rad: 0.0,
        };
        for (north, gear) in [(7.0, 1.0), (-3.0, -1.0)] {
            let goal = Pose {
                position: Ned::new(north, 0.0),
                yaw_rad: 0.0,
            };
            let (x, y, phi) = normalise(&start, &goal, 5.0);
            let best = words(x, y, phi)
                .into_iter()
                .min_by(|a, b| a.length().total_cmp(&b.length()))
                .unwrap();
            assert!((best.length() * 5.0 - north.abs()).abs() < 1e-9, "{best:?}");
            let strokes = to_strokes(&start, &best, 5.0);
            assert_eq!(strokes.len(), 1);
            assert_eq!(strokes[0].direction.sign(), gear);
        }
    }

    #[test]
    fn a_reverse_left_arc_turns_the_nose_right() {
        // Backing up with the wheels to the left swings the rear left: the
        // nose turns clockwise (right).
        let start = Pose {
            position: Ned::new(0.0, 0.0),
            yaw_rad: 0.0,
        };
        let motion = Motion {
            steer: Steer::Left,
            length: -FRAC_PI_2_F,
        };
        let (_, end) = drive(&start, &motion, 5.0);
        assert!((end.yaw_rad - FRAC_PI_2_F).abs() < 1e-9, "{end:?}");
        assert!((end.position.north_m + 5.0).abs() < 1e-9 && (end.position.east_m + 5.0).abs() < 1e-9);
    }

    const FRAC_PI_2_F: f64 = std::f64::consts::FRAC_PI_2;

    proptest! {
        /// Every word the formulas give ends at the goal pose, never turns
        /// tighter than the radius, and changes gear at most twice.
        #[test]
        fn every_word_reaches_the_goal(
            n in -12.0f64..12.0, e in -12.0f64..12.0, yaw in -PI..PI,
            start_yaw in -PI..PI, radius in 1.0f64..8.0,
        ) {
            let start = Pose { position: Ned::new(1.0, -2.0), yaw_rad: start_yaw };
            let goal = Pose { position: Ned::new(1.0 + n, -2.0 + e), yaw_rad: yaw };
            let (x, y, phi) = normalise(&start, &goal, radius);
            let found = words(x, y, phi);
            prop_assert!(!found.is_empty(), "no CSC/CCC word");
            for w in &found {
                let end = end_of(&start, w, radius);
                prop_assert!(end.position.distance_to(&goal.position) < 1e-6, "{w:?} ends at {end:?}");
                prop_assert!(wrap_pi(end.yaw_rad - goal.yaw_rad).abs() < 1e-6, "{w:?} ends at {end:?}");
                prop_assert!(w.direction_changes() <= 2);
                for stroke in to_strokes(&start, w, radius) {
                    for piece in &stroke.pieces {
                        prop_assert!(piece.curvature().abs() <= 1.0 / radius + 1e-12);
                    }
                }
            }
        }
    }
}
