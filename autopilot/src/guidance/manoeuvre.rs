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
//! A manoeuvre that follows driving to the same goal (a retry after a miss,
//! the turn onto a far goal's heading after its straight leg) counts a first
//! stroke against the way the vehicle last drove as a change of direction
//! too: the limit is on the changes the wheels make on the way to the goal.
//!
//! A vehicle that can turn on the spot (differential drive, pivots allowed)
//! also has the pivot plan: turn in place to face the goal (or away from it,
//! to back in), drive the straight line to it, and turn in place onto its
//! heading. Each pivot costs `PIVOT_COST_M` (a stop, a turn and a rest),
//! so the arcs still win where a long approach is cheaper.

use std::f64::consts::PI;

use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::{Piece, Segment};
use crate::guidance::reeds_shepp::{Pose, Stroke, normalise, to_strokes, words};
use crate::guidance::tracker::Direction;

/// What a change of direction costs, in metres of path: a stop, a rest and
/// a start.
pub const CUSP_COST_M: f64 = 2.0;
/// What a turn on the spot costs, in metres of path, as a change of
/// direction does.
pub const PIVOT_COST_M: f64 = CUSP_COST_M;
/// A pivot is planned only for a heading change larger than this: the
/// tracker takes out a smaller one on the straight.
pub const PIVOT_MIN_RAD: f64 = 0.1 * PI / 180.0;
/// A goal this close is reached by turning on the spot alone: a straight
/// this short has no direction to pivot onto.
const PIVOT_ONLY_M: f64 = 0.002;
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
    /// The vehicle may turn on the spot (differential drive, `MNV_PIVOT`).
    pub pivots: bool,
    /// The way the vehicle last drove towards this goal, if it did: a first
    /// stroke the other way is a change of direction.
    pub arriving: Option<Direction>,
}

/// A planned manoeuvre: strokes of one gear each, stopping between them.
/// With `pivots`, the vehicle turns on the spot before each stroke onto the
/// heading it starts with, and after the last onto the goal's heading
/// (there may then be no stroke at all: a heading change at a stop).
#[derive(Clone, Debug, PartialEq)]
pub struct Manoeuvre {
    pub strokes: Vec<Stroke>,
    pub goal: Pose,
    pub pivots: bool,
}

impl Manoeuvre {
    pub fn length_m(&self) -> f64 {
        self.strokes.iter().map(Stroke::length_m).sum()
    }

    /// Changes between forward and reverse.
    pub fn direction_changes(&self) -> usize {
        self.strokes
            .windows(2)
            .filter(|w| w[0].direction != w[1].direction)
            .count()
    }

    /// Changes between forward and reverse after arriving driving
    /// `arriving`: the first stroke may be one too.
    pub fn direction_changes_after(&self, arriving: Option<Direction>) -> usize {
        let first = self.strokes.first().map(|s| s.direction);
        let turns_back = arriving.is_some() && first.is_some() && arriving != first;
        self.direction_changes() + usize::from(turns_back)
    }

    /// The way the last stroke drives (none for a pivot alone).
    pub fn last_direction(&self) -> Option<Direction> {
        self.strokes.last().map(|s| s.direction)
    }

    /// The headings the vehicle turns on the spot to, in order, from
    /// `start_yaw_rad`.
    pub fn pivot_headings(&self, start_yaw_rad: f64) -> Vec<f64> {
        if !self.pivots {
            return Vec::new();
        }
        let mut yaw = start_yaw_rad;
        let mut out = Vec::new();
        let starts = self.strokes.iter().map(|s| (stroke_start_yaw(s), s.end.yaw_rad));
        for (start, end) in starts.chain([(self.goal.yaw_rad, self.goal.yaw_rad)]) {
            if wrap_pi(start - yaw).abs() > PIVOT_MIN_RAD {
                out.push(start);
            }
            yaw = end;
        }
        out
    }

    pub fn cost_m(&self, start_yaw_rad: f64, arriving: Option<Direction>) -> f64 {
        self.length_m()
            + CUSP_COST_M * self.direction_changes_after(arriving) as f64
            + PIVOT_COST_M * self.pivot_headings(start_yaw_rad).len() as f64
    }
}

/// The vehicle's heading where a stroke starts.
pub fn stroke_start_yaw(stroke: &Stroke) -> f64 {
    let flip = if stroke.direction == Direction::Reverse {
        PI
    } else {
        0.0
    };
    wrap_pi(stroke.pieces[0].heading_at(0.0) - flip)
}

/// The pivot plans to `goal`: turn on the spot, drive the straight line
/// to it forwards or in reverse, turn onto its heading; or, for a goal
/// where the vehicle stands, only the turn.
fn pivot_candidates(start: &Pose, goal: &Pose) -> Vec<Manoeuvre> {
    let distance = start.position.distance_to(&goal.position);
    if distance < PIVOT_ONLY_M {
        return vec![Manoeuvre {
            strokes: Vec::new(),
            goal: *goal,
            pivots: true,
        }];
    }
    let bearing = start.position.bearing_to(&goal.position);
    [Direction::Forward, Direction::Reverse]
        .into_iter()
        .map(|direction| {
            let flip = if direction == Direction::Reverse { PI } else { 0.0 };
            let stroke = Stroke {
                direction,
                pieces: vec![Piece::Line(Segment::new(start.position, goal.position))],
                end: Pose {
                    position: goal.position,
                    yaw_rad: wrap_pi(bearing - flip),
                },
            };
            Manoeuvre {
                strokes: vec![stroke],
                goal: *goal,
                pivots: true,
            }
        })
        .collect()
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
            pivots: false,
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
            out.push(Manoeuvre {
                strokes,
                goal: *goal,
                pivots: false,
            });
        }
    }
    if config.pivots {
        out.extend(pivot_candidates(start, goal));
    }
    out
}

/// The cheapest manoeuvre to `goal` (with heading `yaw_rad`, or any) that
/// fits the limits.
pub fn plan(start: &Pose, goal: Ned, yaw_rad: Option<f64>, config: &ManoeuvreConfig) -> Result<Manoeuvre, Refusal> {
    plan_preferring(start, goal, yaw_rad, config, |_| true)
}

/// [`plan`], with the cheapest manoeuvre `preferred` accepts among those
/// that fit the limits, if any does (asked in order of cost, until one
/// does); else the cheapest that fits, as [`plan`].
pub fn plan_preferring(
    start: &Pose,
    goal: Ned,
    yaw_rad: Option<f64>,
    config: &ManoeuvreConfig,
    preferred: impl Fn(&Manoeuvre) -> bool,
) -> Result<Manoeuvre, Refusal> {
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
    let changes = |m: &Manoeuvre| m.direction_changes_after(config.arriving);
    let fitting_changes = all.iter().filter(|m| changes(m) <= config.max_direction_changes);
    let cost = |m: &Manoeuvre| m.cost_m(start.yaw_rad, config.arriving);
    let mut fitting: Vec<(f64, &Manoeuvre)> = fitting_changes
        .clone()
        .filter(|m| m.length_m() <= config.max_length_m)
        .map(|m| (cost(m), m))
        .collect();
    // Stable: of equal costs the first candidate, as `min_by` took it.
    fitting.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = fitting.iter().find(|(_, m)| preferred(m)).or(fitting.first());
    if let Some((_, best)) = best {
        return Ok((*best).clone());
    }
    match fitting_changes.map(Manoeuvre::length_m).min_by(f64::total_cmp) {
        Some(shortest_m) => Err(Refusal::TooLong { shortest_m }),
        None => Err(Refusal::TooManyDirectionChanges {
            fewest: all.iter().map(changes).min().unwrap_or(0),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::FRAC_PI_2;

    fn config() -> ManoeuvreConfig {
        ManoeuvreConfig {
            radius_m: 6.0,
            approach_m: 3.0,
            max_length_m: 60.0,
            max_direction_changes: 3,
            pivots: false,
            arriving: None,
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

    /// A centimetre beside the goal the vehicle may go out forwards and
    /// back, or back and forwards: a preference for the first stroke the
    /// cheapest plan does not take gets a plan that takes it, and a
    /// preference nothing meets leaves the plan as it was.
    #[test]
    fn a_preferred_manoeuvre_is_the_cheapest_the_preference_accepts() {
        let goal = Ned::new(0.0, 0.01);
        let cheapest = plan(&start(), goal, Some(0.0), &config()).unwrap();
        let first_way = cheapest.strokes[0].direction;
        let other_way = if first_way == Direction::Forward {
            Direction::Reverse
        } else {
            Direction::Forward
        };
        let other = plan_preferring(&start(), goal, Some(0.0), &config(), |m| {
            m.strokes[0].direction == other_way
        })
        .unwrap();
        check_shape(&other, &start(), &config()).unwrap();
        assert_eq!(other.strokes[0].direction, other_way, "{other:?}");
        let none = plan_preferring(&start(), goal, Some(0.0), &config(), |_| false).unwrap();
        assert_eq!(none, cheapest);
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

    #[test]
    fn a_first_stroke_against_the_way_it_arrived_is_a_change_of_direction() {
        // Straight ahead: one forward stroke, no change of its own…
        let ahead = Ned::new(4.0, 0.0);
        let m = plan(&start(), ahead, Some(0.0), &config()).unwrap();
        assert_eq!((m.direction_changes(), m.direction_changes_after(None)), (0, 0));
        // …but one after arriving in reverse, so a limit of none refuses it.
        assert_eq!(m.direction_changes_after(Some(Direction::Reverse)), 1);
        let arrived_reversing = ManoeuvreConfig {
            max_direction_changes: 0,
            arriving: Some(Direction::Reverse),
            ..config()
        };
        assert_eq!(
            plan(&start(), ahead, Some(0.0), &arrived_reversing),
            Err(Refusal::TooManyDirectionChanges { fewest: 1 })
        );
        // Any goal planned after arriving either way keeps to the limit,
        // the junction counted.
        for arriving in [Direction::Forward, Direction::Reverse] {
            let cfg = ManoeuvreConfig {
                arriving: Some(arriving),
                ..config()
            };
            for (north, east) in [(0.02, 0.01), (1.0, 2.0), (-3.0, 1.0), (0.0, -0.5)] {
                let m = plan(&start(), Ned::new(north, east), Some(0.0), &cfg).unwrap();
                check_shape(&m, &start(), &cfg).unwrap();
                assert!(m.direction_changes_after(Some(arriving)) <= 3, "{m:?}");
            }
        }
    }

    #[test]
    fn a_vehicle_that_pivots_turns_on_the_spot_for_a_goal_beside() {
        let cfg = ManoeuvreConfig {
            pivots: true,
            ..config()
        };
        let m = plan(&start(), Ned::new(0.0, 3.0), Some(0.0), &cfg).unwrap();
        assert!(m.pivots, "{m:?}");
        assert_eq!(m.direction_changes(), 0);
        assert!((m.length_m() - 3.0).abs() < 1e-9, "{}", m.length_m());
        let pivots = m.pivot_headings(0.0);
        assert_eq!(pivots.len(), 2, "{pivots:?}");
        // Facing along the line (east, or west to back in), then north.
        assert!((wrap_pi(pivots[0]).abs() - FRAC_PI_2).abs() < 1e-9, "{pivots:?}");
        assert!(pivots[1].abs() < 1e-12);
        // The same goal without pivots takes arcs and is longer.
        let arcs = plan(&start(), Ned::new(0.0, 3.0), Some(0.0), &config()).unwrap();
        assert!(!arcs.pivots && arcs.length_m() > 3.0);
    }

    #[test]
    fn a_centimetre_miss_of_a_vehicle_that_pivots_is_a_turn_drive_turn() {
        // A retry 12 mm short and to the side: face the goal, drive the
        // 12 mm, turn back (not a turn on the spot alone, which cannot
        // move the vehicle), whichever way the vehicle arrived.
        for arriving in [None, Some(Direction::Forward), Some(Direction::Reverse)] {
            let cfg = ManoeuvreConfig {
                pivots: true,
                arriving,
                ..config()
            };
            let goal = Ned::new(0.008, 0.009);
            let m = plan(&start(), goal, Some(0.0), &cfg).unwrap();
            assert!(m.pivots, "{m:?}");
            assert_eq!(m.strokes.len(), 1, "{m:?}");
            assert!((m.length_m() - 0.008f64.hypot(0.009)).abs() < 1e-12, "{}", m.length_m());
            assert!(m.strokes[0].end.position.distance_to(&goal) < 1e-12);
            assert_eq!(m.direction_changes_after(arriving), 0, "{m:?}");
            assert_eq!(m.pivot_headings(0.0).len(), 2, "{m:?}");
        }
    }

    #[test]
    fn a_heading_change_at_a_stop_is_a_pivot_alone() {
        let cfg = ManoeuvreConfig {
            pivots: true,
            ..config()
        };
        let m = plan(&start(), Ned::new(0.001, 0.0), Some(2.0), &cfg).unwrap();
        assert!(m.strokes.is_empty(), "{m:?}");
        assert_eq!(m.pivot_headings(0.0), vec![2.0]);
        assert_eq!(m.length_m(), 0.0);
    }

    proptest! {
        /// With pivots, any goal 1–10 m away is planned within the limits,
        /// never dearer than turning, driving straight and turning.
        #[test]
        fn with_pivots_no_plan_is_dearer_than_the_pivot_plan(
            distance in 1.0f64..10.0, bearing in -PI..PI, yaw in -PI..PI, start_yaw in -PI..PI,
        ) {
            let cfg = ManoeuvreConfig { pivots: true, ..config() };
            let from = Pose { position: Ned::new(0.0, 0.0), yaw_rad: start_yaw };
            let goal = Ned::new(distance * bearing.cos(), distance * bearing.sin());
            let m = plan(&from, goal, Some(yaw), &cfg).map_err(|e| TestCaseError::fail(format!("{e}")))?;
            prop_assert!(m.direction_changes() <= cfg.max_direction_changes);
            prop_assert!(m.length_m() <= cfg.max_length_m);
            let pivot_plan_cost = distance + 2.0 * PIVOT_COST_M;
            prop_assert!(m.cost_m(start_yaw, None) <= pivot_plan_cost + 1e-9, "{} > {}", m.cost_m(start_yaw, None), pivot_plan_cost);
            if m.pivots {
                let last = m.strokes.last().unwrap();
                prop_assert!(last.end.position.distance_to(&goal) < 1e-9);
                prop_assert!(m.pivot_headings(start_yaw).len() <= 2);
            }
        }

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
                        prop_assert!(m.cost_m(0.0, None) <= other.cost_m(0.0, None) + 1e-9);
                    }
                }
            }
        }
    }
}
