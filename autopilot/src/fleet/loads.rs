//! The loads on the vehicle as its `pick` and `drop` actions leave them
//! (§6.8.2, the state's `loads`). Furrow has no load sensor: a finished
//! `pick` puts a load on, a finished `drop` takes it off; the actions'
//! `loadId`, `loadType` and `lhd` parameters name it and where it sits.

use vda5050::common::Action;
use vda5050::state::Load;

fn text(action: &Action, key: &str) -> Option<String> {
    let parameters = action.action_parameters.as_deref().unwrap_or_default();
    parameters
        .iter()
        .find(|p| p.key == key)
        .and_then(|p| p.value.as_str())
        .map(str::to_owned)
}

/// What a finished action does to the loads: `pick` adds one, `drop`
/// removes the one with its `loadId` (or, without one, the last picked).
pub fn apply(loads: &mut Vec<Load>, action: &Action) {
    match action.action_type.as_str() {
        "pick" => loads.push(Load {
            load_id: text(action, "loadId"),
            load_type: text(action, "loadType"),
            load_position: text(action, "lhd"),
            bounding_box_reference: None,
            load_dimensions: None,
            weight: None,
        }),
        "drop" => {
            let id = text(action, "loadId");
            let index = match &id {
                Some(id) => loads.iter().position(|l| l.load_id.as_ref() == Some(id)),
                None => loads.len().checked_sub(1),
            };
            if let Some(index) = index {
                loads.remove(index);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use vda5050::common::{ActionParameter, BlockingType};

    use super::*;

    fn action(kind: &str, load_id: Option<&str>) -> Action {
        Action {
            action_type: kind.into(),
            action_id: format!("{kind}-1"),
            action_description: None,
            blocking_type: BlockingType::Hard,
            action_parameters: load_id.map(|id| {
                vec![ActionParameter {
                    key: "loadId".into(),
                    value: id.into(),
                }]
            }),
        }
    }

    #[test]
    fn pick_puts_a_load_on_and_drop_takes_that_one_off() {
        let mut loads = Vec::new();
        apply(&mut loads, &action("pick", Some("car-17")));
        apply(&mut loads, &action("pick", None));
        assert_eq!(loads.len(), 2);
        assert_eq!(loads[0].load_id.as_deref(), Some("car-17"));
        apply(&mut loads, &action("drop", Some("car-17")));
        assert_eq!(loads.len(), 1);
        assert_eq!(loads[0].load_id, None);
        apply(&mut loads, &action("drop", Some("not-on-board")));
        assert_eq!(loads.len(), 1, "a drop of a load not carried changes nothing");
        apply(&mut loads, &action("drop", None));
        assert!(loads.is_empty());
        apply(&mut loads, &action("drop", None));
        apply(&mut loads, &action("beaconOn", None));
        assert!(loads.is_empty());
    }
}
