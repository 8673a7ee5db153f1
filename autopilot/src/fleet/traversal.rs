//! When a node counts as traversed (§6.10.2): the vehicle's control point
//! within the node's `allowedDeviationXY`, and its heading within
//! `allowedDeviationTheta` when the node gives a `theta`, by the estimate
//! *and* its uncertainty (the estimate's distance plus the radius that holds
//! the vehicle with 95 % confidence). A node the vehicle stops on counts
//! by the same rule, while it is still rolling in: the standard asks for
//! the control point within the deviation, not for rest (its blocking
//! actions wait for rest, see [`super::actions`]).
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
            driven_past,
            left_behind,
            way,
        } = passage;
        let Some((x, y)) = node.node_position.as_ref().map(|p| (p.x, p.y)) else {
            return if driven_past { Verdict::Traversed } else { Verdict::No };
        };
        // Behind the vehicle: farther than at its closest by more than the
        // estimate's wander and beyond the node along the way through it,
        // or a whole leg ago.
        let receding = |closest_m: f64, distance: f64, fix: &Fix| {
            let beyond = (fix.pose.x_m - x) * way.0 + (fix.pose.y_m - y) * way.1 > 0.0;
            (distance > closest_m + PASSED_BY_M && beyond) || left_behind
        };
        let Some(allowed_m) = allowed_deviation_m(node) else {
            // No deviation of its own: the navigator's tolerance decides a
            // stop; a node driven through counts once behind the vehicle.
            return match fix {
                _ if stops => traversed_if(driven_past),
                Some(fix) => {
                    let distance = (fix.pose.x_m - x).hypot(fix.pose.y_m - y);
                    self.closest_m = self.closest_m.min(distance);
                    traversed_if(driven_past && receding(self.closest_m, distance, fix))
                }
                None => traversed_if(driven_past),
            };
        };
        let Some(fix) = fix else {
            // No position (the vehicle holds without one): only a node
            // the navigator has left a whole leg behind is missed.
            return if left_behind {
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
        if distance + fix.position_bound_m <= allowed_m && heading_fits(node, fix) {
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
}

fn traversed_if(traversed: bool) -> Verdict {
    if traversed { Verdict::Traversed } else { Verdict::No }
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    fn node(theta: Option<f64>) -> Node {
        let mut position = json!({"x": 10.0, "y": 0.0, "mapId": "yard", "allowedDeviationXY": 0.3});
        if let Some(theta) = theta {
            position["theta"] = json!(theta);
            position["allowedDeviationTheta"] = json!(0.1);
        }
        serde_json::from_value(json!({
            "nodeId": "b", "sequenceId": 2, "released": true, "actions": [], "nodePosition": position,
        }))
        .unwrap()
    }

    fn fix(x_m: f64, theta_rad: f64) -> Fix {
        Fix {
            pose: MapPose {
                x_m,
                y_m: 0.0,
                theta_rad,
            },
            position_bound_m: 0.02,
            yaw_bound_rad: 0.01,
        }
    }

    const THROUGH: Passage = Passage {
        stops: false,
        driven_past: true,
        left_behind: false,
        way: (2.0, 0.0),
    };

    #[test]
    fn a_heading_outside_the_nodes_theta_keeps_it_from_counting_and_passing_it_is_a_miss() {
        let mut watch = Watch::default();
        let b = node(Some(0.5));
        for x in [9.8, 10.0, 10.04] {
            assert_eq!(watch.judge(&b, Some(&fix(x, 0.0)), &THROUGH), Verdict::No, "at {x}");
        }
        let verdict = watch.judge(&b, Some(&fix(10.1, 0.0)), &THROUGH);
        assert_eq!(
            verdict,
            Verdict::Missed {
                closest_m: 0.0,
                allowed_m: 0.3
            }
        );
        let mut watch = Watch::default();
        assert_eq!(watch.judge(&b, Some(&fix(9.8, 0.45)), &THROUGH), Verdict::Traversed);
    }

    #[test]
    fn without_a_fix_a_node_waits_until_it_is_a_whole_leg_behind() {
        let mut watch = Watch::default();
        let b = node(None);
        assert_eq!(watch.judge(&b, None, &THROUGH), Verdict::No);
        let behind = Passage {
            left_behind: true,
            ..THROUGH
        };
        assert!(matches!(watch.judge(&b, None, &behind), Verdict::Missed { .. }));
    }

    #[test]
    fn a_stop_counts_within_its_deviation_while_rolling_in_and_by_the_navigator_without_one() {
        let stop = Passage {
            stops: true,
            driven_past: false,
            ..THROUGH
        };
        let mut watch = Watch::default();
        let b = node(Some(0.0));
        assert_eq!(watch.judge(&b, Some(&fix(9.6, 0.0)), &stop), Verdict::No, "0.4 m short");
        assert_eq!(
            watch.judge(&b, Some(&fix(9.9, 0.2)), &stop),
            Verdict::No,
            "heading outside its deviation"
        );
        assert_eq!(watch.judge(&b, Some(&fix(9.9, 0.05)), &stop), Verdict::Traversed);
        // No deviation of its own: the navigator's tolerance decides.
        let mut bare = node(None);
        bare.node_position.as_mut().unwrap().allowed_deviation_x_y = Some(0.0);
        let mut watch = Watch::default();
        assert_eq!(watch.judge(&bare, Some(&fix(10.0, 0.0)), &stop), Verdict::No);
        let settled = Passage {
            driven_past: true,
            ..stop
        };
        assert_eq!(watch.judge(&bare, Some(&fix(10.0, 0.0)), &settled), Verdict::Traversed);
    }
}
