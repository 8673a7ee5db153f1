//! The `factsheet` topic (§6.15): what this vehicle is and can do.

use serde::{Deserialize, Serialize};

use crate::common::{BlockingType, BoundingBoxReference, LoadDimensions};

/// The factsheet. Unlike other messages its header fields other than
/// version/manufacturer/serialNumber are optional in the schema; Furrow always
/// sends them, so the common [`crate::Header`] is used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Factsheet {
    #[serde(flatten)]
    pub header: crate::header::Header,
    pub type_specification: TypeSpecification,
    pub physical_parameters: PhysicalParameters,
    pub protocol_limits: ProtocolLimits,
    pub protocol_features: ProtocolFeatures,
    pub agv_geometry: AgvGeometry,
    pub load_specification: LoadSpecification,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle_config: Option<VehicleConfig>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum AgvKinematic {
    Diff,
    Omni,
    ThreeWheel,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum AgvClass {
    Forklift,
    Conveyor,
    Tugger,
    Carrier,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum LocalizationType {
    Natural,
    Reflector,
    Rfid,
    Dmc,
    Spot,
    Grid,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum NavigationType {
    PhysicalLineGuided,
    VirtualLineGuided,
    Autonomous,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct TypeSpecification {
    pub series_name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub series_description: Option<String>,
    pub agv_kinematic: AgvKinematic,
    pub agv_class: AgvClass,
    /// kg.
    pub max_load_mass: f64,
    pub localization_types: Vec<LocalizationType>,
    pub navigation_types: Vec<NavigationType>,
}

/// Speeds in m/s, accelerations in m/s², lengths in m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PhysicalParameters {
    pub speed_min: f64,
    pub speed_max: f64,
    pub acceleration_max: f64,
    pub deceleration_max: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_min: Option<f64>,
    pub height_max: f64,
    pub width: f64,
    pub length: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ProtocolLimits {
    pub max_string_lens: MaxStringLens,
    pub max_array_lens: MaxArrayLens,
    pub timing: Timing,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct MaxStringLens {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub msg_len: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic_serial_len: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic_elem_len: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id_len: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id_numerical_only: Option<bool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub enum_len: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_id_len: Option<u32>,
}

/// Array limits; the schema's keys are dotted (`order.nodes`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MaxArrayLens {
    #[serde(rename = "order.nodes", default, skip_serializing_if = "Option::is_none")]
    pub order_nodes: Option<u32>,
    #[serde(rename = "order.edges", default, skip_serializing_if = "Option::is_none")]
    pub order_edges: Option<u32>,
    #[serde(rename = "node.actions", default, skip_serializing_if = "Option::is_none")]
    pub node_actions: Option<u32>,
    #[serde(rename = "edge.actions", default, skip_serializing_if = "Option::is_none")]
    pub edge_actions: Option<u32>,
    #[serde(
        rename = "actions.actionsParameters",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub actions_action_parameters: Option<u32>,
    #[serde(rename = "instantActions", default, skip_serializing_if = "Option::is_none")]
    pub instant_actions: Option<u32>,
    #[serde(rename = "trajectory.knotVector", default, skip_serializing_if = "Option::is_none")]
    pub trajectory_knot_vector: Option<u32>,
    #[serde(
        rename = "trajectory.controlPoints",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub trajectory_control_points: Option<u32>,
    #[serde(rename = "state.nodeStates", default, skip_serializing_if = "Option::is_none")]
    pub state_node_states: Option<u32>,
    #[serde(rename = "state.edgeStates", default, skip_serializing_if = "Option::is_none")]
    pub state_edge_states: Option<u32>,
    #[serde(rename = "state.loads", default, skip_serializing_if = "Option::is_none")]
    pub state_loads: Option<u32>,
    #[serde(rename = "state.actionStates", default, skip_serializing_if = "Option::is_none")]
    pub state_action_states: Option<u32>,
    #[serde(rename = "state.errors", default, skip_serializing_if = "Option::is_none")]
    pub state_errors: Option<u32>,
    #[serde(rename = "state.information", default, skip_serializing_if = "Option::is_none")]
    pub state_information: Option<u32>,
    #[serde(rename = "error.errorReferences", default, skip_serializing_if = "Option::is_none")]
    pub error_error_references: Option<u32>,
    #[serde(
        rename = "information.infoReferences",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub information_info_references: Option<u32>,
}

/// Intervals in s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Timing {
    pub min_order_interval: f64,
    pub min_state_interval: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub default_state_interval: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visualization_interval: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ProtocolFeatures {
    pub optional_parameters: Vec<OptionalParameter>,
    pub agv_actions: Vec<AgvAction>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Support {
    Supported,
    Required,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct OptionalParameter {
    /// Dotted path, e.g. `order.nodes.nodePosition.allowedDeviationTheta`.
    pub parameter: String,
    pub support: Support,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum ActionScope {
    Instant,
    Node,
    Edge,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum ValueDataType {
    Bool,
    Number,
    Integer,
    Float,
    String,
    Object,
    Array,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AgvActionParameter {
    pub key: String,
    pub value_data_type: ValueDataType,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub is_optional: Option<bool>,
}

/// One action this vehicle supports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AgvAction {
    pub action_type: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_description: Option<String>,
    pub action_scopes: Vec<ActionScope>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_parameters: Option<Vec<AgvActionParameter>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result_description: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blocking_types: Option<Vec<BlockingType>>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AgvGeometry {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_definitions: Option<Vec<WheelDefinition>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub envelopes2d: Option<Vec<Envelope2d>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub envelopes3d: Option<Vec<Envelope3d>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum WheelType {
    Drive,
    Caster,
    Fixed,
    Mecanum,
}

/// A wheel's position in the vehicle frame (m, rad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WheelPosition {
    pub x: f64,
    pub y: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct WheelDefinition {
    #[serde(rename = "type")]
    pub wheel_type: WheelType,
    pub is_active_driven: bool,
    pub is_active_steered: bool,
    pub position: WheelPosition,
    /// m.
    pub diameter: f64,
    /// m.
    pub width: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center_displacement: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constraints: Option<String>,
}

/// A point of an outline in the vehicle frame (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolygonPoint {
    pub x: f64,
    pub y: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Envelope2d {
    pub set: String,
    pub polygon_points: Vec<PolygonPoint>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// A 3-D envelope. The official schema types `description` as an integer
/// (a slip in the standard); it is kept as any JSON value to stay valid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Envelope3d {
    pub set: String,
    pub format: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<serde_json::Map<String, serde_json::Value>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub url: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<serde_json::Value>,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LoadSpecification {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_positions: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_sets: Option<Vec<LoadSet>>,
}

/// A load the vehicle can carry; lengths in m, angles in rad, times in s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct LoadSet {
    pub set_name: String,
    pub load_type: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_positions: Option<Vec<String>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounding_box_reference: Option<BoundingBoxReference>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_dimensions: Option<LoadDimensions>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_weight: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agv_speed_limit: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pick_time: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drop_time: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VersionEntry {
    pub key: String,
    pub value: String,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct VehicleConfig {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub versions: Option<Vec<VersionEntry>>,
}
