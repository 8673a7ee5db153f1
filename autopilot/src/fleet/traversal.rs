//! When a node counts as traversed (§6.10.2): the vehicle's control point
//! within the node's `allowedDeviationXY`, and its heading within
//! `allowedDeviationTheta` when the node gives a `theta`, by the estimate
//! *and* its uncertainty (the estimate's distance plus the radius that holds
//! the vehicle with 95 % confidence). A node the vehicle stops on counts
//! only once it is at rest there.
//!
//! The navigator's own leg switching (`WP_RADIUS` ahead of a node it drives
//! through, the corner arc's middle) only moves the driving on; it claims
//! nothing. A node driven past without ever being within its deviation
//! counts as traversed at its closest approach, with an error in `state`
//! saying by how much it was missed: the order goes on, and nothing is
//! claimed silently.
//!
//! Pure: the agent feeds it the pose each tick.

use vda5050::order::Node;

use crate::geo::wrap_pi;

use super::map::MapPose;

/// Past its closest approach by this much (m), and beyond the node along
/// the way through it, a node driven past is behind the vehicle: the
/// estimate's distance grows on by more than its tick-to-tick wander (and
/// a detour swerving before the node does not count).
pub const PASSED_BY_M: f64 = 0.05;

/// Where the vehicle is, with what the estimate is sure of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix {
    pub pose: MapPose,
    /// The radius about the pose that holds the vehicle with 95 %
    /// confidence (m).
    pub position_bound_m: f64,
    /// The heading's 95 % bound (rad).
    pub yaw_bound_rad: f64,
}

/// What the vehicle's pose says of one node this tick.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Not (yet) traversed.
    No,
    /// Within the allowed deviation, for sure.
    Traversed,
    /// Driven past, never within the allowed deviation: the closest the
    /// estimate came (m) and what was allowed (m).
    Missed { closest_m: f64, allowed_m: f64 },
}

/// How the vehicle comes to a node this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Passage {
    /// The vehicle is to stop on the node.
    pub stops: bool,
    /// It stands still.
    pub at_rest: bool,
    /// The navigator has finished the leg to the node (driven through it,
    /// or settled on it).
    pub driven_past: bool,
    /// …and the leg after it too: the node is behind whatever the way.
    pub left_behind: bool,
    /// The way through the node (map frame, not necessarily unit): the
    /// edge in plus the edge out.
    pub way: (f64, f64),
}

/// The watch on the next node to traverse: how close the vehicle has come.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Watch {
    pub closest_m: f64,
}

impl Default for Watch {
    fn default() -> Self {
        Watch {
            closest_m: f64::INFINITY,
        }
    }
}

/// The node's allowed deviation (m), when it gives one (0 means "the
/// vehicle's normal tolerance", the navigator's).
pub fn allowed_deviation_m(node: &Node) -> Option<f64> {
    let position = node.node_position.as_ref()?;
    position.allowed_deviation_x_y.filter(|d| *d > 0.0)
}

/// Whether the heading is within the node's `theta` ± `allowedDeviationTheta`
/// for sure (true when the node gives no theta or no deviation for it).
fn heading_fits(node: &Node, fix: &Fix) -> bool {
    let Some(position) = node.node_position.as_ref() else {
        return true;
    };
    match (position.theta, position.allowed_deviation_theta.filter(|d| *d > 0.0)) {
        (Some(theta), Some(allowed)) => wrap_pi(fix.pose.theta_rad - theta).abs() + fix.yaw_bound_rad <= allowed,
        _ => true,
    }
}

impl Watch {
    /// One tick of the node.
    pub fn judge(&mut self, node: &Node, fix: Option<&Fix>, passage: &Passage) -> Verdict {
        let &Passage {
            stops,
            at_rest,
            driven_past,
            left_behind,
            way,
        } = passage;
        let Some((x, y)) = node.node_position.as_ref().map(|p| (p.x, p.y)) else {
            return if driven_past { Verdict::Traversed } else { Verdict::No };
        };
        // Closer than ever, or not yet beyond the node.
        let receding = |closest_m: f64, distance: f64, fix: &Fix| {
            let beyond = (fix.pose.x_m - x) * way.0 + (fix.pose.y_m - y) * way.1 > 0.0;
            (distance > closest_m + PASSED_BY_M && beyond) || left_behind
        };
        let Some(allowed_m) = allowed_deviation_m(node) else {
            // No deviation of its own: the navigator's tolerance decides a
            // stop; a node driven through counts once behind the vehicle.
            return match fix {
                _ if stops => self.verdict(driven_past),
                Some(fix) => {
                    let distance = (fix.pose.x_m - x).hypot(fix.pose.y_m - y);
                    self.closest_m = self.closest_m.min(distance);
                    self.verdict(driven_past && receding(self.closest_m, distance, fix))
                }
                None => self.verdict(driven_past),
            };
        };
        let Some(fix) = fix else {
            return if driven_past {
                Verdict::Missed {
                    closest_m: self.closest_m,
                    allowed_m,
                }
            } else {
                Verdict::No
            };
        };
        let distance = (fix.pose.x_m - x).hypot(fix.pose.y_m - y);
        self.closest_m = self.closest_m.min(distance);
        let within = distance + fix.position_bound_m <= allowed_m && heading_fits(node, fix);
        // A stop counts once at rest there (the navigator's settling says
        // so too).
        if within && (!stops || at_rest || driven_past) {
            return Verdict::Traversed;
        }
        let behind = if stops {
            driven_past
        } else {
            driven_past && receding(self.closest_m, distance, fix)
        };
        if behind {
            Verdict::Missed {
                closest_m: self.closest_m,
                allowed_m,
            }
        } else {
            Verdict::No
        }
    }

    fn verdict(&self, traversed: bool) -> Verdict {
        if traversed { Verdict::Traversed } else { Verdict::No }
    }
}
