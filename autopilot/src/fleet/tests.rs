//! The agent's rules, stepped with time: acceptance and rejection, updates,
//! progress, actions, cancel and pause.

use serde_json::{Value, json};
use test_support::vda5050::{ALLOWED_DEVIATION_XY_M, N, instant, order};
use vda5050::Topic;
use vda5050::state::{ActionStatus, EStop, OperatingMode};

use super::agent::{Agent, AgentConfig, Command, Publish, VehicleView};
use super::map::MapPose;
use super::traversal::Fix;

fn agent() -> Agent {
    Agent::new(AgentConfig {
        map_id: "yard".into(),
        ..AgentConfig::default()
    })
}

/// The estimate's 95 % radius in these tests (m).
const BOUND_M: f64 = 0.01;

fn view(t: f64) -> VehicleView {
    at(t, 0.0, 0.0)
}

/// A view with the vehicle at map (x, y), heading east.
fn at(t: f64, x_m: f64, y_m: f64) -> VehicleView {
    let pose = MapPose {
        x_m,
        y_m,
        theta_rad: 0.0,
    };
    VehicleView {
        boot_s: t,
        wall_s: t,
        pose: Some(pose),
        fix: Some(Fix {
            pose,
            position_bound_m: BOUND_M,
            yaw_bound_rad: 0.01,
        }),
        arrived_at: None,
        at_rest: false,
        driving: false,
        operating_mode: OperatingMode::Automatic,
        e_stop: EStop::None,
        min_turn_radius_m: None,
    }
}

fn send(agent: &mut Agent, topic: Topic, value: &Value) {
    agent.receive(topic, serde_json::to_vec(value).unwrap());
}

/// a → b, 10 m east, b the end of the order.
fn two_nodes() -> Value {
    order(
        "o1",
        0,
        0,
        &[N("a", 0.0, 0.0, true, None), N("b", 10.0, 0.0, true, None)],
        &[],
    )
}

fn three_nodes() -> Value {
    order(
        "o1",
        0,
        0,
        &[
            N("a", 0.0, 0.0, true, None),
            N("b", 10.0, 0.0, true, None),
            N("c", 20.0, 0.0, true, None),
        ],
        &[],
    )
}

fn error_types(agent: &Agent) -> Vec<String> {
    let mut all: Vec<String> = agent.order.errors.iter().map(|e| e.error_type.clone()).collect();
    all.extend(agent.errors.iter().map(|e| e.error_type.clone()));
    all
}

fn leg(command: &Command) -> &super::Leg {
    match command {
        Command::Drive(leg) => leg,
        Command::Hold => panic!("expected a leg, got Hold"),
    }
}

#[test]
fn a_new_order_is_taken_from_its_first_node_and_driven_leg_by_leg() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    let command = a.step(&view(0.0));
    assert_eq!(a.order.last_node_id, "a");
    assert_eq!(a.order.nodes.len(), 2);
    let first = leg(&command);
    assert_eq!(
        (first.from, first.to, first.node_sequence_id),
        ((0.0, 0.0), (10.0, 0.0), 2)
    );
    assert!(!first.stop, "b is driven through towards c");
    assert_eq!(first.next, Some((20.0, 0.0)));
    assert!(a.take_publish().contains(&Publish::State), "state on a new order");

    let mut at_b = at(5.0, 10.0, 0.0);
    at_b.arrived_at = Some(2);
    let command = a.step(&at_b);
    assert_eq!((a.order.last_node_id.as_str(), a.order.last_node_sequence_id), ("b", 2));
    let second = leg(&command);
    assert!(second.stop, "c is the last node");
    assert_eq!(second.allowed_deviation_m, Some(ALLOWED_DEVIATION_XY_M));
    let mut at_c = at(10.0, 20.0, 0.0);
    at_c.arrived_at = Some(4);
    assert_eq!(a.step(&at_c), Command::Hold);
    assert!(!a.has_order());
}

#[test]
fn malformed_and_invalid_orders_are_rejected_and_the_old_order_is_kept() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    a.receive(Topic::Order, b"{not json".to_vec());
    let mut no_edges = three_nodes();
    no_edges["orderId"] = json!("o2");
    no_edges["edges"] = json!([]);
    send(&mut a, Topic::Order, &no_edges);
    let command = a.step(&view(1.0));
    assert_eq!(error_types(&a), vec!["validationError", "validationError"]);
    assert_eq!(a.order.order_id, "o1");
    assert_eq!(leg(&command).node_sequence_id, 2, "the running order goes on");
}

#[test]
fn unsupported_actions_other_maps_far_starts_and_bad_curves_are_refused_with_their_error_types() {
    type Change = fn(&mut Value);
    let cases: [(Change, &str); 4] = [
        (
            |o| o["nodes"][1]["actions"] = json!([{"actionId": "x", "actionType": "fly", "blockingType": "HARD"}]),
            "orderError",
        ),
        (
            |o| o["nodes"][2]["nodePosition"]["mapId"] = json!("other"),
            "noRouteError",
        ),
        (|o| o["nodes"][0]["nodePosition"]["x"] = json!(5.0), "noRouteError"),
        (
            |o| o["edges"][0]["trajectory"] = json!({"degree": 1, "knotVector": [0, 0.5, 0.2, 1], "controlPoints": [{"x": 0, "y": 0}, {"x": 10, "y": 0}]}),
            "validationError",
        ),
    ];
    for (change, expected) in cases {
        let mut a = agent();
        let mut o = three_nodes();
        change(&mut o);
        send(&mut a, Topic::Order, &o);
        assert_eq!(a.step(&view(0.0)), Command::Hold);
        assert_eq!(error_types(&a), vec![expected]);
        assert!(a.order.order_id.is_empty());
    }
}

fn with_horizon() -> Value {
    order(
        "o1",
        0,
        0,
        &[
            N("a", 0.0, 0.0, true, None),
            N("b", 10.0, 0.0, true, None),
            N("c", 20.0, 0.0, false, None),
        ],
        &[],
    )
}

#[test]
fn an_update_is_stitched_at_the_decision_point_and_ids_are_checked() {
    let mut a = agent();
    send(&mut a, Topic::Order, &with_horizon());
    let command = a.step(&view(0.0));
    assert!(leg(&command).stop, "b is the decision point");
    assert!(a.new_base_request(), "the base runs out at b");

    // An update from the wrong node, then an older one: refused.
    let wrong = order(
        "o1",
        1,
        0,
        &[N("a", 0.0, 0.0, true, None), N("b", 10.0, 0.0, true, None)],
        &[],
    );
    send(&mut a, Topic::Order, &wrong);
    a.step(&view(1.0));
    assert_eq!(error_types(&a), vec!["orderUpdateError"]);

    let update = order(
        "o1",
        2,
        2,
        &[
            N("b", 10.0, 0.0, true, None),
            N("c", 20.0, 0.0, true, None),
            N("d", 30.0, 0.0, true, None),
        ],
        &[],
    );
    send(&mut a, Topic::Order, &update);
    let command = a.step(&view(2.0));
    assert!(error_types(&a).is_empty(), "errors clear on acceptance");
    assert_eq!(a.order.order_update_id, 2);
    let ids: Vec<&str> = a.order.nodes.iter().map(|n| n.node_id.as_str()).collect();
    assert_eq!(ids, ["b", "c", "d"]);
    assert!(!leg(&command).stop, "b is now driven through");
    assert!(!a.new_base_request());

    let mut older = update.clone();
    older["orderUpdateId"] = json!(1);
    send(&mut a, Topic::Order, &older);
    a.step(&view(3.0));
    assert_eq!(error_types(&a), vec!["orderUpdateError"]);
    send(&mut a, Topic::Order, &update);
    a.step(&view(4.0));
    assert_eq!(error_types(&a).len(), 1, "a duplicate is ignored, not an error");
}

#[test]
fn an_update_after_completion_continues_from_the_last_node() {
    let mut a = agent();
    send(&mut a, Topic::Order, &two_nodes());
    a.step(&view(0.0));
    let mut at_b = at(1.0, 10.0, 0.0);
    at_b.arrived_at = Some(2);
    a.step(&at_b);
    assert!(!a.has_order());
    send(
        &mut a,
        Topic::Order,
        &order(
            "o1",
            1,
            2,
            &[N("b", 10.0, 0.0, true, None), N("c", 20.0, 0.0, true, None)],
            &[],
        ),
    );
    let command = a.step(&view(2.0));
    assert_eq!(leg(&command).to, (20.0, 0.0));
    // A different order while one runs is refused.
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(3.0));
    assert_eq!(error_types(&a), vec!["orderUpdateError"]);
}

#[test]
fn a_hard_node_action_holds_the_vehicle_until_it_finishes_and_reverse_edges_say_so() {
    let mut a = agent();
    let o = order(
        "o1",
        0,
        0,
        &[
            N("a", 0.0, 0.0, true, None),
            N("b", 10.0, 0.0, true, Some(("pick1", "pick"))),
            N("c", 0.0, 0.0, true, None),
        ],
        &[1],
    );
    send(&mut a, Topic::Order, &o);
    let command = a.step(&view(0.0));
    assert!(leg(&command).stop, "a blocking action stops at b");
    assert!(!leg(&command).reverse);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Waiting));
    let mut at_b = at(10.0, 10.0, 0.0);
    at_b.arrived_at = Some(2);
    assert_eq!(a.step(&at_b), Command::Hold);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Initializing));
    assert!(a.take_outputs().is_empty(), "not at rest yet");
    let mut resting = at(11.0, 10.0, 0.0);
    resting.at_rest = true;
    assert_eq!(a.step(&resting), Command::Hold);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Running));
    assert_eq!(a.take_outputs().len(), 1, "the pick's servo output");
    assert_eq!(a.step(&at(13.9, 10.0, 0.0)), Command::Hold);
    let command = a.step(&at(14.0, 10.0, 0.0));
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Finished));
    assert!(leg(&command).reverse, "orientation π, tangential: backwards");
}

/// startPause pauses the running pick: PAUSED, its clock stopped (a pause
/// longer than the pick does not finish it), its servo holding; stopPause
/// resumes it as RUNNING for the 2 s it had left, its output set again.
#[test]
fn a_pause_pauses_a_running_pick_and_the_resume_runs_it_for_what_it_had_left() {
    let mut a = agent();
    let nodes = [
        N("a", 0.0, 0.0, true, None),
        N("b", 10.0, 0.0, true, Some(("pick1", "pick"))),
    ];
    send(&mut a, Topic::Order, &order("o1", 0, 0, &nodes, &[]));
    a.step(&view(0.0));
    let resting = |t: f64| {
        let mut v = at(t, 10.0, 0.0);
        v.arrived_at = Some(2);
        v.at_rest = true;
        v
    };
    a.step(&resting(10.0));
    a.step(&resting(11.0));
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Running), "from 11 s");
    assert_eq!(a.take_outputs().len(), 1, "the pick's servo output");
    send(&mut a, Topic::InstantActions, &instant("p", "startPause"));
    a.step(&resting(12.0));
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Paused));
    assert!(a.take_outputs().is_empty(), "a servo holds its position");
    assert_eq!(a.step(&resting(20.0)), Command::Hold);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Paused), "8 s paused");
    send(&mut a, Topic::InstantActions, &instant("r", "stopPause"));
    a.step(&resting(20.0));
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Running));
    assert_eq!(a.take_outputs().len(), 1, "its output set again");
    a.step(&resting(21.9));
    assert_eq!(
        a.actions.status("pick1"),
        Some(ActionStatus::Running),
        "1 s run, 1.9 s more"
    );
    a.step(&resting(22.0));
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Finished));
}

#[test]
fn cancel_stops_at_once_and_finishes_once_the_vehicle_stands() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    send(&mut a, Topic::InstantActions, &instant("c1", "cancelOrder"));
    let mut moving = view(1.0);
    moving.driving = true;
    assert_eq!(a.step(&moving), Command::Hold);
    assert_eq!(a.actions.status("c1"), Some(ActionStatus::Running));
    assert!(a.order.nodes.is_empty() && a.order.edges.is_empty());
    assert_eq!(a.order.order_id, "o1", "ids are kept");
    a.step(&view(2.0));
    assert_eq!(
        a.actions.status("c1"),
        Some(ActionStatus::Running),
        "not standing for long yet"
    );
    a.step(&view(2.5));
    assert_eq!(a.actions.status("c1"), Some(ActionStatus::Finished));
    // Nothing left to cancel: FAILED and a warning.
    send(&mut a, Topic::InstantActions, &instant("c2", "cancelOrder"));
    a.step(&view(3.0));
    assert_eq!(a.actions.status("c2"), Some(ActionStatus::Failed));
    assert_eq!(error_types(&a), vec!["noOrderToCancel"]);
}

#[test]
fn pause_holds_and_resume_drives_on_and_a_ground_station_takes_over() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    send(&mut a, Topic::InstantActions, &instant("p", "startPause"));
    assert_eq!(a.step(&view(1.0)), Command::Hold);
    assert!(a.paused);
    send(&mut a, Topic::InstantActions, &instant("r", "stopPause"));
    assert!(matches!(a.step(&view(2.0)), Command::Drive(_)));
    let mut manual = view(3.0);
    manual.operating_mode = OperatingMode::Manual;
    assert_eq!(a.step(&manual), Command::Hold);
}

#[test]
fn requests_publish_and_state_is_paced_by_driving() {
    let mut a = agent();
    a.step(&view(0.0));
    assert_eq!(a.take_publish(), vec![Publish::State, Publish::Visualization]);
    a.step(&view(10.0));
    assert_eq!(a.take_publish(), vec![Publish::Visualization], "idle: state every 30 s");
    send(&mut a, Topic::InstantActions, &instant("s", "stateRequest"));
    a.step(&view(10.1));
    assert!(a.take_publish().contains(&Publish::State));
    send(&mut a, Topic::InstantActions, &instant("f", "factsheetRequest"));
    a.step(&view(10.2));
    assert!(a.take_publish().contains(&Publish::Factsheet));
    let mut driving = view(11.0);
    driving.driving = true;
    a.step(&driving);
    assert!(a.take_publish().contains(&Publish::State), "driving changed");
    driving.wall_s = 12.05;
    a.step(&driving);
    assert!(a.take_publish().contains(&Publish::State), "1 s while driving");
    a.receive(Topic::InstantActions, b"[]".to_vec());
    a.step(&driving);
    assert_eq!(error_types(&a), vec!["validationError"]);
}

mod fuzzed {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Whatever bytes arrive, the agent survives and the running order
        /// goes on.
        #[test]
        fn any_payload_is_survived(bytes in proptest::collection::vec(any::<u8>(), 0..400), instant in any::<bool>()) {
            let mut a = agent();
            send(&mut a, Topic::Order, &three_nodes());
            a.step(&view(0.0));
            let topic = if instant { Topic::InstantActions } else { Topic::Order };
            a.receive(topic, bytes);
            let command = a.step(&view(1.0));
            prop_assert!(matches!(command, Command::Drive(_)));
            prop_assert_eq!(a.order.order_id.as_str(), "o1");
        }

        /// Orders with shuffled sequence ids, released flags and edge counts
        /// are taken only when they keep §6.6.1's rules.
        #[test]
        fn only_well_formed_graphs_are_taken(
            count in 1usize..6,
            first_seq in 0u32..5,
            released in proptest::collection::vec(any::<bool>(), 6),
            drop_edge in any::<bool>(),
        ) {
            let nodes: Vec<N> = (0..count)
                .map(|i| N(["a", "b", "c", "d", "e", "f"][i], 5.0 * i as f64, 0.0, released[i], None))
                .collect();
            let mut o = order("o1", 0, first_seq, &nodes, &[]);
            if drop_edge && count > 1 {
                o["edges"].as_array_mut().unwrap().pop();
            }
            let mut a = agent();
            send(&mut a, Topic::Order, &o);
            a.step(&view(0.0));
            let base_first = released[0] && released[..count].windows(2).all(|w| w[0] || !w[1]);
            let well_formed = first_seq % 2 == 0 && base_first && !(drop_edge && count > 1);
            prop_assert_eq!(a.order.order_id == "o1", well_formed, "{:?}", a.order.errors);
            if well_formed {
                prop_assert_eq!(a.order.nodes.len(), count - 1);
                prop_assert_eq!(a.order.edges.len(), count - 1);
            }
        }
    }
}

/// b → c is a half circle of radius 5 bulging north (two rational
/// quadratic quarters), a → b a straight NURBS of degree 1.
fn with_trajectories() -> Value {
    let mut o = three_nodes();
    let h = std::f64::consts::FRAC_1_SQRT_2;
    o["edges"][0]["trajectory"] = json!({
        "degree": 1, "knotVector": [0, 0, 1, 1],
        "controlPoints": [{"x": 0, "y": 0}, {"x": 10, "y": 0}],
    });
    o["edges"][1]["trajectory"] = json!({
        "degree": 2, "knotVector": [0, 0, 0, 0.5, 0.5, 1, 1, 1],
        "controlPoints": [
            {"x": 10, "y": 0}, {"x": 10, "y": 5, "weight": h}, {"x": 15, "y": 5},
            {"x": 20, "y": 5, "weight": h}, {"x": 20, "y": 0},
        ],
    });
    o
}

#[test]
fn a_trajectory_is_driven_as_chords_on_the_curve_and_a_bad_one_is_refused() {
    let mut a = agent();
    send(&mut a, Topic::Order, &with_trajectories());
    let first = leg(&a.step(&view(0.0))).clone();
    let straight = first.path.as_deref().expect("a trajectory's chords");
    assert_eq!(straight, [(0.0, 0.0), (10.0, 0.0)]);
    let mut arrived = at(1.0, 10.0, 0.0);
    arrived.arrived_at = Some(2);
    let second = leg(&a.step(&arrived)).clone();
    let arc = second.path.as_deref().expect("a trajectory's chords");
    assert!(arc.len() > 20, "{} chords for a half circle of 5 m", arc.len());
    assert_eq!((arc[0], arc[arc.len() - 1]), ((10.0, 0.0), (20.0, 0.0)));
    for &(x, y) in arc {
        assert!(
            ((x - 15.0).hypot(y) - 5.0).abs() < 1e-9 && y >= 0.0,
            "({x}, {y}) is off the half circle"
        );
    }
    assert_eq!(a.errors.len() + a.order.errors.len(), 0);

    // Ends away from the nodes; a weight of 0.
    let cases: [fn(&mut Value); 2] = [
        |o| o["edges"][1]["trajectory"]["controlPoints"][4]["x"] = json!(19.5),
        |o| o["edges"][1]["trajectory"]["controlPoints"][1]["weight"] = json!(0.0),
    ];
    for change in cases {
        let mut a = agent();
        let mut o = with_trajectories();
        change(&mut o);
        send(&mut a, Topic::Order, &o);
        assert_eq!(a.step(&view(0.0)), Command::Hold);
        assert_eq!(error_types(&a), vec!["validationError"]);
        let refs = a.order.errors[0].error_references.clone().unwrap_or_default();
        assert!(
            refs.iter()
                .any(|r| r.reference_key == "edgeId" && r.reference_value == "e3"),
            "{refs:?}"
        );
    }
}

/// Steps `a` with the vehicle at (x, 0), the navigator's finished leg and
/// rest as given; the last node reported.
fn drive_at(a: &mut Agent, t: f64, x: f64, arrived_at: Option<u32>, at_rest: bool) -> (Command, String) {
    let mut v = at(t, x, 0.0);
    v.arrived_at = arrived_at;
    v.at_rest = at_rest;
    let command = a.step(&v);
    (command, a.order.last_node_id.clone())
}

#[test]
fn a_node_driven_through_is_reported_only_once_within_its_allowed_deviation() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    // The navigator switches legs `WP_RADIUS` (2 m) ahead of b: the
    // driving moves on, the report does not.
    let (command, last) = drive_at(&mut a, 5.0, 8.0, Some(2), false);
    assert_eq!(last, "a", "2 m short of b");
    assert_eq!(leg(&command).node_sequence_id, 4, "driving on towards c");
    assert_eq!(a.order.nodes[0].node_id, "b", "b is still to traverse");
    let (_, last) = drive_at(&mut a, 5.6, 9.0, None, false);
    assert_eq!(last, "a", "1 m short of b");
    // Within the deviation only with the estimate's uncertainty added.
    let edge = 10.0 - ALLOWED_DEVIATION_XY_M + BOUND_M / 2.0;
    let (_, last) = drive_at(&mut a, 5.7, edge, None, false);
    assert_eq!(last, "a", "{edge}: within the deviation only without the uncertainty");
    let (command, last) = drive_at(&mut a, 5.8, 9.8, None, false);
    assert_eq!(last, "b", "0.2 m from b, within its 0.25 m");
    assert_eq!(leg(&command).node_sequence_id, 4);
    assert!(error_types(&a).is_empty(), "{:?}", error_types(&a));
}

#[test]
fn a_node_driven_past_outside_its_deviation_is_reported_with_an_error() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    drive_at(&mut a, 5.0, 8.0, Some(2), false);
    let mut t = 5.0;
    // Past b 0.4 m to its side: closest at x = 10, then away.
    for x in [9.0, 9.5, 10.0, 10.02, 10.3] {
        t += 0.1;
        let mut v = at(t, x, 0.4);
        v.arrived_at = None;
        a.step(&v);
        if x <= 10.02 {
            assert_eq!(a.order.last_node_id, "a", "at x {x}: not yet past its closest");
        }
    }
    assert_eq!(a.order.last_node_id, "b", "behind the vehicle");
    assert_eq!(error_types(&a), vec!["nodeMissed"]);
    let text = a.errors[0].error_description.clone().unwrap_or_default();
    assert!(text.contains("0.40 m"), "{text}");
}

#[test]
fn a_stop_node_is_reported_while_rolling_in_within_its_deviation_and_driven_on_to_rest() {
    let mut a = agent();
    send(&mut a, Topic::Order, &two_nodes());
    a.step(&view(0.0));
    let (_, last) = drive_at(&mut a, 8.0, 9.7, None, false);
    assert_eq!(last, "a", "0.3 m short, outside the deviation");
    let (command, last) = drive_at(&mut a, 8.1, 9.9, None, false);
    assert_eq!(last, "b", "within the deviation, still rolling");
    assert!(a.order.nodes.is_empty(), "nodeStates: b is gone");
    assert_eq!(
        (leg(&command).node_sequence_id, leg(&command).stop),
        (2, true),
        "the stop is driven on"
    );
    assert!(a.has_order(), "AUTO drives the stop out");
    let (command, _) = drive_at(&mut a, 8.5, 9.95, None, true);
    assert_eq!(command, Command::Hold, "at rest: done");
    assert!(!a.has_order());
    assert!(error_types(&a).is_empty(), "{:?}", error_types(&a));
}

#[test]
fn a_hard_pick_on_a_stop_node_reported_while_rolling_runs_only_at_rest() {
    let mut a = agent();
    let o = order(
        "o1",
        0,
        0,
        &[
            N("a", 0.0, 0.0, true, None),
            N("b", 10.0, 0.0, true, Some(("pick1", "pick"))),
            N("c", 20.0, 0.0, true, None),
        ],
        &[],
    );
    send(&mut a, Topic::Order, &o);
    a.step(&view(0.0));
    let (command, last) = drive_at(&mut a, 5.0, 9.9, None, false);
    assert_eq!(last, "b");
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Initializing), "triggered");
    assert_eq!(leg(&command).node_sequence_id, 2, "rolling in onto b");
    let (command, _) = drive_at(&mut a, 5.1, 9.97, None, false);
    assert_eq!(
        a.actions.status("pick1"),
        Some(ActionStatus::Initializing),
        "still rolling"
    );
    assert_eq!(leg(&command).node_sequence_id, 2);
    assert!(a.take_outputs().is_empty(), "no pick while moving");
    let (command, _) = drive_at(&mut a, 5.2, 9.98, None, true);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Running));
    assert_eq!(a.take_outputs().len(), 1, "the pick's servo output");
    assert_eq!(command, Command::Hold);
    // The navigator settling afterwards changes nothing.
    let (command, _) = drive_at(&mut a, 6.0, 9.98, Some(2), true);
    assert_eq!(command, Command::Hold);
    let (command, last) = drive_at(&mut a, 8.3, 9.98, None, true);
    assert_eq!(a.actions.status("pick1"), Some(ActionStatus::Finished));
    assert_eq!((leg(&command).node_sequence_id, last.as_str()), (4, "b"), "on to c");
}

#[test]
fn a_decision_point_reported_before_rest_is_stitched_on_and_driven_on_from() {
    let mut a = agent();
    send(&mut a, Topic::Order, &with_horizon());
    a.step(&view(0.0));
    let (command, last) = drive_at(&mut a, 5.0, 9.9, None, false);
    assert_eq!(last, "b", "the decision point, still rolling");
    assert!(leg(&command).stop);
    assert!(a.new_base_request());
    let update = order(
        "o1",
        1,
        2,
        &[
            N("b", 10.0, 0.0, true, None),
            N("c", 20.0, 0.0, true, None),
            N("d", 30.0, 0.0, true, None),
        ],
        &[],
    );
    send(&mut a, Topic::Order, &update);
    let (command, _) = drive_at(&mut a, 5.1, 9.95, None, false);
    assert!(error_types(&a).is_empty(), "{:?}", error_types(&a));
    assert_eq!(a.order.order_update_id, 1);
    let ids: Vec<&str> = a.order.nodes.iter().map(|n| n.node_id.as_str()).collect();
    assert_eq!(ids, ["c", "d"]);
    let next = leg(&command);
    assert_eq!(
        (next.from, next.to, next.stop),
        ((10.0, 0.0), (20.0, 0.0), false),
        "no stop at b"
    );
    assert!(!a.new_base_request());
}

#[test]
fn the_base_request_follows_the_leg_being_driven() {
    let mut a = agent();
    let o = order(
        "o1",
        0,
        0,
        &[
            N("a", 0.0, 0.0, true, None),
            N("b", 10.0, 0.0, true, None),
            N("c", 20.0, 0.0, true, None),
            N("d", 30.0, 0.0, false, None),
        ],
        &[],
    );
    send(&mut a, Topic::Order, &o);
    a.step(&view(0.0));
    assert!(!a.new_base_request(), "driving to b, c is released");
    // The navigator leaves b's leg 2 m ahead of it: the leg to c, the
    // decision point, is driven while b is not reported yet.
    let (command, last) = drive_at(&mut a, 5.0, 8.0, Some(2), false);
    assert_eq!((leg(&command).node_sequence_id, last.as_str()), (4, "a"));
    assert!(a.new_base_request(), "the leg being driven ends the base");
}

#[test]
fn a_stop_the_navigator_settles_outside_the_deviation_is_reported_with_an_error() {
    let mut a = agent();
    send(&mut a, Topic::Order, &two_nodes());
    a.step(&view(0.0));
    let (_, last) = drive_at(&mut a, 8.0, 9.5, None, true);
    assert_eq!(last, "a", "at rest 0.5 m short");
    let (command, last) = drive_at(&mut a, 9.0, 9.5, Some(2), true);
    assert_eq!((last.as_str(), command), ("b", Command::Hold));
    assert_eq!(error_types(&a), vec!["nodeMissed"]);
}

#[test]
fn a_node_reached_before_the_navigator_is_done_with_its_leg_keeps_the_leg() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    // Within b's deviation while the navigator still rounds the corner.
    let (command, last) = drive_at(&mut a, 5.0, 9.9, None, false);
    assert_eq!(last, "b");
    assert_eq!(leg(&command).node_sequence_id, 2, "the leg to b is driven on");
    let (command, _) = drive_at(&mut a, 5.1, 10.0, Some(2), false);
    assert_eq!(leg(&command).node_sequence_id, 4, "then the one to c");
    assert_eq!(a.order.last_node_id, "b");
}

#[test]
fn a_swerve_before_a_node_is_no_miss_and_a_node_left_behind_a_whole_leg_is() {
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    drive_at(&mut a, 5.0, 8.0, Some(2), false);
    // Round something 2 m before b: farther from b, but not beyond it.
    let mut swerve = at(5.5, 8.3, 1.2);
    swerve.arrived_at = None;
    a.step(&swerve);
    assert_eq!(a.order.last_node_id, "a", "b is still ahead");
    assert!(error_types(&a).is_empty(), "{:?}", error_types(&a));
    let (_, last) = drive_at(&mut a, 6.5, 9.9, None, false);
    assert_eq!(last, "b");

    // Never near c's predecessor: the navigator finishing the leg after
    // it leaves it behind, whatever the way.
    let mut a = agent();
    send(&mut a, Topic::Order, &three_nodes());
    a.step(&view(0.0));
    let mut off = at(5.0, 8.0, 3.0);
    off.arrived_at = Some(2);
    a.step(&off);
    let mut at_c = at(12.0, 20.0, 0.0);
    at_c.arrived_at = Some(4);
    at_c.at_rest = true;
    assert_eq!(a.step(&at_c), Command::Hold);
    assert_eq!(a.order.last_node_id, "c");
    assert_eq!(error_types(&a), vec!["nodeMissed"], "b, never within 0.25 m");
}
