//! The order a vehicle holds (§6.6): acceptance, validation and rejection
//! with the standard's error types (§6.6.4), order updates stitched onto
//! the decision point (§6.6.2), progress node by node, and cancellation.
//!
//! Pure: no clock is needed, the caller says where the vehicle is.

use vda5050::Order;
use vda5050::common::Trajectory;
use vda5050::order::{Edge, Node};
use vda5050::state::{Error, ErrorLevel, ErrorReference};

use super::trajectory::Nurbs;

/// A new order's first node counts as reached within this distance when it
/// gives no `allowedDeviationXY` of its own (m).
pub const DEFAULT_START_DEVIATION_M: f64 = 0.5;

/// What the order logic needs to know of the vehicle to judge an order.
pub struct OrderContext<'a> {
    /// The map this vehicle drives on; every node must be on it.
    pub map_id: &'a str,
    /// Where the vehicle is in the map frame (x, y), if it knows.
    pub position: Option<(f64, f64)>,
    /// Whether actions of the current order are still to finish.
    pub actions_busy: bool,
    /// Whether the vehicle can carry out an action type in an order.
    pub supports_action: &'a dyn Fn(&str) -> bool,
    /// The tightest turn the vehicle follows (m); `None` when it can turn
    /// on the spot (a differential drive).
    pub min_turn_radius_m: Option<f64>,
}

/// The verdict on a received order.
#[derive(Debug, PartialEq)]
pub enum Verdict {
    /// Taken over: a new order, or an update stitched onto the current one.
    Accepted { new_order: bool },
    /// The same orderId and orderUpdateId again: ignored (§6.6.4.3).
    Duplicate,
    /// Not taken over; the order held before is kept (errors in state).
    Rejected,
}

/// The order the vehicle holds: what is left of it, and the last node.
#[derive(Debug, Default, Clone)]
pub struct OrderBook {
    pub order_id: String,
    pub order_update_id: u32,
    pub zone_set_id: Option<String>,
    pub last_node_id: String,
    pub last_node_sequence_id: u32,
    /// The last node reached (its position is where the next edge starts).
    pub last_node: Option<Node>,
    /// Nodes not yet reached, base then horizon.
    pub nodes: Vec<Node>,
    /// Edges not yet left, base then horizon.
    pub edges: Vec<Edge>,
    /// Rejections, reported until an order is accepted.
    pub errors: Vec<Error>,
}

pub fn error(error_type: &str, description: String, references: Vec<(&str, String)>) -> Error {
    Error {
        error_type: error_type.to_owned(),
        error_references: (!references.is_empty()).then(|| {
            references
                .into_iter()
                .map(|(key, value)| ErrorReference {
                    reference_key: key.to_owned(),
                    reference_value: value,
                })
                .collect()
        }),
        error_description: Some(description),
        error_hint: None,
        error_level: ErrorLevel::Warning,
    }
}

fn order_refs(order: &Order) -> Vec<(&'static str, String)> {
    vec![
        ("headerId", order.header.header_id.to_string()),
        ("topic", "order".to_owned()),
        ("orderId", order.order_id.clone()),
        ("orderUpdateId", order.order_update_id.to_string()),
    ]
}

impl OrderBook {
    /// Nodes or edges still to traverse (base or horizon).
    pub fn has_nodes(&self) -> bool {
        !self.nodes.is_empty()
    }

    /// Nodes not released yet.
    pub fn has_horizon(&self) -> bool {
        self.nodes.iter().any(|n| !n.released)
    }

    /// The next edge and node to drive, when both are released.
    pub fn next_leg(&self) -> Option<(&Edge, &Node)> {
        self.leg_at(0)
    }

    /// The `i`-th edge and node still held, when both are released.
    pub fn leg_at(&self, i: usize) -> Option<(&Edge, &Node)> {
        let (edge, node) = (self.edges.get(i)?, self.nodes.get(i)?);
        (edge.released && node.released).then_some((edge, node))
    }

    /// The decision point: the last released node (reached or not).
    fn decision_point(&self) -> Option<&Node> {
        self.nodes.iter().rev().find(|n| n.released).or(self.last_node.as_ref())
    }

    /// The next node was reached: it becomes the last node, the edge that led
    /// to it is left. Returns both.
    pub fn reach_next(&mut self) -> Option<(Node, Option<Edge>)> {
        if self.nodes.is_empty() {
            return None;
        }
        let node = self.nodes.remove(0);
        let edge = (!self.edges.is_empty()).then(|| self.edges.remove(0));
        self.last_node_id = node.node_id.clone();
        self.last_node_sequence_id = node.sequence_id;
        self.last_node = Some(node.clone());
        Some((node, edge))
    }

    /// cancelOrder: the nodes and edges left are dropped; ids are kept.
    pub fn cancel(&mut self) -> Vec<(Node, Option<Edge>)> {
        let edges = std::mem::take(&mut self.edges);
        let nodes = std::mem::take(&mut self.nodes);
        let mut edges = edges.into_iter();
        nodes.into_iter().map(|n| (n, edges.next())).collect()
    }

    /// Judges `order` (§6.6.2 Figure 8, §6.6.4). On rejection the error is
    /// added to [`OrderBook::errors`] and the order held before stays.
    pub fn receive(&mut self, order: Order, ctx: &OrderContext) -> Verdict {
        let checked = check_structure(&order)
            .and_then(|()| check_capabilities(&order, ctx))
            .and_then(|()| self.check_continuation(&order, ctx));
        match checked {
            Ok(Some(verdict)) => verdict,
            Ok(None) => {
                let new_order = order.order_id != self.order_id;
                if new_order {
                    self.take_new(order);
                } else {
                    self.stitch(order);
                }
                self.errors.clear();
                Verdict::Accepted { new_order }
            }
            Err(error) => {
                self.errors.push(error);
                Verdict::Rejected
            }
        }
    }

    /// Figure 8 steps 2–8. `Ok(Some)` settles the verdict without taking
    /// the order; `Ok(None)` takes it.
    fn check_continuation(&self, order: &Order, ctx: &OrderContext) -> Result<Option<Verdict>, Error> {
        let busy = self.has_nodes() || ctx.actions_busy;
        let first = &order.nodes[0];
        if order.order_id != self.order_id {
            if busy {
                let text = format!("order {} is still running: cancel it first", self.order_id);
                return Err(error("orderUpdateError", text, order_refs(order)));
            }
            return self.check_start_reachable(order, ctx).map(|()| None);
        }
        if order.order_update_id < self.order_update_id {
            let text = format!(
                "orderUpdateId {} is older than the current {}",
                order.order_update_id, self.order_update_id
            );
            return Err(error("orderUpdateError", text, order_refs(order)));
        }
        if order.order_update_id == self.order_update_id {
            return Ok(Some(Verdict::Duplicate));
        }
        let stitch = if busy {
            self.decision_point()
        } else {
            self.last_node.as_ref()
        };
        let matches = stitch.is_some_and(|n| n.node_id == first.node_id && n.sequence_id == first.sequence_id);
        if !matches {
            let expected = stitch.map_or("none".to_owned(), |n| {
                format!("{} (sequenceId {})", n.node_id, n.sequence_id)
            });
            let text = format!(
                "the update starts at {} (sequenceId {}), not at the decision point {expected}",
                first.node_id, first.sequence_id
            );
            return Err(error("orderUpdateError", text, order_refs(order)));
        }
        Ok(None)
    }

    /// A new order's first node must be where the vehicle stands (§6.6.1).
    fn check_start_reachable(&self, order: &Order, ctx: &OrderContext) -> Result<(), Error> {
        let first = &order.nodes[0];
        let Some(position) = &first.node_position else {
            return Ok(());
        };
        let allowed = position.allowed_deviation_x_y.unwrap_or(DEFAULT_START_DEVIATION_M);
        let Some((x, y)) = ctx.position else {
            let mut refs = order_refs(order);
            refs.push(("nodeId", first.node_id.clone()));
            return Err(error(
                "noRouteError",
                "the vehicle does not know where it is".into(),
                refs,
            ));
        };
        let distance = (position.x - x).hypot(position.y - y);
        if distance <= allowed {
            return Ok(());
        }
        let mut refs = order_refs(order);
        refs.push(("nodeId", first.node_id.clone()));
        let text = format!(
            "the first node {} is {distance:.2} m away (allowed {allowed:.2} m): not trivially reachable",
            first.node_id
        );
        Err(error("noRouteError", text, refs))
    }

    fn take_new(&mut self, mut order: Order) {
        let first = order.nodes.remove(0);
        self.order_id = order.order_id;
        self.order_update_id = order.order_update_id;
        self.zone_set_id = order.zone_set_id;
        self.last_node_id = first.node_id.clone();
        self.last_node_sequence_id = first.sequence_id;
        self.last_node = Some(first);
        self.nodes = order.nodes;
        self.edges = order.edges;
    }

    /// Appends an update at the decision point: the horizon held so far is
    /// replaced, the stitching node keeps what the first order said.
    fn stitch(&mut self, mut order: Order) {
        let released_nodes = self.nodes.iter().take_while(|n| n.released).count();
        self.nodes.truncate(released_nodes);
        let released_edges = self.edges.iter().take_while(|e| e.released).count();
        self.edges.truncate(released_edges);
        order.nodes.remove(0);
        self.nodes.append(&mut order.nodes);
        self.edges.append(&mut order.edges);
        self.order_update_id = order.order_update_id;
        self.zone_set_id = order.zone_set_id;
    }
}

/// The graph rules of §6.6.1: one edge fewer than nodes, sequence ids
/// running 2n / 2n+1, edges joining their neighbours, the base first.
fn check_structure(order: &Order) -> Result<(), Error> {
    let fail = |text: String| Err(error("validationError", text, order_refs(order)));
    let (nodes, edges) = (&order.nodes, &order.edges);
    if nodes.is_empty() {
        return fail("an order needs at least one node".into());
    }
    if edges.len() + 1 != nodes.len() {
        return fail(format!(
            "{} nodes need {} edges, not {}",
            nodes.len(),
            nodes.len() - 1,
            edges.len()
        ));
    }
    let start = nodes[0].sequence_id;
    if start % 2 != 0 {
        return fail(format!("node {} has the odd sequenceId {start}", nodes[0].node_id));
    }
    if !nodes[0].released {
        return fail("the first node must be released".into());
    }
    for (i, node) in nodes.iter().enumerate() {
        let expected = start + 2 * i as u32;
        if node.sequence_id != expected {
            return fail(format!(
                "node {} has sequenceId {}, expected {expected}",
                node.node_id, node.sequence_id
            ));
        }
        if i > 0 && node.released && !nodes[i - 1].released {
            return fail(format!("node {} is released after an unreleased node", node.node_id));
        }
    }
    for (i, edge) in edges.iter().enumerate() {
        let expected = start + 2 * i as u32 + 1;
        if edge.sequence_id != expected {
            return fail(format!(
                "edge {} has sequenceId {}, expected {expected}",
                edge.edge_id, edge.sequence_id
            ));
        }
        if edge.start_node_id != nodes[i].node_id || edge.end_node_id != nodes[i + 1].node_id {
            return fail(format!(
                "edge {} does not join nodes {} and {}",
                edge.edge_id,
                nodes[i].node_id,
                nodes[i + 1].node_id
            ));
        }
        if edge.released && !(nodes[i].released && nodes[i + 1].released) {
            return fail(format!("edge {} is released but one of its nodes is not", edge.edge_id));
        }
    }
    Ok(())
}

/// What this vehicle can do: nodes on its map with positions, actions it
/// knows, no field it would ignore (§6.6.4.2).
fn check_capabilities(order: &Order, ctx: &OrderContext) -> Result<(), Error> {
    for node in &order.nodes {
        let Some(position) = &node.node_position else {
            let text = format!(
                "node {} has no nodePosition: this vehicle navigates freely and needs one",
                node.node_id
            );
            let mut refs = order_refs(order);
            refs.push(("nodeId", node.node_id.clone()));
            return Err(error("orderError", text, refs));
        };
        if position.map_id != ctx.map_id {
            let text = format!(
                "node {} is on map {:?}; this vehicle drives on {:?}",
                node.node_id, position.map_id, ctx.map_id
            );
            let mut refs = order_refs(order);
            refs.push(("nodeId", node.node_id.clone()));
            return Err(error("noRouteError", text, refs));
        }
    }
    let node_actions = order.nodes.iter().flat_map(|n| n.actions.iter());
    let edge_actions = order.edges.iter().flat_map(|e| e.actions.iter());
    for action in node_actions.chain(edge_actions) {
        if !(ctx.supports_action)(&action.action_type) {
            let text = format!("action type {:?} is not supported in an order", action.action_type);
            let mut refs = order_refs(order);
            refs.push(("actionId", action.action_id.clone()));
            refs.push(("actionType", action.action_type.clone()));
            return Err(error("orderError", text, refs));
        }
    }
    // A corridor and rotationAllowed only permit: staying on the edge's
    // line (or its trajectory) obeys them.
    for (i, edge) in order.edges.iter().enumerate() {
        if let Some(trajectory) = &edge.trajectory {
            check_trajectory(order, i, trajectory, ctx.min_turn_radius_m)?;
        }
    }
    Ok(())
}

/// A trajectory's ends may be this far from its nodes when the end node
/// gives no `allowedDeviationXY` of its own (m).
pub const TRAJECTORY_END_TOLERANCE_M: f64 = 0.1;

/// An edge's NURBS (§6.6.6): well-formed (see [`Nurbs::new`]), from the
/// edge's start node to its end node (else a `validationError`), and no
/// tighter than the vehicle turns (else an `orderError`: a field the
/// vehicle cannot use, §6.6.4.2).
fn check_trajectory(
    order: &Order,
    index: usize,
    trajectory: &Trajectory,
    min_turn_radius_m: Option<f64>,
) -> Result<(), Error> {
    let edge = &order.edges[index];
    let fail = |text: String| {
        let mut refs = order_refs(order);
        refs.push(("edgeId", edge.edge_id.clone()));
        Err(error(
            "validationError",
            format!("edge {} trajectory: {text}", edge.edge_id),
            refs,
        ))
    };
    let curve = match Nurbs::new(trajectory) {
        Ok(curve) => curve,
        Err(text) => return fail(text),
    };
    let (lo, hi) = curve.domain();
    let ends = [
        (&order.nodes[index], curve.point(lo)),
        (&order.nodes[index + 1], curve.point(hi)),
    ];
    for (node, (x, y)) in ends {
        let Some(position) = &node.node_position else {
            continue;
        };
        let allowed = position
            .allowed_deviation_x_y
            .unwrap_or(0.0)
            .max(TRAJECTORY_END_TOLERANCE_M);
        let off = (position.x - x).hypot(position.y - y);
        if off > allowed {
            return fail(format!(
                "it passes {off:.2} m from node {} (allowed {allowed:.2} m)",
                node.node_id
            ));
        }
    }
    let radius_m = curve.min_radius_m();
    if let Some(min_m) = min_turn_radius_m.filter(|min_m| radius_m < *min_m) {
        let mut refs = order_refs(order);
        refs.push(("edgeId", edge.edge_id.clone()));
        refs.push(("trajectory", "controlPoints".to_owned()));
        let text = format!(
            "edge {} trajectory turns on a {radius_m:.2} m radius; this vehicle turns no tighter than {min_m:.2} m",
            edge.edge_id
        );
        return Err(error("orderError", text, refs));
    }
    Ok(())
}
