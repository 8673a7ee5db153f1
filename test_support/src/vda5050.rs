//! VDA 5050 messages as a master control would send them to vehicle `R1`
//! of manufacturer `Furrow` on map `yard`.

use serde_json::{Value, json};

/// Every node's `allowedDeviationXY`, metres.
pub const ALLOWED_DEVIATION_XY_M: f64 = 0.25;

/// A node: id, map x (east) / y (north), released, and an optional
/// (actionId, actionType) HARD action.
pub struct N(
    pub &'static str,
    pub f64,
    pub f64,
    pub bool,
    pub Option<(&'static str, &'static str)>,
);

/// An order whose edge i joins nodes i and i+1 (at 1.5 m/s at most);
/// `reverse` lists edges driven backwards. Sequence ids count up from
/// `first_seq`, nodes even and edges odd.
pub fn order(order_id: &str, update_id: u32, first_seq: u32, nodes: &[N], reverse: &[usize]) -> Value {
    let node_json: Vec<Value> = nodes
        .iter()
        .enumerate()
        .map(|(i, N(id, x, y, released, action))| {
            let actions: Vec<Value> = action
                .iter()
                .map(|(aid, kind)| json!({"actionId": aid, "actionType": kind, "blockingType": "HARD"}))
                .collect();
            json!({
                "nodeId": id, "sequenceId": first_seq + 2 * i as u32, "released": released,
                "nodePosition": {"x": x, "y": y, "mapId": "yard", "allowedDeviationXY": ALLOWED_DEVIATION_XY_M},
                "actions": actions,
            })
        })
        .collect();
    let edge_json: Vec<Value> = nodes
        .windows(2)
        .enumerate()
        .map(|(i, pair)| {
            let mut edge = json!({
                "edgeId": format!("e{}", first_seq + 2 * i as u32 + 1),
                "sequenceId": first_seq + 2 * i as u32 + 1,
                "released": pair[0].3 && pair[1].3,
                "startNodeId": pair[0].0, "endNodeId": pair[1].0,
                "maxSpeed": 1.5,
                "actions": [],
            });
            if reverse.contains(&i) {
                edge["orientation"] = json!(std::f64::consts::PI);
                edge["orientationType"] = json!("TANGENTIAL");
            }
            edge
        })
        .collect();
    json!({
        "headerId": 1, "timestamp": "2026-11-27T04:00:00.00Z", "version": "2.1.0",
        "manufacturer": "Furrow", "serialNumber": "R1",
        "orderId": order_id, "orderUpdateId": update_id, "nodes": node_json, "edges": edge_json,
    })
}

/// Instant actions carrying one NONE-blocking action.
pub fn instant(action_id: &str, kind: &str) -> Value {
    json!({
        "headerId": 2, "timestamp": "2026-11-27T04:00:00.00Z", "version": "2.1.0",
        "manufacturer": "Furrow", "serialNumber": "R1",
        "actions": [{"actionId": action_id, "actionType": kind, "blockingType": "NONE"}],
    })
}
