//! Mission files (`mission::files`): QGC WPL 110 (`.waypoints`) and
//! QGroundControl's `.plan` JSON, then `validate_plan` on what they hold,
//! as `furrow mission import` and the SITL `--tape` option read them.
//!
//! Properties: a parsed file written back and parsed again gives the same
//! items (WPL: every item exactly; `.plan`: the three plans), and writing
//! is a fixed point from then on.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mission::files::{FileKind, plan_json, wpl};
use mission::{MissionItem, MissionType, Plan, Plans, validate_plan};

/// An item's content with every NaN the same (`-nan` and `nan` are one
/// value to a mission; the text form keeps no sign on NaN).
fn key(item: &MissionItem) -> [u8; 38] {
    let canonical = |v: f32| if v.is_nan() { f32::NAN } else { v };
    let mut it = *item;
    it.params = it.params.map(canonical);
    it.z = canonical(it.z);
    it.content_bytes()
}

fn keys(items: &[MissionItem]) -> Vec<[u8; 38]> {
    items.iter().map(key).collect()
}

fn check_wpl(text: &str) {
    let Ok(items) = wpl::parse(text) else {
        return;
    };
    let _ = validate_plan(MissionType::Mission, items.clone());
    let written = wpl::render_items(&items);
    let again = wpl::parse(&written).expect("a written WPL file parses");
    assert_eq!(
        keys(&again),
        keys(&items),
        "WPL written back reads differently:\n{written}"
    );
    assert_eq!(wpl::render_items(&again), written, "WPL writing is not a fixed point");
}

fn plans_of(file: &plan_json::PlanFile) -> Plans {
    let mut plans = Plans::default();
    for (t, items) in [
        (MissionType::Mission, &file.mission),
        (MissionType::Fence, &file.fence),
        (MissionType::Rally, &file.rally),
    ] {
        let _ = validate_plan(t, items.clone());
        plans.set(t, Plan::new(t, items.clone()));
    }
    plans
}

fn check_plan_json(text: &str) {
    let Ok(file) = plan_json::parse(text) else {
        return;
    };
    let written = plan_json::render(&plans_of(&file), None);
    let again = plan_json::parse(&written).expect("a written .plan file parses");
    for (what, a, b) in [
        ("mission", &again.mission, &file.mission),
        ("fence", &again.fence, &file.fence),
        ("rally", &again.rally, &file.rally),
    ] {
        assert_eq!(
            keys(a),
            keys(b),
            ".plan {what} written back reads differently:\n{written}"
        );
    }
    assert_eq!(
        plan_json::render(&plans_of(&again), None),
        written,
        ".plan writing is not a fixed point"
    );
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Both parsers see every input (a wrong extension is common); sniffing
    // must agree with a successful parse.
    let kind = FileKind::sniff(text);
    if wpl::parse(text).is_ok() {
        assert_eq!(kind, Some(FileKind::Wpl), "a WPL file not sniffed as WPL");
    }
    check_wpl(text);
    check_plan_json(text);
});
