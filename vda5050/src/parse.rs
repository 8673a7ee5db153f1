//! Parsing of the messages a vehicle receives (`order`, `instantActions`)
//! into typed values. Malformed input is an `Err` with a message a master
//! control's operator can act on; it never panics.
//!
//! Checked here: JSON syntax, required fields, types, enum values, and the
//! schema's numeric bounds and formats. The order's protocol rules
//! (sequence ids, stitching, map ids) belong to the order logic, not here.

use crate::common::{Action, Trajectory};
use crate::header::Header;
use crate::instant_actions::InstantActions;
use crate::order::Order;

/// The schema's bound on `theta` and `orientation` (π to 11 decimals, as the
/// schema writes it: the exact literal, not `PI`, decides what is accepted).
#[allow(clippy::approx_constant)]
const THETA_LIMIT_RAD: f64 = 3.14159265359;
/// The schema's bound on `allowedDeviationTheta` (π to 9 decimals).
#[allow(clippy::approx_constant)]
const DEVIATION_THETA_LIMIT_RAD: f64 = 3.141592654;

/// Why an incoming message was refused.
#[derive(Debug)]
pub enum ParseError {
    /// Not JSON, or a field missing, of the wrong type, or an unknown enum value.
    Json(serde_json::Error),
    /// A field outside the range the schema allows.
    OutOfRange {
        field: String,
        value: f64,
        allowed: &'static str,
    },
    /// An action parameter whose value is `null` (the schema forbids it).
    NullParameter { field: String },
    /// A header `timestamp` that is not ISO 8601 date-time.
    Timestamp { value: String },
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParseError::Json(err) => write!(f, "malformed message: {err}"),
            ParseError::OutOfRange { field, value, allowed } => {
                write!(f, "{field} = {value} is out of range ({allowed})")
            }
            ParseError::NullParameter { field } => {
                write!(f, "{field} is null (a parameter needs a value)")
            }
            ParseError::Timestamp { value } => {
                write!(f, "timestamp {value:?} is not an ISO 8601 date-time")
            }
        }
    }
}

impl std::error::Error for ParseError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ParseError::Json(err) => Some(err),
            _ => None,
        }
    }
}

impl From<serde_json::Error> for ParseError {
    fn from(err: serde_json::Error) -> Self {
        ParseError::Json(err)
    }
}

/// Parses an `order` payload.
pub fn parse_order(payload: &[u8]) -> Result<Order, ParseError> {
    let order: Order = serde_json::from_slice(payload)?;
    check_header(&order.header)?;
    for (i, node) in order.nodes.iter().enumerate() {
        if let Some(position) = &node.node_position {
            let at = format!("nodes[{i}].nodePosition");
            if let Some(theta) = position.theta {
                check_symmetric(&format!("{at}.theta"), theta, THETA_LIMIT_RAD)?;
            }
            if let Some(deviation) = position.allowed_deviation_x_y {
                check_at_least(&format!("{at}.allowedDeviationXY"), deviation, 0.0)?;
            }
            if let Some(deviation) = position.allowed_deviation_theta {
                let field = format!("{at}.allowedDeviationTheta");
                check_symmetric(&field, deviation, DEVIATION_THETA_LIMIT_RAD)?;
            }
        }
        check_actions(&format!("nodes[{i}].actions"), &node.actions)?;
    }
    for (i, edge) in order.edges.iter().enumerate() {
        let at = format!("edges[{i}]");
        if let Some(orientation) = edge.orientation {
            check_symmetric(&format!("{at}.orientation"), orientation, THETA_LIMIT_RAD)?;
        }
        if let Some(trajectory) = &edge.trajectory {
            check_trajectory(&format!("{at}.trajectory"), trajectory)?;
        }
        if let Some(corridor) = &edge.corridor {
            check_at_least(&format!("{at}.corridor.leftWidth"), corridor.left_width, 0.0)?;
            check_at_least(&format!("{at}.corridor.rightWidth"), corridor.right_width, 0.0)?;
        }
        check_actions(&format!("{at}.actions"), &edge.actions)?;
    }
    Ok(order)
}

/// Parses an `instantActions` payload.
pub fn parse_instant_actions(payload: &[u8]) -> Result<InstantActions, ParseError> {
    let instant: InstantActions = serde_json::from_slice(payload)?;
    check_header(&instant.header)?;
    check_actions("actions", &instant.actions)?;
    Ok(instant)
}

fn check_header(header: &Header) -> Result<(), ParseError> {
    match chrono::DateTime::parse_from_rfc3339(&header.timestamp) {
        Ok(_) => Ok(()),
        Err(_) => Err(ParseError::Timestamp {
            value: header.timestamp.clone(),
        }),
    }
}

fn check_actions(at: &str, actions: &[Action]) -> Result<(), ParseError> {
    for (i, action) in actions.iter().enumerate() {
        let parameters = action.action_parameters.as_deref().unwrap_or_default();
        for (j, parameter) in parameters.iter().enumerate() {
            if parameter.value.is_null() {
                return Err(ParseError::NullParameter {
                    field: format!("{at}[{i}].actionParameters[{j}].value"),
                });
            }
        }
    }
    Ok(())
}

fn check_trajectory(at: &str, trajectory: &Trajectory) -> Result<(), ParseError> {
    check_at_least(&format!("{at}.degree"), f64::from(trajectory.degree), 1.0)?;
    for (i, knot) in trajectory.knot_vector.iter().enumerate() {
        let field = format!("{at}.knotVector[{i}]");
        if !(0.0..=1.0).contains(knot) {
            return Err(ParseError::OutOfRange {
                field,
                value: *knot,
                allowed: "0 to 1",
            });
        }
    }
    for (i, point) in trajectory.control_points.iter().enumerate() {
        if let Some(weight) = point.weight {
            check_at_least(&format!("{at}.controlPoints[{i}].weight"), weight, 0.0)?;
        }
    }
    Ok(())
}

fn check_symmetric(field: &str, value: f64, limit_rad: f64) -> Result<(), ParseError> {
    if (-limit_rad..=limit_rad).contains(&value) {
        return Ok(());
    }
    Err(ParseError::OutOfRange {
        field: field.to_owned(),
        value,
        allowed: "-π to π",
    })
}

fn check_at_least(field: &str, value: f64, minimum: f64) -> Result<(), ParseError> {
    if value >= minimum {
        return Ok(());
    }
    Err(ParseError::OutOfRange {
        field: field.to_owned(),
        value,
        allowed: if minimum == 0.0 { ">= 0" } else { ">= 1" },
    })
}
