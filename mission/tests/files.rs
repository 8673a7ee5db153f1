//! Mission files: the bench courses, lossless round trips of random plans
//! (WPL 110 for any items, `.plan` for what it carries), and arbitrary text
//! that must never panic the parsers.

use std::path::PathBuf;

use mission::command::{cmd, frame};
use mission::files::plan_json::{self, PlanFile};
use mission::files::{FileKind, wpl};
use mission::{MissionItem, MissionType, Plan, Plans, validate_plan};
use proptest::prelude::*;

fn bench_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/bench")
}

/// Every field, bit for bit (NaN included).
fn same(a: &[MissionItem], b: &[MissionItem]) -> Result<(), TestCaseError> {
    prop_assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        prop_assert_eq!(x.content_bytes(), y.content_bytes(), "{:?} vs {:?}", x, y);
    }
    Ok(())
}

#[test]
fn bench_courses_parse_into_valid_plans_and_write_back() {
    let mut seen = 0;
    for entry in std::fs::read_dir(bench_dir()).expect("tests/data/bench") {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("waypoints") {
            continue;
        }
        seen += 1;
        assert_eq!(FileKind::from_path(&path), Some(FileKind::Wpl));
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(FileKind::sniff(&text), Some(FileKind::Wpl));
        let items = wpl::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(items.len() > 5);
        // Home, as Mission Planner writes it.
        assert_eq!((items[0].x, items[0].y, items[0].z), (291_330_000, 1_196_400_000, 40.0));
        let plan =
            validate_plan(MissionType::Mission, items.clone()).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        // Written by Furrow and read again: the same plan, the same id.
        let again = wpl::parse(&wpl::render(&plan)).unwrap();
        same(&again, &items).unwrap();
        assert_eq!(
            validate_plan(MissionType::Mission, again).unwrap().opaque_id(),
            plan.opaque_id()
        );
        // And through a .plan file.
        let plans = Plans {
            mission: plan.clone(),
            ..Plans::default()
        };
        let file = plan_json::parse(&plan_json::render(&plans, None)).unwrap();
        let back = validate_plan(MissionType::Mission, file.mission).unwrap();
        for (a, b) in back.items().iter().zip(plan.items()).skip(1) {
            assert_eq!(
                (a.command, a.frame, a.params, a.x, a.y, a.z),
                (b.command, b.frame, b.params, b.x, b.y, b.z)
            );
        }
    }
    assert_eq!(seen, 2, "agv_course and square_40m");
}

#[test]
fn agv_course_reads_exactly() {
    let text = std::fs::read_to_string(bench_dir().join("agv_course.waypoints")).unwrap();
    let items = wpl::parse(&text).unwrap();
    let pickup = &items[8];
    assert_eq!(
        (pickup.command, pickup.frame),
        (cmd::NAV_WAYPOINT, frame::GLOBAL_RELATIVE_ALT)
    );
    assert_eq!(pickup.params[0], 5.0, "hold 5 s");
    assert_eq!(
        (pickup.x, pickup.y),
        (291_333_609, 1_196_404_933),
        "8 decimals rounded to 7"
    );
    assert_eq!(items[9].command, cmd::DO_SET_SERVO);
    assert_eq!(items[9].params[..2], [9.0, 1900.0]);
}

// ---- Strategies -----------------------------------------------------------

fn any_param() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => (-1000i32..1000).prop_map(|v| v as f32 * 0.25),
        2 => any::<f32>().prop_filter("canonical NaN only", |v| !v.is_nan()),
        1 => Just(f32::NAN),
        1 => Just(-0.0f32),
    ]
}

fn finite_param() -> impl Strategy<Value = f32> {
    any_param().prop_filter("finite", |v| v.is_finite())
}

fn json_param() -> impl Strategy<Value = f32> {
    any_param().prop_filter("no infinities in JSON", |v| !v.is_infinite())
}

/// Any item at all: WPL 110 carries every field.
fn any_item() -> impl Strategy<Value = MissionItem> {
    (
        (any::<u8>(), any::<u16>(), any::<bool>(), any::<bool>()),
        [any_param(), any_param(), any_param(), any_param()],
        (any::<i32>(), any::<i32>(), any_param()),
    )
        .prop_map(
            |((frame, command, current, autocontinue), params, (x, y, z))| MissionItem {
                seq: 0,
                frame,
                command,
                current,
                autocontinue,
                params,
                x,
                y,
                z,
            },
        )
}

fn numbered(mut items: Vec<MissionItem>) -> Vec<MissionItem> {
    for (i, it) in items.iter_mut().enumerate() {
        it.seq = i as u16;
    }
    items
}

fn lat() -> impl Strategy<Value = i32> {
    -900_000_000i32..=900_000_000
}

fn lon() -> impl Strategy<Value = i32> {
    -1_800_000_000i32..=1_800_000_000
}

/// A valid mission plan of the shape a `.plan` file carries: home as
/// QGroundControl's planned home, then items without `current` flags whose
/// DO_JUMPs point at items of the plan.
fn plan_mission() -> impl Strategy<Value = Vec<MissionItem>> {
    let home = (lat(), lon(), finite_param()).prop_map(|(x, y, z)| MissionItem {
        seq: 0,
        frame: frame::GLOBAL,
        command: cmd::NAV_WAYPOINT,
        current: false,
        autocontinue: true,
        params: [0.0; 4],
        x,
        y,
        z,
    });
    let frames = prop::sample::select(vec![
        frame::GLOBAL,
        frame::GLOBAL_RELATIVE_ALT,
        frame::GLOBAL_INT,
        frame::GLOBAL_RELATIVE_ALT_INT,
        frame::GLOBAL_TERRAIN_ALT,
        frame::LOCAL_NED,
        frame::LOCAL_ENU,
    ]);
    let nav = (
        prop::sample::select(vec![cmd::NAV_WAYPOINT, cmd::NAV_LOITER_UNLIM, cmd::NAV_TAKEOFF]),
        frames,
        lat(),
        lon(),
        json_param(),
        json_param(),
        any::<bool>(),
    )
        .prop_map(|(command, f, x, y, z, p4, autocontinue)| MissionItem {
            seq: 0,
            frame: f,
            command,
            current: false,
            autocontinue,
            params: [0.0, 0.0, 0.0, p4],
            x,
            y,
            z,
        });
    let speed = (0.1f32..20.0, json_param()).prop_map(|(s, p4)| MissionItem {
        seq: 0,
        frame: frame::MISSION,
        command: cmd::DO_CHANGE_SPEED,
        current: false,
        autocontinue: true,
        params: [1.0, s, -1.0, p4],
        x: 0,
        y: 0,
        z: 0.0,
    });
    let jump = (1u16..50, -1i8..5).prop_map(|(target, repeat)| MissionItem {
        seq: 0,
        frame: frame::MISSION,
        command: cmd::DO_JUMP,
        current: false,
        autocontinue: true,
        params: [f32::from(target), f32::from(repeat), 0.0, 0.0],
        x: 0,
        y: 0,
        z: 0.0,
    });
    let body = prop::collection::vec(prop_oneof![5 => nav, 2 => speed, 1 => jump], 1..40);
    (home, body).prop_map(|(home, body)| {
        let n = body.len() as u16 + 1;
        let mut items = vec![home];
        for mut it in body {
            if it.command == cmd::DO_JUMP {
                it.params[0] = f32::from(1 + (it.params[0] as u16) % (n - 1));
            }
            items.push(it);
        }
        numbered(items)
    })
}

fn fence_vertex(inclusion: bool, n: usize, x: i32, y: i32) -> MissionItem {
    MissionItem {
        seq: 0,
        frame: frame::GLOBAL,
        command: if inclusion {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION
        } else {
            cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION
        },
        current: false,
        autocontinue: false,
        params: [n as f32, 0.0, 0.0, 0.0],
        x,
        y,
        z: 0.0,
    }
}

/// A valid fence of the shape a `.plan` file carries: polygons, then
/// circles, then at most one return point.
fn plan_fence() -> impl Strategy<Value = Vec<MissionItem>> {
    let polygon = (any::<bool>(), prop::collection::vec((lat(), lon()), 3..8)).prop_map(|(inc, vs)| {
        vs.iter()
            .map(|(x, y)| fence_vertex(inc, vs.len(), *x, *y))
            .collect::<Vec<_>>()
    });
    let circle = (any::<bool>(), 0.5f32..5000.0, lat(), lon()).prop_map(|(inc, r, x, y)| MissionItem {
        seq: 0,
        frame: frame::GLOBAL,
        command: if inc {
            cmd::NAV_FENCE_CIRCLE_INCLUSION
        } else {
            cmd::NAV_FENCE_CIRCLE_EXCLUSION
        },
        current: false,
        autocontinue: false,
        params: [r, 0.0, 0.0, 0.0],
        x,
        y,
        z: 0.0,
    });
    let ret = (lat(), lon(), finite_param()).prop_map(|(x, y, z)| MissionItem {
        seq: 0,
        frame: frame::GLOBAL_RELATIVE_ALT,
        command: cmd::NAV_FENCE_RETURN_POINT,
        current: false,
        autocontinue: false,
        params: [0.0; 4],
        x,
        y,
        z,
    });
    (
        prop::collection::vec(polygon, 0..4),
        prop::collection::vec(circle, 0..4),
        prop::option::of(ret),
    )
        .prop_map(|(polygons, circles, ret)| {
            let mut items: Vec<MissionItem> = polygons.into_iter().flatten().collect();
            items.extend(circles);
            items.extend(ret);
            numbered(items)
        })
}

fn plan_rally() -> impl Strategy<Value = Vec<MissionItem>> {
    prop::collection::vec(
        (lat(), lon(), finite_param()).prop_map(|(x, y, z)| MissionItem {
            seq: 0,
            frame: frame::GLOBAL_RELATIVE_ALT,
            command: cmd::NAV_RALLY_POINT,
            current: false,
            autocontinue: false,
            params: [0.0; 4],
            x,
            y,
            z,
        }),
        0..10,
    )
    .prop_map(numbered)
}

/// Lines that look like a WPL file, some of them broken.
fn wpl_like_text() -> impl Strategy<Value = String> {
    let field = prop_oneof![
        Just("0".to_string()),
        Just("1".to_string()),
        Just("16".to_string()),
        Just("nan".to_string()),
        Just("-".to_string()),
        Just(".".to_string()),
        Just("1e400".to_string()),
        Just("29.13354133".to_string()),
        Just("99999999999999999999.9".to_string()),
        "[-+.0-9eEna]{0,12}",
    ];
    let line = prop::collection::vec(field, 0..14).prop_map(|f| f.join("\t"));
    (any::<bool>(), prop::collection::vec(line, 0..6)).prop_map(|(header, lines)| {
        let mut text = if header {
            "QGC WPL 110\n".to_string()
        } else {
            String::new()
        };
        text.push_str(&lines.join("\n"));
        text
    })
}

/// JSON that looks like a `.plan` file, some of it broken.
fn plan_like_text() -> impl Strategy<Value = String> {
    let value = prop_oneof![
        Just("null".to_string()),
        Just("1e999".to_string()),
        Just("-0".to_string()),
        Just("65536".to_string()),
        Just("[1, 2]".to_string()),
        Just("[95, 200, 1]".to_string()),
        Just("\"x\"".to_string()),
        Just("{}".to_string()),
        Just("[]".to_string()),
        any::<f64>().prop_map(|v| format!("{v}")),
    ];
    let item = (prop::sample::select(vec!["SimpleItem", "ComplexItem", "Other"]), value.clone(), value.clone())
        .prop_map(|(t, a, b)| {
            format!(
                r#"{{"type": "{t}", "command": {a}, "frame": {b}, "params": [0, 0, 0, null, {a}, {b}, 1], "autoContinue": true, "doJumpId": {a}, "complexItemType": "survey"}}"#
            )
        });
    (prop::collection::vec(item, 0..4), value.clone(), value).prop_map(|(items, home, pts)| {
        format!(
            r#"{{"fileType": "Plan", "mission": {{"items": [{}], "plannedHomePosition": {home}}},
               "geoFence": {{"polygons": [{{"inclusion": true, "polygon": [{pts}]}}], "circles": []}},
               "rallyPoints": {{"points": [{pts}]}}}}"#,
            items.join(", ")
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn wpl_round_trips_any_items_exactly(items in prop::collection::vec(any_item(), 0..30)) {
        let items = numbered(items);
        let text = wpl::render_items(&items);
        let back = wpl::parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        same(&back, &items)?;
    }

    #[test]
    fn wpl_round_trips_valid_plans(mission in plan_mission(), fence in plan_fence(), rally in plan_rally()) {
        for (t, items) in [(MissionType::Mission, mission), (MissionType::Fence, fence), (MissionType::Rally, rally)] {
            let plan = validate_plan(t, items).map_err(|e| TestCaseError::fail(format!("{t:?} {e:?}")))?;
            let back = validate_plan(t, wpl::parse(&wpl::render(&plan)).unwrap()).unwrap();
            same(back.items(), plan.items())?;
            prop_assert_eq!(back.opaque_id(), plan.opaque_id());
        }
    }

    #[test]
    fn plan_json_round_trips_what_it_carries(mission in plan_mission(), fence in plan_fence(), rally in plan_rally()) {
        let plans = Plans {
            mission: validate_plan(MissionType::Mission, mission).map_err(|e| TestCaseError::fail(format!("{e:?}")))?,
            fence: validate_plan(MissionType::Fence, fence).map_err(|e| TestCaseError::fail(format!("{e:?}")))?,
            rally: validate_plan(MissionType::Rally, rally).map_err(|e| TestCaseError::fail(format!("{e:?}")))?,
        };
        let text = plan_json::render(&plans, None);
        let PlanFile { mission, fence, rally } =
            plan_json::parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        same(&mission, plans.mission.items())?;
        same(&fence, plans.fence.items())?;
        same(&rally, plans.rally.items())?;
        let ids: Vec<u32> = [
            (MissionType::Mission, mission),
            (MissionType::Fence, fence),
            (MissionType::Rally, rally),
        ]
        .into_iter()
        .map(|(t, items)| validate_plan(t, items).unwrap().opaque_id())
        .collect();
        prop_assert_eq!(ids, vec![plans.mission.opaque_id(), plans.fence.opaque_id(), plans.rally.opaque_id()]);
    }

    #[test]
    fn arbitrary_text_never_panics(text in any::<String>()) {
        let _ = wpl::parse(&text);
        let _ = plan_json::parse(&text);
        let _ = FileKind::sniff(&text);
    }

    #[test]
    fn wpl_like_text_never_panics(text in wpl_like_text()) {
        if let Ok(items) = wpl::parse(&text) {
            let _ = validate_plan(MissionType::Mission, items);
        }
    }

    #[test]
    fn plan_like_text_never_panics(text in plan_like_text()) {
        if let Ok(file) = plan_json::parse(&text) {
            let _ = validate_plan(MissionType::Mission, file.mission);
            let _ = validate_plan(MissionType::Fence, file.fence);
            let _ = validate_plan(MissionType::Rally, file.rally);
        }
    }
}

#[test]
fn empty_plans_render_and_parse() {
    let plans = Plans::default();
    let text = plan_json::render(&plans, None);
    let file = plan_json::parse(&text).unwrap();
    assert_eq!(file, PlanFile::default());
    assert_eq!(
        wpl::render(&Plan::new(MissionType::Mission, Vec::new())),
        "QGC WPL 110\n"
    );
    assert!(wpl::parse("QGC WPL 110\n").unwrap().is_empty());
}

#[test]
fn plan_json_uses_the_current_home_when_given() {
    let plans = Plans::default();
    let home = mission::HomeItem {
        lat_e7: 291_330_001,
        lon_e7: 1_196_400_002,
        alt_m: 40.5,
    };
    let text = plan_json::render(&plans, Some(home));
    assert!(text.contains("29.1330001") && text.contains("119.6400002"), "{text}");
    assert!(text.contains("\"fileType\": \"Plan\""));
    assert!(text.contains("\"groundStation\": \"Furrow\""));
}
