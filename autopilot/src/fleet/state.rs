//! The `state` and `visualization` messages (§6.10, §6.13) built from the
//! agent and what the core reports of the vehicle.

use vda5050::common::{AgvPosition, NodePosition, Velocity};
use vda5050::state::{
    BatteryState, EStop, EdgeState, Error, Information, MapInfo, MapStatus, NodeState, OperatingMode, SafetyState,
};
use vda5050::{Header, State, Visualization};

use super::agent::Agent;
use super::map::MapPose;

/// The vehicle's side of the state: pose, motion, battery, health.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleReport {
    pub pose: Option<MapPose>,
    /// A fix good enough to drive on.
    pub position_initialized: bool,
    /// 0 … 1, from the fix quality.
    pub localization_score: f64,
    /// m, from the estimator's σ.
    pub deviation_range_m: f64,
    /// Forward speed (m/s, negative in reverse) and yaw rate (rad/s, CCW).
    pub speed_mps: f64,
    pub yaw_rate_rad_s: f64,
    pub driving: bool,
    pub battery_percent: f64,
    pub battery_voltage_v: Option<f64>,
    pub operating_mode: OperatingMode,
    /// Failsafes, a GNSS loss, an obstacle stop…
    pub errors: Vec<Error>,
    /// The mode, the GNSS fix, why the vehicle stands…
    pub information: Vec<Information>,
    pub field_violation: bool,
    pub e_stop: EStop,
}

/// A header the edge replaces with its own id and time.
fn blank_header() -> Header {
    Header::new(0, 0, "", "")
}

fn agv_position(report: &VehicleReport, map_id: &str) -> Option<AgvPosition> {
    report.pose.map(|pose| AgvPosition {
        x: pose.x_m,
        y: pose.y_m,
        theta: pose.theta_rad,
        map_id: map_id.to_owned(),
        map_description: None,
        position_initialized: report.position_initialized,
        localization_score: Some(report.localization_score.clamp(0.0, 1.0)),
        deviation_range: Some(report.deviation_range_m.max(0.0)),
    })
}

fn velocity(report: &VehicleReport) -> Velocity {
    Velocity {
        vx: Some(report.speed_mps),
        vy: Some(0.0),
        omega: Some(report.yaw_rate_rad_s),
    }
}

/// The state message of this moment.
pub fn build_state(agent: &Agent, report: &VehicleReport) -> State {
    let order = &agent.order;
    let node_states = order
        .nodes
        .iter()
        .map(|n| NodeState {
            node_id: n.node_id.clone(),
            sequence_id: n.sequence_id,
            node_description: n.node_description.clone(),
            // The state schema's nodePosition has no allowed deviations.
            node_position: n.node_position.as_ref().map(|p| NodePosition {
                allowed_deviation_x_y: None,
                allowed_deviation_theta: None,
                ..p.clone()
            }),
            released: n.released,
        })
        .collect();
    let edge_states = order
        .edges
        .iter()
        .map(|e| EdgeState {
            edge_id: e.edge_id.clone(),
            sequence_id: e.sequence_id,
            edge_description: e.edge_description.clone(),
            released: e.released,
            // The curve the vehicle follows is the one it was given.
            trajectory: e.trajectory.clone(),
        })
        .collect();
    let mut errors = order.errors.clone();
    errors.extend(agent.errors.iter().cloned());
    errors.extend(report.errors.iter().cloned());
    let taken_over = report.operating_mode != OperatingMode::Automatic && order.has_nodes();
    State {
        header: blank_header(),
        maps: Some(vec![MapInfo {
            map_id: agent.config.map_id.clone(),
            map_version: agent.config.map_version.clone(),
            map_description: None,
            map_status: MapStatus::Enabled,
        }]),
        order_id: order.order_id.clone(),
        order_update_id: order.order_update_id,
        zone_set_id: order.zone_set_id.clone(),
        last_node_id: order.last_node_id.clone(),
        last_node_sequence_id: order.last_node_sequence_id,
        driving: report.driving,
        paused: Some(agent.paused || taken_over),
        new_base_request: Some(agent.new_base_request()),
        distance_since_last_node: None,
        operating_mode: report.operating_mode,
        node_states,
        edge_states,
        agv_position: agv_position(report, &agent.config.map_id),
        velocity: Some(velocity(report)),
        // Known from the pick and drop actions: empty is unloaded.
        loads: Some(agent.loads.clone()),
        action_states: agent.actions.states(),
        battery_state: BatteryState {
            battery_charge: report.battery_percent.clamp(0.0, 100.0),
            battery_voltage: report.battery_voltage_v,
            battery_health: None,
            charging: false,
            reach: None,
        },
        errors,
        information: Some(report.information.clone()),
        safety_state: SafetyState {
            e_stop: report.e_stop,
            field_violation: report.field_violation,
        },
    }
}

/// The visualization message of this moment.
pub fn build_visualization(agent: &Agent, report: &VehicleReport) -> Visualization {
    Visualization {
        header: blank_header(),
        agv_position: agv_position(report, &agent.config.map_id),
        velocity: Some(velocity(report)),
    }
}
