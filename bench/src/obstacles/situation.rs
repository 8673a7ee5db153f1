//! Where a collision or a false stop happened, for the randomized part's
//! breakdown, so the next fix knows where to look:
//! - the vehicle's **phase**: in a stop's tail (an obstacle stop announced
//!   and no "Obstacle clear" since: braking, creeping or waiting), starting
//!   (within [`STARTING_S`] of leaving rest, at the mission's start or on
//!   resuming), at rest, or moving;
//! - the **object** standing or walking (its true velocity);
//! - **arc** or straight: the course's turn about the vehicle's place on it
//!   (a radius under [`ARC_RADIUS_M`]), and **forwards** or **reverse**: the
//!   direction the course drives there.
//!
//! The phase comes from the STATUSTEXTs' timing and the true speed; the
//! rest from the truth.

use std::collections::BTreeMap;

use super::truth::{MOVING_MPS, Pose};

/// Leaving rest counts as starting for this long.
pub const STARTING_S: f64 = 3.0;
/// A course turning tighter than this is in an arc, m (the generator's
/// arcs are 6–15 m; a straight leg's heading wobble is far wider).
pub const ARC_RADIUS_M: f64 = 40.0;

/// What the vehicle was doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Phase {
    Moving,
    StopTail,
    Starting,
    AtRest,
}

/// The situation of one collision or false stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Situation {
    pub phase: Phase,
    pub walking: bool,
    pub arc: bool,
    pub reverse: bool,
}

impl Situation {
    pub fn label(&self) -> String {
        let phase = match self.phase {
            Phase::Moving => "moving",
            Phase::StopTail => "in a stop's tail",
            Phase::Starting => "starting/resuming",
            Phase::AtRest => "at rest",
        };
        format!(
            "{phase}, object {}, {}, {}",
            if self.walking { "walking" } else { "standing" },
            if self.arc { "arc" } else { "straight" },
            if self.reverse { "reverse" } else { "forwards" }
        )
    }
}

/// Follows the run's obstacle stops and its starts from rest.
#[derive(Debug, Default)]
pub struct PhaseWatch {
    stop_in_force: bool,
    moving_since_s: Option<f64>,
}

impl PhaseWatch {
    /// The true pose of this tick.
    pub fn update(&mut self, pose: &Pose) {
        if pose.speed_mps.abs() > MOVING_MPS {
            self.moving_since_s.get_or_insert(pose.t_s);
        } else {
            self.moving_since_s = None;
        }
    }

    /// This tick's STATUSTEXTs, after its situations are taken.
    pub fn texts(&mut self, texts: &[String]) {
        for text in texts {
            if text.starts_with("Obstacle stop:") {
                self.stop_in_force = true;
            } else if text.starts_with("Obstacle clear") {
                self.stop_in_force = false;
            }
        }
    }

    pub fn phase(&self, pose: &Pose) -> Phase {
        match self.moving_since_s {
            _ if self.stop_in_force => Phase::StopTail,
            None => Phase::AtRest,
            Some(since_s) if pose.t_s - since_s < STARTING_S => Phase::Starting,
            Some(_) => Phase::Moving,
        }
    }
}

/// Counts per situation: collisions (of them avoidable) and false stops.
#[derive(Debug, Default)]
pub struct Breakdown {
    rows: BTreeMap<Situation, [u32; 3]>,
}

impl Breakdown {
    pub fn collision(&mut self, situation: Situation, unavoidable: bool) {
        let row = self.rows.entry(situation).or_default();
        row[0] += 1;
        row[1] += u32::from(!unavoidable);
    }

    pub fn false_stop(&mut self, situation: Situation) {
        self.rows.entry(situation).or_default()[2] += 1;
    }

    /// A table, the most frequent situation first.
    pub fn print(&self) {
        let mut rows: Vec<(&Situation, &[u32; 3])> = self.rows.iter().collect();
        rows.sort_by_key(|(s, n)| (std::cmp::Reverse(n[1] + n[2]), std::cmp::Reverse(n[0]), **s));
        println!("| situation (vehicle, object, course, direction) | collisions | of them avoidable | false stops |");
        println!("|---|---:|---:|---:|");
        for (situation, n) in rows {
            println!("| {} | {} | {} | {} |", situation.label(), n[0], n[1], n[2]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_s: f64, speed_mps: f64) -> Pose {
        Pose {
            t_s,
            speed_mps,
            ..Pose::default()
        }
    }

    #[test]
    fn phases_follow_the_stops_and_starts() {
        let mut watch = PhaseWatch::default();
        watch.update(&at(0.0, 0.0));
        assert_eq!(watch.phase(&at(0.0, 0.0)), Phase::AtRest);
        watch.update(&at(1.0, 0.5));
        assert_eq!(watch.phase(&at(1.0, 0.5)), Phase::Starting);
        watch.update(&at(4.5, 1.5));
        assert_eq!(watch.phase(&at(4.5, 1.5)), Phase::Moving);
        watch.texts(&["Obstacle stop: obstacle #3 collision in 2.0 s".to_string()]);
        watch.update(&at(5.0, 0.03));
        assert_eq!(watch.phase(&at(5.0, 0.03)), Phase::StopTail);
        watch.update(&at(6.0, 0.0));
        watch.texts(&["Obstacle clear: resuming after 1.0 s".to_string()]);
        watch.update(&at(6.5, 0.2));
        assert_eq!(watch.phase(&at(6.5, 0.2)), Phase::Starting);
    }

    #[test]
    fn the_breakdown_counts_avoidable_collisions_apart() {
        let s = Situation {
            phase: Phase::Moving,
            walking: true,
            arc: false,
            reverse: false,
        };
        let mut b = Breakdown::default();
        b.collision(s, true);
        b.collision(s, false);
        b.false_stop(s);
        assert_eq!(b.rows[&s], [2, 1, 1]);
    }
}
