//! Structures shared by several messages: actions, positions, trajectories,
//! velocities, loads.

use serde::{Deserialize, Serialize};

/// How an action blocks driving and other actions (§6.11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum BlockingType {
    /// May run in parallel with driving and other actions.
    None,
    /// May run in parallel with other actions; the vehicle stands still.
    Soft,
    /// Runs alone; the vehicle stands still.
    Hard,
}

/// One action parameter. `value` is any JSON value except `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct ActionParameter {
    pub key: String,
    pub value: serde_json::Value,
}

/// An action on a node, an edge, or sent as an instant action (§6.8).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Action {
    pub action_type: String,
    pub action_id: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_description: Option<String>,
    pub blocking_type: BlockingType,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_parameters: Option<Vec<ActionParameter>>,
}

/// A node's position in the map frame (m, rad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct NodePosition {
    pub x: f64,
    pub y: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub allowed_deviation_x_y: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub allowed_deviation_theta: Option<f64>,
    pub map_id: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_description: Option<String>,
}

/// One NURBS control point in the map frame (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlPoint {
    pub x: f64,
    pub y: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weight: Option<f64>,
}

/// An edge's path as a NURBS curve (§6.7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Trajectory {
    /// Written as a float64 in the standard's table and an integer in its
    /// schema: a whole number either way (2 or 2.0), never 2.5.
    #[serde(deserialize_with = "whole_number")]
    pub degree: u32,
    pub knot_vector: Vec<f64>,
    pub control_points: Vec<ControlPoint>,
}

/// A JSON number that is a whole number from 0 to `u32::MAX`, whether
/// written as an integer or a float.
fn whole_number<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<u32, D::Error> {
    let value = f64::deserialize(deserializer)?;
    if value.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&value) {
        Ok(value as u32)
    } else {
        Err(serde::de::Error::custom(format!(
            "{value} is not a whole number from 0 to {}",
            u32::MAX
        )))
    }
}

/// The vehicle's position in the map frame (m, rad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AgvPosition {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    pub map_id: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_description: Option<String>,
    pub position_initialized: bool,
    /// 0 (lost) … 1 (certain).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub localization_score: Option<f64>,
    /// Position deviation range in m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deviation_range: Option<f64>,
}

/// The vehicle's velocity in its own frame (m/s, rad/s).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Velocity {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vx: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vy: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<f64>,
}

/// Where a load's bounding box sits relative to the vehicle (m, rad).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundingBoxReference {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub theta: Option<f64>,
}

/// A load's dimensions (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadDimensions {
    pub length: f64,
    pub width: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
}
