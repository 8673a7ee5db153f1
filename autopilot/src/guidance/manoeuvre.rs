//! Manoeuvres: reaching a pose the current leg cannot (beside, behind,
//! inside the turning circle) with a short forward/reverse path.
//!
//! The path is the Reeds–Shepp word to a point `approach_m` before the goal
//! on its heading, then a straight into the goal: a precision stop needs a
//! straight stretch to settle heading and cross-track on, which a word that
//! ends in an arc does not give. The approach may be driven forwards or in
//! reverse, whichever is shorter. A goal without a heading tries a fan of
//! headings (and the bearing from the vehicle) and keeps the cheapest.
//!
//! Cheapest: the length plus `CUSP_COST_M` per change of direction (each is
//! a stop and a rest), within the limits on length and direction changes.

use std::f64::consts::PI;

use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::{Piece, Segment};
use crate::guidance::reeds_shepp::{Pose, Stroke, normalise, to_strokes, words};
use crate::guidance::tracker::Direction;

/// What a change of direction costs, in metres of path: a stop, a rest and
/// a start.
pub const CUSP_COST_M: f64 = 2.0;
/// Headings tried for a goal that has none.
const FREE_HEADINGS: usize = 16;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManoeuvreConfig {
    /// The turning radius planned with (the tightest turn with the arc
    /// margin, so the tracker has room to correct).
    pub radius_m: f64,
    /// The straight into the goal.
    pub approach_m: f64,
    pub max_length_m: f64,
    pub max_direction_changes: usize,
}

/// A planned manoeuvre: strokes of one gear each, stopping between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Manoeuvre {
    pub strokes: Vec<Stroke>,
    pub goal: Pose,
}

impl Manoeuvre {
    pub fn length_m(&self) -> f64 {
        self.strokes.iter().map(Stroke::length_m).sum()
    }

    pub fn direction_changes(&self) -> usize {
        self.strokes.len().saturating_sub(1)
    }

    pub fn cost_m(&self) -> f64 {
        self.length_m() + CUSP_COST_M * self.direction_changes() as f64
    }
}

/// Why no manoeuvre was planned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Refusal {
    /// The shortest path that fits the direction-change limit is longer
    /// than the length limit.
    TooLong { shortest_m: f64 },
    /// Every path changes direction more often than allowed.
    TooManyDirectionChanges { fewest: usize },
    /// A goal or start that is not a finite number.
    Invalid,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::TooLong { shortest_m } => write!(f, "shortest path {shortest_m:.1} m is too long"),
            Refusal::TooManyDirectionChanges { fewest } => {
                write!(f, "needs {fewest} direction changes")
            }
            Refusal::Invalid => write!(f, "invalid goal"),
        }
    }
}

/// Every manoeuvre from `start` to `goal` (heading `yaw_rad`) through
/// each approach direction, limits not applied; and the words straight to
/// the goal that end with a straight at least as long as the approach, or
/// are one straight (the vehicle already on the goal's line).
pub fn candidates(start: &Pose, goal: &Pose, config: &ManoeuvreConfig) -> Vec<Manoeuvre> {
    let (x, y, phi) = normalise(start, goal, config.radius_m);
    let mut out: Vec<Manoeuvre> = words(x, y, phi)
        .into_iter()
        .map(|word| Manoeuvre {
            strokes: to_strokes(start, &word, config.radius_m),
            goal: *goal,
        })
        .filter(|m| {
            let pieces: Vec<&Piece> = m.strokes.iter().flat_map(|s| &s.pieces).collect();
            match pieces.as_slice() {
                [Piece::Line(_)] => true,
                [.., Piece::Line(last)] => last.length_m() >= config.approach_m,
                _ => false,
            }
        })
        .collect();
    for approach in [Direction::Forward, Direction::Reverse] {
        // The vehicle drives into the goal along its heading (forwards) or
        // backs into it (reverse): the approach starts before it in the
        // direction of travel.
        let travel = wrap_pi(goal.yaw_rad + if approach == Direction::Reverse { PI } else { 0.0 });
        let pre = Pose {
            position: Ned::new(
                goal.position.north_m - config.approach_m * travel.cos(),
                goal.position.east_m - config.approach_m * travel.sin(),
            ),
            yaw_rad: goal.yaw_rad,
        };
        let (x, y, phi) = normalise(start, &pre, config.radius_m);
        for word in words(x, y, phi) {
            let mut strokes = to_strokes(start, &word, config.radius_m);
            let line = Piece::Line(Segment::new(pre.position, goal.position));
            match strokes.last_mut() {
                Some(last) if last.direction == approach => {
                    last.pieces.push(line);
                    last.end = *goal;
                }
                _ => strokes.push(Stroke {
                    direction: approach,
                    pieces: vec![line],
                    end: *goal,
                }),
            }
            out.push(Manoeuvre { strokes, goal: *goal });
        }
    }
    out
}

/// The cheapest manoeuvre to `goal` (with heading `yaw_rad`, or any) that
/// fits the limits.
pub fn plan(start: &Pose, goal: Ned, yaw_rad: Option<f64>, config: &ManoeuvreConfig) -> Result<Manoeuvre, Refusal> {
    let finite = [
        start.position.north_m,
        start.position.east_m,
        start.yaw_rad,
        goal.north_m,
        goal.east_m,
    ]
    .iter()
    .chain(yaw_rad.as_ref())
    .all(|v| v.is_finite());
    if !(finite && config.radius_m > 0.0 && config.approach_m >= 0.0) {
        return Err(Refusal::Invalid);
    }
    let headings: Vec<f64> = match yaw_rad {
        Some(yaw) => vec![yaw],
        None => (0..FREE_HEADINGS)
            .map(|i| wrap_pi(2.0 * PI * i as f64 / FREE_HEADINGS as f64))
            .chain([start.yaw_rad, start.position.bearing_to(&goal)])
            .collect(),
    };
    let all: Vec<Manoeuvre> = headings
        .iter()
        .flat_map(|&yaw| {
            let goal = Pose {
                position: goal,
                yaw_rad: yaw,
            };
            candidates(start, &goal, config)
        })
        .collect();
    let fitting_changes = all
        .iter()
        .filter(|m| m.direction_changes() <= config.max_direction_changes);
    let best = fitting_changes
        .clone()
        .filter(|m| m.length_m() <= config.max_length_m)
        .min_by(|a, b| a.cost_m().total_cmp(&b.cost_m()));
    if let Some(best) = best {
        return Ok(best.clone());
    }
    match fitting_changes.map(Manoeuvre::length_m).min_by(f64::total_cmp) {
        Some(shortest_m) => Err(Refusal::TooLong { shortest_m }),
        None => Err(Refusal::TooManyDirectionChanges {
            fewest: all.iter().map(Manoeuvre::direction_changes).min().unwrap_or(0),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn config() -> ManoeuvreConfig {
        ManoeuvreConfig {
            radius_m: 6.0,
            approach_m: 3.0,
            max_length_m: 60.0,
            max_direction_changes: 3,
        }
    }

    fn start() -> Pose {
        Pose {
            position: Ned::new(0.0, 0.0),
            yaw_rad: 0.0,
        }
    }

    /// Strokes are continuous, alternate in gear, end at the goal pose and
    /// never turn tighter than the planning radius.
    fn check_shape(m: &Manoeuvre, start: &Pose, config: &ManoeuvreConfig) -> Result<(), String> {
        let mut at = *start;
        for (i, stroke) in m.strokes.iter().enumerate() {
            if i > 0 && stroke.direction == m.strokes[i - 1].direction {
                return Err(format!("stroke {i} does not change direction"));
            }
            let flip = if stroke.direction == Direction::Reverse {
                PI
            } else {
                0.0
            };
            let first = stroke.pieces[0];
            if first.point_at(0.0).distance_to(&at.position) > 1e-6
                || wrap_pi(first.heading_at(0.0) - flip - at.yaw_rad).abs() > 1e-6
            {
                return Err(format!("stroke {i} does not start where the last ended"));
            }
            for piece in &stroke.pieces {
                if piece.curvature().abs() > 1.0 / config.radius_m + 1e-12 {
                    return Err(format!("stroke {i} turns tighter than the radius"));
                }
            }
            let last = stroke.pieces[stroke.pieces.len() - 1];
            let end = last.point_at(last.length_m());
            if end.distance_to(&stroke.end.position) > 1e-6 {
                return Err(format!("stroke {i} ends at {end:?}, not {:?}", stroke.end));
            }
            at = stroke.end;
        }
        if at.position.distance_to(&m.goal.position) > 1e-6 || wrap_pi(at.yaw_rad - m.goal.yaw_rad).abs() > 1e-6 {
            return Err(format!("ends at {at:?}, not at the goal {:?}", m.goal));
        }
        Ok(())
    }

    #[test]
    fn a_goal_behind_is_reached_by_backing_up() {
        let m = plan(&start(), Ned::new(-4.0, 0.0), Some(0.0), &config()).unwrap();
        check_shape(&m, &start(), &config()).unwrap();
        assert_eq!(m.strokes.len(), 1, "{m:?}");
        assert_eq!(m.strokes[0].direction, Direction::Reverse);
        assert!((m.length_m() - 4.0).abs() < 1e-9);
    }

    #[test]
    fn a_goal_beside_inside_the_turning_circle_needs_reverse() {
        let m = plan(&start(), Ned::new(1.0, 2.0), Some(0.0), &config()).unwrap();
        check_shape(&m, &start(), &config()).unwrap();
        assert!(m.direction_changes() >= 1 && m.direction_changes() <= 3, "{m:?}");
        assert!(m.length_m() < 30.0, "{}", m.length_m());
    }

    #[test]
    fn the_limits_refuse_with_the_reason() {
        let tight = ManoeuvreConfig {
            max_length_m: 5.0,
            ..config()
        };
        let refusal = plan(&start(), Ned::new(3.0, 6.0), Some(PI), &tight).unwrap_err();
        assert!(
            matches!(refusal, Refusal::TooLong { shortest_m } if shortest_m > 5.0),
            "{refusal:?}"
        );
        let no_reverse = ManoeuvreConfig {
            max_direction_changes: 0,
            ..config()
        };
        // Straight behind is one reverse stroke: no change of direction.
        let m = plan(&start(), Ned::new(-2.0, 0.0), Some(0.0), &no_reverse).unwrap();
        assert_eq!((m.strokes.len(), m.strokes[0].direction), (1, Direction::Reverse));
        // Beside, inside the turning circle: not without changing direction.
        match plan(&start(), Ned::new(1.0, 2.0), Some(0.0), &no_reverse) {
            Ok(m) => assert_eq!(m.direction_changes(), 0, "{m:?}"),
            Err(Refusal::TooManyDirectionChanges { fewest }) => assert!(fewest >= 1),
            Err(other) => panic!("{other:?}"),
        }
        assert!(plan(&start(), Ned::new(f64::NAN, 0.0), None, &config()).is_err());
    }

    proptest! {
        /// Any goal 1–10 m away in any direction, with or without a heading:
        /// a manoeuvre within the limits that ends at the goal, the cheapest
        /// of all the candidates that fit.
        #[test]
        fn any_near_goal_is_planned_within_the_limits(
            distance in 1.0f64..10.0, bearing in -PI..PI, yaw in proptest::option::of(-PI..PI),
        ) {
            let cfg = config();
            let goal = Ned::new(distance * bearing.cos(), distance * bearing.sin());
            let m = plan(&start(), goal, yaw, &cfg).map_err(|e| TestCaseError::fail(format!("{e}")))?;
            check_shape(&m, &start(), &cfg).map_err(TestCaseError::fail)?;
            prop_assert!(m.direction_changes() <= cfg.max_direction_changes);
            prop_assert!(m.length_m() <= cfg.max_length_m);
            if let Some(yaw) = yaw {
                prop_assert!(wrap_pi(m.goal.yaw_rad - yaw).abs() < 1e-12);
                let goal_pose = Pose { position: goal, yaw_rad: yaw };
                for other in candidates(&start(), &goal_pose, &cfg) {
                    if other.direction_changes() <= cfg.max_direction_changes && other.length_m() <= cfg.max_length_m {
                        prop_assert!(m.cost_m() <= other.cost_m() + 1e-9);
                    }
                }
            }
        }
    }
}
