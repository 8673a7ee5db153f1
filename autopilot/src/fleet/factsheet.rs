//! The `factsheet` (§6.15): what this vehicle is and can do, from its
//! parameters and the agent's configuration, so it says only what is true.

use vda5050::factsheet::*;
use vda5050::{Factsheet, Header};

use super::agent::{AgentConfig, INSTANT_ACTIONS};
use super::trajectory::{MAX_CONTROL_POINTS, MAX_DEGREE};

/// The vehicle as its parameters describe it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehicleDescription {
    pub differential: bool,
    pub speed_max_mps: f64,
    pub accel_max_mps2: f64,
    pub decel_max_mps2: f64,
    /// Reference point (rear axle centre) to the front and rear bumpers (m).
    pub front_m: f64,
    pub rear_m: f64,
    pub width_m: f64,
}

/// The longest id or string an order may carry (m a free-navigation
/// vehicle has no reason to limit: reported as the MQTT limit of the edge).
const MAX_MESSAGE_BYTES: u32 = 256 * 1024;

pub fn build_factsheet(vehicle: &VehicleDescription, config: &AgentConfig) -> Factsheet {
    Factsheet {
        header: Header::new(0, 0, "", ""),
        type_specification: TypeSpecification {
            series_name: "Furrow".into(),
            series_description: Some("Furrow rover autopilot (GNSS-RTK, free navigation)".into()),
            // VDA 5050 has no car-like kinematic: a steered axle behind a
            // driven one moves as its THREEWHEEL model does.
            agv_kinematic: if vehicle.differential {
                AgvKinematic::Diff
            } else {
                AgvKinematic::ThreeWheel
            },
            agv_class: AgvClass::Carrier,
            max_load_mass: 0.0,
            localization_types: vec![LocalizationType::Natural],
            navigation_types: vec![NavigationType::Autonomous],
        },
        physical_parameters: PhysicalParameters {
            speed_min: 0.0,
            speed_max: vehicle.speed_max_mps,
            acceleration_max: vehicle.accel_max_mps2,
            deceleration_max: vehicle.decel_max_mps2,
            height_min: None,
            height_max: 0.0,
            width: vehicle.width_m,
            length: vehicle.front_m + vehicle.rear_m,
        },
        protocol_limits: ProtocolLimits {
            max_string_lens: MaxStringLens {
                msg_len: Some(MAX_MESSAGE_BYTES),
                ..MaxStringLens::default()
            },
            max_array_lens: MaxArrayLens {
                trajectory_knot_vector: Some((MAX_CONTROL_POINTS + MAX_DEGREE as usize + 1) as u32),
                trajectory_control_points: Some(MAX_CONTROL_POINTS as u32),
                ..MaxArrayLens::default()
            },
            timing: Timing {
                min_order_interval: 0.0,
                min_state_interval: 0.0,
                default_state_interval: Some(config.state_interval_idle_s),
                visualization_interval: (config.visualization_interval_s > 0.0)
                    .then_some(config.visualization_interval_s),
            },
        },
        protocol_features: ProtocolFeatures {
            optional_parameters: optional_parameters(),
            agv_actions: agv_actions(config),
        },
        agv_geometry: AgvGeometry {
            envelopes2d: Some(vec![Envelope2d {
                set: "default".into(),
                polygon_points: outline(vehicle),
                description: Some("body outline about the rear axle centre".into()),
            }]),
            ..AgvGeometry::default()
        },
        load_specification: LoadSpecification::default(),
        vehicle_config: None,
    }
}

/// The body outline in the vehicle frame (x forward, y left).
fn outline(v: &VehicleDescription) -> Vec<PolygonPoint> {
    let half = v.width_m / 2.0;
    [
        (v.front_m, half),
        (-v.rear_m, half),
        (-v.rear_m, -half),
        (v.front_m, -half),
    ]
    .into_iter()
    .map(|(x, y)| PolygonPoint { x, y })
    .collect()
}

fn optional_parameters() -> Vec<OptionalParameter> {
    let supported = |parameter: &str, description: &str| OptionalParameter {
        parameter: parameter.into(),
        support: Support::Supported,
        description: Some(description.into()),
    };
    vec![
        supported(
            "order.nodes.nodePosition.allowedDeviationXY",
            "the stop tolerance at a node that stops",
        ),
        supported(
            "order.nodes.nodePosition.allowedDeviationTheta",
            "the heading tolerance at a node that stops",
        ),
        supported("order.edges.maxSpeed", "caps the cruise speed on the edge"),
        supported("order.edges.orientation", "TANGENTIAL π drives the edge in reverse"),
        supported(
            "order.edges.trajectory",
            "a NURBS of degree 1 to 10 is followed, as chords within 1 cm of it",
        ),
    ]
}

fn agv_actions(config: &AgentConfig) -> Vec<AgvAction> {
    let action = |action_type: &str, scopes: Vec<ActionScope>, description: String| AgvAction {
        action_type: action_type.into(),
        action_description: Some(description),
        action_scopes: scopes,
        action_parameters: None,
        result_description: None,
        // The official 2.1 schema types blockingTypes as one string where
        // the text means a list; leaving it out is valid either way.
        blocking_types: None,
    };
    let mut actions: Vec<AgvAction> = INSTANT_ACTIONS
        .iter()
        .map(|kind| action(kind, vec![ActionScope::Instant], format!("{kind} (§6.8)")))
        .collect();
    for mapping in &config.mappings {
        let scopes = vec![ActionScope::Instant, ActionScope::Node, ActionScope::Edge];
        let text = format!("sets {:?} for {} s", mapping.output, mapping.duration_s);
        actions.push(action(&mapping.action_type, scopes, text));
    }
    actions
}
