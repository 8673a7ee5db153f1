//! Every message type, serialised from a realistic example, validates against
//! the official VDA 5050 2.1.0 JSON schema vendored in `tests/data/vda5050`.

use serde_json::{Value, json};
use vda5050::common::{
    Action, ActionParameter, AgvPosition, BlockingType, ControlPoint, LoadDimensions, NodePosition, Trajectory,
    Velocity,
};
use vda5050::factsheet::*;
use vda5050::order::{Corridor, CorridorRefPoint, Edge, Node, OrientationType};
use vda5050::state::*;
use vda5050::{Connection, ConnectionState, Header, InstantActions, Order, Visualization};

fn schema(name: &str) -> Value {
    let path = format!("{}/../tests/data/vda5050/{name}.schema", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap()
}

/// Validation errors of `message` against schema `name`, formats asserted.
fn violations(name: &str, schema_value: &Value, message: &Value) -> Vec<String> {
    let validator = jsonschema::options()
        .should_validate_formats(true)
        .build(schema_value)
        .unwrap_or_else(|e| panic!("{name}.schema does not compile: {e}"));
    validator
        .iter_errors(message)
        .map(|e| format!("{name}: {e} at {}", e.instance_path()))
        .collect()
}

fn assert_valid(name: &str, message: &impl serde::Serialize) {
    let value = serde_json::to_value(message).unwrap();
    let errors = violations(name, &schema(name), &value);
    assert!(errors.is_empty(), "{errors:#?}\n{value:#}");
}

fn header(id: u32) -> Header {
    Header::new(id, 1_764_208_800_250, "Furrow", "R1")
}

fn action(id: &str, kind: &str, blocking: BlockingType) -> Action {
    Action {
        action_type: kind.into(),
        action_id: id.into(),
        action_description: Some(format!("{kind} at the dock")),
        blocking_type: blocking,
        action_parameters: Some(vec![
            ActionParameter {
                key: "stationType".into(),
                value: json!("floor"),
            },
            ActionParameter {
                key: "height".into(),
                value: json!(0.25),
            },
            ActionParameter {
                key: "lhd".into(),
                value: json!(["fork", 1]),
            },
        ]),
    }
}

fn node(id: &str, seq: u32, x: f64, y: f64, released: bool, actions: Vec<Action>) -> Node {
    Node {
        node_id: id.into(),
        sequence_id: seq,
        node_description: None,
        released,
        node_position: Some(NodePosition {
            x,
            y,
            theta: Some(std::f64::consts::FRAC_PI_2),
            allowed_deviation_x_y: Some(0.1),
            allowed_deviation_theta: Some(0.05),
            map_id: "yard".into(),
            map_description: Some("north yard".into()),
        }),
        actions,
    }
}

fn edge(id: &str, seq: u32, from: &str, to: &str, released: bool) -> Edge {
    Edge {
        edge_id: id.into(),
        sequence_id: seq,
        edge_description: None,
        released,
        start_node_id: from.into(),
        end_node_id: to.into(),
        max_speed: Some(1.5),
        max_height: None,
        min_height: None,
        orientation: Some(std::f64::consts::PI),
        orientation_type: Some(OrientationType::Tangential),
        direction: None,
        rotation_allowed: Some(false),
        max_rotation_speed: Some(0.5),
        length: Some(10.0),
        trajectory: Some(Trajectory {
            degree: 2,
            knot_vector: vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            control_points: vec![
                ControlPoint {
                    x: 0.0,
                    y: 0.0,
                    weight: Some(1.0),
                },
                ControlPoint {
                    x: 5.0,
                    y: 0.0,
                    weight: Some(0.7),
                },
                ControlPoint {
                    x: 5.0,
                    y: 5.0,
                    weight: None,
                },
            ],
        }),
        corridor: Some(Corridor {
            left_width: 0.5,
            right_width: 0.4,
            corridor_ref_point: Some(CorridorRefPoint::KinematicCenter),
        }),
        actions: vec![],
    }
}

pub fn example_order() -> Order {
    Order {
        header: header(7),
        order_id: "order-42".into(),
        order_update_id: 0,
        zone_set_id: Some("zones-1".into()),
        nodes: vec![
            node("n1", 0, 0.0, 0.0, true, vec![]),
            node("n2", 2, 5.0, 5.0, true, vec![action("a1", "pick", BlockingType::Hard)]),
            node("n3", 4, 10.0, 5.0, false, vec![]),
        ],
        edges: vec![edge("e1", 1, "n1", "n2", true), edge("e2", 3, "n2", "n3", false)],
    }
}

#[test]
fn order_validates() {
    assert_valid("order", &example_order());
}

#[test]
fn instant_actions_validate() {
    let message = InstantActions {
        header: header(8),
        actions: vec![
            action("i1", "startPause", BlockingType::Hard),
            Action {
                action_type: "cancelOrder".into(),
                action_id: "i2".into(),
                action_description: None,
                blocking_type: BlockingType::None,
                action_parameters: None,
            },
        ],
    };
    assert_valid("instantActions", &message);
}

#[test]
fn connection_validates_in_every_state() {
    for connection_state in [
        ConnectionState::Online,
        ConnectionState::Offline,
        ConnectionState::ConnectionBroken,
    ] {
        let message = Connection {
            header: header(1),
            connection_state,
        };
        assert_valid("connection", &message);
    }
}

fn position() -> AgvPosition {
    AgvPosition {
        x: 3.2,
        y: -1.5,
        theta: 0.3,
        map_id: "yard".into(),
        map_description: None,
        position_initialized: true,
        localization_score: Some(0.9),
        deviation_range: Some(0.02),
    }
}

fn velocity() -> Velocity {
    Velocity {
        vx: Some(1.2),
        vy: Some(0.0),
        omega: Some(-0.1),
    }
}

#[test]
fn visualization_validates() {
    let message = Visualization {
        header: header(3),
        agv_position: Some(position()),
        velocity: Some(velocity()),
    };
    assert_valid("visualization", &message);
}

pub fn example_state() -> State {
    State {
        header: header(9),
        maps: Some(vec![MapInfo {
            map_id: "yard".into(),
            map_version: "1".into(),
            map_description: None,
            map_status: MapStatus::Enabled,
        }]),
        order_id: "order-42".into(),
        order_update_id: 0,
        zone_set_id: None,
        last_node_id: "n1".into(),
        last_node_sequence_id: 0,
        driving: true,
        paused: Some(false),
        new_base_request: Some(false),
        distance_since_last_node: Some(2.5),
        operating_mode: OperatingMode::Automatic,
        node_states: vec![NodeState {
            node_id: "n2".into(),
            sequence_id: 2,
            node_description: None,
            node_position: Some(NodePosition {
                x: 5.0,
                y: 5.0,
                theta: Some(1.0),
                allowed_deviation_x_y: None,
                allowed_deviation_theta: None,
                map_id: "yard".into(),
                map_description: None,
            }),
            released: true,
        }],
        edge_states: vec![EdgeState {
            edge_id: "e1".into(),
            sequence_id: 1,
            edge_description: None,
            released: true,
            trajectory: None,
        }],
        agv_position: Some(position()),
        velocity: Some(velocity()),
        loads: Some(vec![Load {
            load_id: Some("car-7".into()),
            load_type: Some("car".into()),
            load_position: None,
            bounding_box_reference: None,
            load_dimensions: Some(LoadDimensions {
                length: 4.5,
                width: 1.8,
                height: Some(1.5),
            }),
            weight: Some(1400.0),
        }]),
        action_states: vec![
            ActionState {
                action_id: "a1".into(),
                action_type: Some("pick".into()),
                action_description: None,
                action_status: ActionStatus::Waiting,
                result_description: None,
            },
            ActionState {
                action_id: "i9".into(),
                action_type: Some("cancelOrder".into()),
                action_description: None,
                action_status: ActionStatus::Failed,
                result_description: Some("no order to cancel".into()),
            },
        ],
        battery_state: BatteryState {
            battery_charge: 81.5,
            battery_voltage: Some(48.2),
            battery_health: Some(97.0),
            charging: false,
            reach: Some(12000),
        },
        errors: vec![Error {
            error_type: "validationError".into(),
            error_references: Some(vec![ErrorReference {
                reference_key: "orderId".into(),
                reference_value: "order-41".into(),
            }]),
            error_description: Some("nodes[0].nodePosition.theta out of range".into()),
            error_hint: None,
            error_level: ErrorLevel::Warning,
        }],
        information: Some(vec![Information {
            info_type: "gnss".into(),
            info_references: None,
            info_description: Some("RTK fixed".into()),
            info_level: InfoLevel::Info,
        }]),
        safety_state: SafetyState {
            e_stop: EStop::None,
            field_violation: false,
        },
    }
}

#[test]
fn state_validates() {
    assert_valid("state", &example_state());
}

#[test]
fn minimal_state_before_any_order_validates() {
    let state = State {
        maps: None,
        order_id: String::new(),
        last_node_id: String::new(),
        paused: None,
        new_base_request: None,
        distance_since_last_node: None,
        node_states: vec![],
        edge_states: vec![],
        agv_position: None,
        velocity: None,
        loads: None,
        action_states: vec![],
        errors: vec![],
        information: None,
        ..example_state()
    };
    assert_valid("state", &state);
}

fn example_factsheet() -> Factsheet {
    Factsheet {
        header: header(0),
        type_specification: TypeSpecification {
            series_name: "Furrow yard AGV".into(),
            series_description: None,
            agv_kinematic: AgvKinematic::Diff,
            agv_class: AgvClass::Carrier,
            max_load_mass: 2000.0,
            localization_types: vec![LocalizationType::Natural],
            navigation_types: vec![NavigationType::Autonomous],
        },
        physical_parameters: PhysicalParameters {
            speed_min: 0.0,
            speed_max: 2.0,
            acceleration_max: 0.5,
            deceleration_max: 1.0,
            height_min: None,
            height_max: 0.3,
            width: 2.2,
            length: 5.5,
        },
        protocol_limits: ProtocolLimits {
            max_string_lens: MaxStringLens {
                id_len: Some(64),
                ..MaxStringLens::default()
            },
            max_array_lens: MaxArrayLens {
                order_nodes: Some(100),
                order_edges: Some(99),
                ..MaxArrayLens::default()
            },
            timing: Timing {
                min_order_interval: 0.1,
                min_state_interval: 0.1,
                default_state_interval: Some(1.0),
                visualization_interval: Some(0.2),
            },
        },
        protocol_features: ProtocolFeatures {
            optional_parameters: vec![OptionalParameter {
                parameter: "order.edges.trajectory".into(),
                support: Support::Supported,
                description: None,
            }],
            agv_actions: vec![AgvAction {
                action_type: "pick".into(),
                action_description: None,
                action_scopes: vec![ActionScope::Node],
                action_parameters: Some(vec![AgvActionParameter {
                    key: "stationType".into(),
                    value_data_type: ValueDataType::String,
                    description: None,
                    is_optional: Some(true),
                }]),
                result_description: None,
                blocking_types: Some(vec![BlockingType::Hard]),
            }],
        },
        agv_geometry: AgvGeometry {
            wheel_definitions: Some(vec![WheelDefinition {
                wheel_type: WheelType::Drive,
                is_active_driven: true,
                is_active_steered: false,
                position: WheelPosition {
                    x: 0.0,
                    y: 0.9,
                    theta: None,
                },
                diameter: 0.4,
                width: 0.15,
                center_displacement: None,
                constraints: None,
            }]),
            envelopes2d: Some(vec![Envelope2d {
                set: "outline".into(),
                polygon_points: vec![
                    PolygonPoint { x: 2.75, y: 1.1 },
                    PolygonPoint { x: -2.75, y: 1.1 },
                    PolygonPoint { x: -2.75, y: -1.1 },
                ],
                description: None,
            }]),
            envelopes3d: None,
        },
        load_specification: LoadSpecification::default(),
        vehicle_config: Some(VehicleConfig {
            versions: Some(vec![VersionEntry {
                key: "furrow".into(),
                value: "0.1.0".into(),
            }]),
        }),
    }
}

/// The official factsheet schema puts `enum` on the `blockingTypes` array
/// instead of its items, so any non-empty array fails. Validate with that one
/// constraint moved onto the items, as the standard's text means it.
fn factsheet_schema_with_blocking_types_fixed() -> Value {
    let mut schema = schema("factsheet");
    let blocking = schema
        .pointer_mut("/properties/protocolFeatures/properties/agvActions/items/properties/blockingTypes")
        .expect("blockingTypes in factsheet.schema");
    let values = blocking
        .as_object_mut()
        .unwrap()
        .remove("enum")
        .expect("the official schema's misplaced enum");
    blocking["items"] = json!({ "type": "string", "enum": values });
    schema
}

#[test]
fn factsheet_validates() {
    let value = serde_json::to_value(example_factsheet()).unwrap();
    let errors = violations("factsheet", &factsheet_schema_with_blocking_types_fixed(), &value);
    assert!(errors.is_empty(), "{errors:#?}");
}

#[test]
fn factsheet_without_blocking_types_validates_against_the_unmodified_schema() {
    let mut factsheet = example_factsheet();
    factsheet.protocol_features.agv_actions[0].blocking_types = None;
    assert_valid("factsheet", &factsheet);
}

#[test]
fn schema_check_is_real_a_broken_state_is_caught() {
    let mut value = serde_json::to_value(example_state()).unwrap();
    value["operatingMode"] = json!("AUTOPILOT");
    value.as_object_mut().unwrap().remove("safetyState");
    let errors = violations("state", &schema("state"), &value);
    assert_eq!(errors.len(), 2, "{errors:#?}");
    let mut value = serde_json::to_value(example_state()).unwrap();
    value["timestamp"] = json!("yesterday");
    assert_eq!(violations("state", &schema("state"), &value).len(), 1);
}

#[test]
fn serialised_order_parses_back_identically() {
    let order = example_order();
    let bytes = serde_json::to_vec(&order).unwrap();
    assert_eq!(vda5050::parse_order(&bytes).unwrap(), order);
}
