//! Parsing incoming `order` and `instantActions`: the standard's example-like
//! messages parse; malformed ones are errors that say what is wrong; arbitrary
//! input never panics.

use proptest::prelude::*;
use serde_json::{Value, json};
use vda5050::common::BlockingType;
use vda5050::order::OrientationType;
use vda5050::{ParseError, parse_instant_actions, parse_order};

/// An order in the style of the standard's examples: base of two nodes, a
/// horizon node, a reverse edge (at exactly the schema's bound on
/// `orientation`), a pick action.
#[allow(clippy::approx_constant)]
fn spec_like_order() -> Value {
    json!({
        "headerId": 3,
        "timestamp": "2017-04-15T11:40:03.12Z",
        "version": "2.1.0",
        "manufacturer": "Furrow",
        "serialNumber": "R1",
        "orderId": "1234",
        "orderUpdateId": 0,
        "nodes": [
            {"nodeId": "A", "sequenceId": 0, "released": true,
             "nodePosition": {"x": 0.0, "y": 0.0, "theta": 0.0, "mapId": "yard",
                              "allowedDeviationXY": 0.2, "allowedDeviationTheta": 0.1},
             "actions": []},
            {"nodeId": "B", "sequenceId": 2, "released": true,
             "nodePosition": {"x": 10.0, "y": 0.0, "mapId": "yard"},
             "actions": [{"actionId": "pick-1", "actionType": "pick", "blockingType": "HARD",
                          "actionParameters": [{"key": "stationType", "value": "floor"},
                                               {"key": "loadType", "value": "EPAL"}]}]},
            {"nodeId": "C", "sequenceId": 4, "released": false,
             "nodePosition": {"x": 10.0, "y": 10.0, "mapId": "yard"}, "actions": []}
        ],
        "edges": [
            {"edgeId": "AB", "sequenceId": 1, "released": true, "startNodeId": "A",
             "endNodeId": "B", "maxSpeed": 1.0, "orientation": 3.14159265359,
             "orientationType": "TANGENTIAL", "rotationAllowed": false, "actions": []},
            {"edgeId": "BC", "sequenceId": 3, "released": false, "startNodeId": "B",
             "endNodeId": "C", "actions": [],
             "trajectory": {"degree": 1, "knotVector": [0, 0, 1, 1],
                            "controlPoints": [{"x": 10, "y": 0}, {"x": 10, "y": 10}]}}
        ]
    })
}

fn order_schema() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/vda5050/order.schema");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn parse_value(order: &Value) -> Result<vda5050::Order, ParseError> {
    parse_order(&serde_json::to_vec(order).unwrap())
}

#[test]
fn spec_like_order_is_schema_valid_and_parses() {
    let order = spec_like_order();
    assert!(jsonschema::is_valid(&order_schema(), &order));
    let parsed = parse_value(&order).unwrap();
    assert_eq!(parsed.order_id, "1234");
    assert_eq!(parsed.nodes.len(), 3);
    assert!(!parsed.nodes[2].released);
    assert_eq!(parsed.nodes[1].actions[0].blocking_type, BlockingType::Hard);
    assert_eq!(parsed.edges[0].orientation_type, Some(OrientationType::Tangential));
    assert_eq!(parsed.edges[1].trajectory.as_ref().unwrap().degree, 1);
    assert_eq!(
        parsed.nodes[0].node_position.as_ref().unwrap().allowed_deviation_x_y,
        Some(0.2)
    );
}

#[test]
fn instant_actions_parse() {
    let message = json!({
        "headerId": 1, "timestamp": "2026-11-27T02:00:00Z", "version": "2.1.0",
        "manufacturer": "Furrow", "serialNumber": "R1",
        "actions": [{"actionId": "c1", "actionType": "cancelOrder", "blockingType": "NONE"},
                    {"actionId": "p1", "actionType": "startPause", "blockingType": "HARD"}]
    });
    let parsed = parse_instant_actions(&serde_json::to_vec(&message).unwrap()).unwrap();
    assert_eq!(parsed.actions.len(), 2);
    assert_eq!(parsed.actions[0].action_type, "cancelOrder");
}

/// Applies `change` to the spec-like order and returns the parse error text.
fn error_after(change: impl FnOnce(&mut Value)) -> String {
    let mut order = spec_like_order();
    change(&mut order);
    match parse_value(&order) {
        Ok(_) => panic!("accepted: {order:#}"),
        Err(err) => err.to_string(),
    }
}

#[test]
fn missing_required_fields_are_named() {
    let text = error_after(|o| {
        o.as_object_mut().unwrap().remove("edges");
    });
    assert!(text.contains("missing field `edges`"), "{text}");
    let text = error_after(|o| {
        o["nodes"][1].as_object_mut().unwrap().remove("released");
    });
    assert!(text.contains("missing field `released`"), "{text}");
    let text = error_after(|o| {
        o["nodes"][0]["nodePosition"].as_object_mut().unwrap().remove("mapId");
    });
    assert!(text.contains("missing field `mapId`"), "{text}");
}

#[test]
fn wrong_types_are_errors() {
    let text = error_after(|o| o["orderUpdateId"] = json!("zero"));
    assert!(text.contains("invalid type"), "{text}");
    let text = error_after(|o| o["orderUpdateId"] = json!(-1));
    assert!(text.contains("invalid value"), "{text}");
    let text = error_after(|o| o["nodes"] = json!({"nodeId": "A"}));
    assert!(text.contains("invalid type"), "{text}");
    let text = error_after(|o| o["edges"][0]["maxSpeed"] = json!("fast"));
    assert!(text.contains("invalid type"), "{text}");
}

#[test]
fn unknown_enum_values_are_errors() {
    let text = error_after(|o| o["nodes"][1]["actions"][0]["blockingType"] = json!("HARDER"));
    assert!(text.contains("unknown variant `HARDER`"), "{text}");
    let text = error_after(|o| o["edges"][0]["orientationType"] = json!("tangential"));
    assert!(text.contains("unknown variant `tangential`"), "{text}");
}

#[test]
fn schema_bounds_are_checked_with_the_field_named() {
    let text = error_after(|o| o["nodes"][0]["nodePosition"]["theta"] = json!(4.0));
    assert_eq!(text, "nodes[0].nodePosition.theta = 4 is out of range (-π to π)");
    let text = error_after(|o| o["nodes"][0]["nodePosition"]["allowedDeviationXY"] = json!(-0.1));
    assert!(text.contains("allowedDeviationXY = -0.1"), "{text}");
    let text = error_after(|o| o["edges"][1]["trajectory"]["knotVector"][3] = json!(1.5));
    assert!(text.contains("edges[1].trajectory.knotVector[3]"), "{text}");
    let text = error_after(|o| o["edges"][1]["trajectory"]["degree"] = json!(0));
    assert!(text.contains("degree = 0"), "{text}");
    let text = error_after(|o| o["edges"][0]["orientation"] = json!(-3.2));
    assert!(text.contains("edges[0].orientation"), "{text}");
    let text = error_after(|o| o["nodes"][1]["actions"][0]["actionParameters"][0]["value"] = json!(null));
    assert!(text.contains("actionParameters[0].value is null"), "{text}");
    let text = error_after(|o| o["timestamp"] = json!("15.04.2017"));
    assert!(text.contains("not an ISO 8601"), "{text}");
}

/// The standard's table gives `degree` as float64, its schema as integer:
/// a whole number written either way is read, a fraction is refused.
#[test]
fn a_trajectory_degree_is_a_whole_number_written_as_integer_or_float() {
    let mut order = spec_like_order();
    order["edges"][1]["trajectory"]["degree"] = json!(1.0);
    let parsed = parse_value(&order).expect("1.0 is a whole number");
    assert_eq!(parsed.edges[1].trajectory.as_ref().unwrap().degree, 1);
    let text = error_after(|o| o["edges"][1]["trajectory"]["degree"] = json!(2.5));
    assert!(text.contains("2.5 is not a whole number"), "{text}");
    let text = error_after(|o| o["edges"][1]["trajectory"]["degree"] = json!(1e12));
    assert!(text.contains("is not a whole number"), "{text}");
}

#[test]
fn every_rejected_bound_is_also_rejected_by_the_official_schema() {
    let schema = order_schema();
    let changes: [fn(&mut Value); 5] = [
        |o| o["nodes"][0]["nodePosition"]["theta"] = json!(4.0),
        |o| o["nodes"][0]["nodePosition"]["allowedDeviationXY"] = json!(-0.1),
        |o| o["edges"][1]["trajectory"]["knotVector"][3] = json!(1.5),
        |o| o["edges"][1]["trajectory"]["degree"] = json!(0),
        |o| o["nodes"][1]["actions"][0]["actionParameters"][0]["value"] = json!(null),
    ];
    for change in changes {
        let mut order = spec_like_order();
        change(&mut order);
        assert!(parse_value(&order).is_err());
        assert!(!jsonschema::is_valid(&schema, &order), "{order:#}");
    }
}

#[test]
fn not_json_is_an_error() {
    for payload in [&b""[..], b"{", b"null", b"[]", b"\xff\xfe", b"{\"headerId\": 1e999}"] {
        assert!(parse_order(payload).is_err());
        assert!(parse_instant_actions(payload).is_err());
    }
}

fn arbitrary_json() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::from),
        any::<i64>().prop_map(Value::from),
        any::<f64>().prop_map(Value::from),
        "[a-zA-Z]{0,8}".prop_map(Value::from),
    ];
    leaf.prop_recursive(4, 64, 8, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..8).prop_map(Value::from),
            prop::collection::btree_map(
                prop_oneof![
                    "[a-z]{1,6}".boxed(),
                    Just("nodes".to_owned()).boxed(),
                    Just("actions".to_owned()).boxed(),
                    Just("nodePosition".to_owned()).boxed(),
                    Just("trajectory".to_owned()).boxed(),
                ],
                inner,
                0..8
            )
            .prop_map(|map| Value::Object(map.into_iter().collect())),
        ]
    })
}

/// Paths into the spec-like order where a replaced value stresses the parser.
const ORDER_PATHS: [&str; 8] = [
    "/nodes/0",
    "/nodes/0/nodePosition",
    "/nodes/1/actions/0",
    "/nodes/1/actions/0/actionParameters/0/value",
    "/edges/0",
    "/edges/1/trajectory",
    "/edges/1/trajectory/knotVector",
    "/orderUpdateId",
];

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let _ = parse_order(&bytes);
        let _ = parse_instant_actions(&bytes);
    }

    #[test]
    fn arbitrary_json_never_panics(value in arbitrary_json()) {
        let bytes = serde_json::to_vec(&value).unwrap();
        let _ = parse_order(&bytes);
        let _ = parse_instant_actions(&bytes);
    }

    #[test]
    fn order_with_one_value_replaced_never_panics(
        path in prop::sample::select(&ORDER_PATHS[..]),
        replacement in arbitrary_json(),
    ) {
        let mut order = spec_like_order();
        *order.pointer_mut(path).unwrap() = replacement;
        let _ = parse_value(&order);
    }
}
