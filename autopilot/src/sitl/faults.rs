//! Faults a test injects through `SIM_*` parameters (as ArduPilot's SITL
//! does): what the simulation changes while each is set. Sensor faults
//! that are plain settings of the simulated receiver or scanners
//! (`SIM_GPS_DISABLE`, `SIM_GPS_QUALITY`, `SIM_GPS_GLITCH_*`,
//! `SIM_HDG_ENABLE`, `SIM_SCAN_DISABLE`) live in [`super::params`]; this
//! holds the ones with state: a value captured when the fault starts, or a
//! fault that lasts a while and then clears itself.

use std::time::Duration;

use params::ParamTable;
use vehicle_types::ActuatorDemand;

use super::params::SimParams;

#[derive(Debug, Default)]
pub struct Faults {
    /// The heading the receiver froze at.
    pub heading_hold_deg: Option<f64>,
    /// `SIM_ACT_STUCK` and the demand captured when it was set.
    stuck: Option<(i8, ActuatorDemand)>,
    link_lost_until: Option<Duration>,
    core_stalled_until: Option<Duration>,
}

/// Timed faults are one-shot: the parameter goes back to 0 once taken.
#[derive(Debug, Default, PartialEq)]
pub struct Resets {
    pub link_drop: bool,
    pub cpu_stall: bool,
}

impl Faults {
    /// Takes the fault parameters after a change. `yaw_deg` and `demand`
    /// are the truth and the demand now, captured by a freeze or a stuck
    /// actuator.
    pub fn on_params(
        &mut self,
        sim: &SimParams,
        table: &ParamTable,
        now: Duration,
        yaw_deg: f64,
        demand: ActuatorDemand,
    ) -> Resets {
        self.heading_hold_deg = match (sim.heading_freeze.get(table), self.heading_hold_deg) {
            (true, held) => Some(held.unwrap_or(yaw_deg)),
            (false, _) => None,
        };
        let stuck = sim.actuator_stuck.get(table);
        self.stuck = match (stuck, self.stuck) {
            (0, _) => None,
            (mask, Some((old, captured))) if mask == old => Some((old, captured)),
            (mask, _) => Some((mask, demand)),
        };
        let mut resets = Resets::default();
        let drop_s = f64::from(sim.link_drop_s.get(table));
        if drop_s > 0.0 {
            self.link_lost_until = Some(now.saturating_add(crate::time::duration_from_secs(drop_s)));
            resets.link_drop = true;
        }
        let stall_ms = sim.cpu_stall_ms.get(table);
        if stall_ms > 0 {
            self.core_stalled_until = Some(now + Duration::from_millis(stall_ms as u64));
            resets.cpu_stall = true;
        }
        resets
    }

    pub fn link_lost(&self, now: Duration) -> bool {
        self.link_lost_until.is_some_and(|t| now < t)
    }

    pub fn core_stalled(&self, now: Duration) -> bool {
        self.core_stalled_until.is_some_and(|t| now < t)
    }

    /// What the wheels and steering really do given the core's `demand`.
    /// Disarmed, the drive has no power (the safety relay is open): a stuck
    /// actuator then does nothing either.
    pub fn actuate(&self, demand: ActuatorDemand, armed: bool) -> ActuatorDemand {
        let Some((mask, stuck)) = self.stuck else {
            return demand;
        };
        if !armed {
            return demand;
        }
        match (demand, stuck) {
            (
                ActuatorDemand::Ackermann { steering, throttle },
                ActuatorDemand::Ackermann {
                    steering: stuck_steering,
                    throttle: stuck_throttle,
                },
            ) => ActuatorDemand::Ackermann {
                steering: if mask & 1 != 0 { stuck_steering } else { steering },
                throttle: if mask & 2 != 0 { stuck_throttle } else { throttle },
            },
            // A skid-steer's two motors: bit 1 the left, bit 2 the right.
            (
                ActuatorDemand::Differential { left, right },
                ActuatorDemand::Differential {
                    left: stuck_left,
                    right: stuck_right,
                },
            ) => ActuatorDemand::Differential {
                left: if mask & 1 != 0 { stuck_left } else { left },
                right: if mask & 2 != 0 { stuck_right } else { right },
            },
            // Stuck at rest before the drive train first moved.
            (ActuatorDemand::Differential { left, right }, ActuatorDemand::Ackermann { .. }) => {
                ActuatorDemand::Differential {
                    left: if mask & 1 != 0 { 0.0 } else { left },
                    right: if mask & 2 != 0 { 0.0 } else { right },
                }
            }
            (ActuatorDemand::Ackermann { steering, throttle }, ActuatorDemand::Differential { .. }) => {
                ActuatorDemand::Ackermann {
                    steering: if mask & 1 != 0 { 0.0 } else { steering },
                    throttle: if mask & 2 != 0 { 0.0 } else { throttle },
                }
            }
        }
    }
}
