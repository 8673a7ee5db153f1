//! The one check every plan passes before it is put in force, whether it
//! was uploaded by a ground station, loaded from the data directory at
//! start or imported from a file: [`validate_plan`].
//!
//! Also here: what the dialect can carry ([`mav_cmd`], [`mav_frame`]), how
//! `x`/`y` integers relate to degrees and metres per frame, and the words
//! for a MAV_MISSION_RESULT.

use mavlink::dialects::ardupilotmega::{MavCmd, MavFrame, MavMissionResult};
use num_traits::FromPrimitive;

use crate::command::{self, check_fence_polygons, frame, interpret_fence, interpret_mission, interpret_rally};
use crate::item::{MissionItem, MissionType, Plan};

/// Most items a mission plan may hold (home included).
pub const MAX_MISSION_ITEMS: usize = 10_000;
/// Most items a fence plan may hold.
pub const MAX_FENCE_ITEMS: usize = 1000;
/// Most items a rally plan may hold.
pub const MAX_RALLY_ITEMS: usize = 200;

/// How many items a plan of `mission_type` may hold.
pub fn max_items(mission_type: MissionType) -> usize {
    match mission_type {
        MissionType::Mission => MAX_MISSION_ITEMS,
        MissionType::Fence => MAX_FENCE_ITEMS,
        MissionType::Rally => MAX_RALLY_ITEMS,
    }
}

/// The dialect's `MAV_CMD` for a command number, if it has one (only such
/// items can be sent in MISSION_ITEM_INT).
pub fn mav_cmd(command: u16) -> Option<MavCmd> {
    MavCmd::from_u16(command)
}

/// The dialect's `MAV_FRAME` for a frame number, if it has one.
pub fn mav_frame(frame: u8) -> Option<MavFrame> {
    MavFrame::from_u8(frame)
}

/// `NAV_WAYPOINT` for 16, `CMD 31999` for a number the dialect lacks.
pub fn command_name(command: u16) -> String {
    match mav_cmd(command) {
        Some(c) => format!("{c:?}").trim_start_matches("MAV_CMD_").to_string(),
        None => format!("CMD {command}"),
    }
}

/// `GLOBAL_RELATIVE_ALT` for 3, `FRAME 99` for a number the dialect lacks.
pub fn frame_name(frame: u8) -> String {
    match mav_frame(frame) {
        Some(f) => format!("{f:?}").trim_start_matches("MAV_FRAME_").to_string(),
        None => format!("FRAME {frame}"),
    }
}

/// Whether `x`/`y` are metres × 1e4 in this frame (local and body frames);
/// in every other frame they are degrees × 1e7 (global frames, and
/// MAV_FRAME_MISSION, as ArduPilot converts MISSION_ITEM).
pub fn is_local_frame(f: u8) -> bool {
    matches!(
        f,
        frame::LOCAL_NED | frame::LOCAL_ENU | 7..=9 | 12..=21
    )
}

/// Units of `x`/`y` per degree (global) or per metre (local).
pub fn xy_scale(f: u8) -> f64 {
    if is_local_frame(f) { 1e4 } else { 1e7 }
}

/// `x` or `y` as MISSION_ITEM (float) and files carry it: degrees or metres.
pub fn xy_to_float(f: u8, v: i32) -> f64 {
    f64::from(v) / xy_scale(f)
}

/// The integer for a float `x`/`y` (degrees or metres), rounded to the
/// nearest unit. `None` when it is not finite or does not fit, except that
/// NaN means 0 in MAV_FRAME_MISSION, where `x`/`y` carry no position.
pub fn xy_from_float(f: u8, v: f64) -> Option<i32> {
    if v.is_nan() && f == frame::MISSION {
        return Some(0);
    }
    let scaled = (v * xy_scale(f)).round();
    if scaled.is_finite() && scaled >= f64::from(i32::MIN) && scaled <= f64::from(i32::MAX) {
        Some(scaled as i32)
    } else {
        None
    }
}

/// A MAV_MISSION_RESULT in words, for STATUSTEXTs and error messages.
pub fn result_text(result: MavMissionResult) -> &'static str {
    use MavMissionResult as R;
    match result {
        R::MAV_MISSION_ACCEPTED => "accepted",
        R::MAV_MISSION_ERROR => "error",
        R::MAV_MISSION_UNSUPPORTED_FRAME => "frame not supported",
        R::MAV_MISSION_UNSUPPORTED => "command not supported",
        R::MAV_MISSION_NO_SPACE => "too many items",
        R::MAV_MISSION_INVALID => "invalid",
        R::MAV_MISSION_INVALID_PARAM1 => "param 1 invalid",
        R::MAV_MISSION_INVALID_PARAM2 => "param 2 invalid",
        R::MAV_MISSION_INVALID_PARAM3 => "param 3 invalid",
        R::MAV_MISSION_INVALID_PARAM4 => "param 4 invalid",
        R::MAV_MISSION_INVALID_PARAM5_X => "latitude/x invalid",
        R::MAV_MISSION_INVALID_PARAM6_Y => "longitude/y invalid",
        R::MAV_MISSION_INVALID_PARAM7 => "altitude/z invalid",
        R::MAV_MISSION_INVALID_SEQUENCE => "out of sequence",
        R::MAV_MISSION_DENIED => "denied",
        R::MAV_MISSION_OPERATION_CANCELLED => "cancelled",
    }
}

/// `INVALID_PARAM1 (param 1 invalid)`: the enum name and its meaning.
pub fn result_name(result: MavMissionResult) -> String {
    let name = format!("{result:?}");
    format!("{} ({})", name.trim_start_matches("MAV_MISSION_"), result_text(result))
}

/// Item 0 of a mission plan is home (ArduPilot's convention): any command,
/// but a position it carries must be one.
fn check_home(item: &MissionItem) -> Result<(), MavMissionResult> {
    let f = item.frame;
    if f == frame::MISSION {
        return Ok(());
    }
    if !is_local_frame(f) {
        if item.x.unsigned_abs() > 900_000_000 {
            return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
        }
        if item.y.unsigned_abs() > 1_800_000_000 {
            return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
        }
    }
    if !item.z.is_finite() {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM7);
    }
    Ok(())
}

/// Checks one item on its own: what an upload can refuse as soon as the
/// item arrives. `count` is the length of the plan it belongs to. Fence
/// polygons are checked across items by [`validate_plan`].
pub fn check_item(mission_type: MissionType, item: &MissionItem, count: u16) -> Result<(), MavMissionResult> {
    // Only what MISSION_ITEM_INT can carry can be downloaded again.
    if mav_cmd(item.command).is_none() {
        return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED);
    }
    if mav_frame(item.frame).is_none() {
        return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME);
    }
    match mission_type {
        MissionType::Mission if item.seq == 0 => check_home(item),
        MissionType::Mission => interpret_mission(item, count).map(|_| ()),
        MissionType::Fence => interpret_fence(item).map(|_| ()),
        MissionType::Rally => interpret_rally(item).map(|_| ()),
    }
}

/// Validates a whole plan: size, sequence numbers 0..n-1 in order, every
/// item, and (fence) complete polygons. The error names the seq of the
/// first bad item and the MAV_MISSION_RESULT a ground station is told.
pub fn validate_plan(mission_type: MissionType, items: Vec<MissionItem>) -> Result<Plan, (u16, MavMissionResult)> {
    let max = max_items(mission_type);
    if items.len() > max {
        return Err((max as u16, MavMissionResult::MAV_MISSION_NO_SPACE));
    }
    let count = items.len() as u16;
    for (i, item) in items.iter().enumerate() {
        if usize::from(item.seq) != i {
            return Err((i as u16, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE));
        }
        check_item(mission_type, item, count).map_err(|r| (item.seq, r))?;
    }
    if mission_type == MissionType::Fence {
        let fence: Vec<command::FenceItem> = items
            .iter()
            .map(|item| interpret_fence(item).map_err(|r| (item.seq, r)))
            .collect::<Result<_, _>>()?;
        check_fence_polygons(&fence)?;
    }
    Ok(Plan::new(mission_type, items.into_iter().map(canonical_nans).collect()))
}

/// The item with every NaN made the one NaN a file stores: a NaN's sign and
/// payload mean nothing to MAVLink, and text files keep neither, so a plan
/// holding one would get another id after a restart.
fn canonical_nans(mut item: MissionItem) -> MissionItem {
    let canonical = |v: f32| if v.is_nan() { f32::NAN } else { v };
    item.params = item.params.map(canonical);
    item.z = canonical(item.z);
    item
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::cmd;

    fn item(seq: u16, command: u16, f: u8, params: [f32; 4], x: i32, y: i32) -> MissionItem {
        MissionItem {
            seq,
            frame: f,
            command,
            current: false,
            autocontinue: true,
            params,
            x,
            y,
            z: 0.0,
        }
    }

    #[test]
    fn home_accepts_any_command_but_needs_a_valid_position() {
        // NAV_LAND (21) is refused in a mission, but not as home.
        let home = item(0, 21, frame::GLOBAL, [0.0; 4], 291_330_000, 1_196_400_000);
        assert!(validate_plan(MissionType::Mission, vec![home]).is_ok());
        let bad = item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 950_000_000, 0);
        assert_eq!(
            validate_plan(MissionType::Mission, vec![bad]),
            Err((0, MavMissionResult::MAV_MISSION_INVALID_PARAM5_X))
        );
        let mut nan_alt = item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, 1);
        nan_alt.z = f32::NAN;
        assert_eq!(
            validate_plan(MissionType::Mission, vec![nan_alt]),
            Err((0, MavMissionResult::MAV_MISSION_INVALID_PARAM7))
        );
        let unknown_cmd = item(0, 31_999, frame::GLOBAL, [0.0; 4], 1, 1);
        assert_eq!(
            validate_plan(MissionType::Mission, vec![unknown_cmd]),
            Err((0, MavMissionResult::MAV_MISSION_UNSUPPORTED))
        );
    }

    #[test]
    fn sequence_size_and_items() {
        let home = item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, 1);
        let wp = |seq| item(seq, cmd::NAV_WAYPOINT, frame::GLOBAL_RELATIVE_ALT, [0.0; 4], 2, 2);
        assert!(validate_plan(MissionType::Mission, vec![home, wp(1), wp(2)]).is_ok());
        assert_eq!(
            validate_plan(MissionType::Mission, vec![home, wp(2)]),
            Err((1, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE))
        );
        let too_many: Vec<_> = (0..=MAX_RALLY_ITEMS as u16)
            .map(|s| item(s, cmd::NAV_RALLY_POINT, frame::GLOBAL, [0.0; 4], 1, 1))
            .collect();
        assert_eq!(
            validate_plan(MissionType::Rally, too_many),
            Err((200, MavMissionResult::MAV_MISSION_NO_SPACE))
        );
        let bad_frame = item(1, cmd::DO_CHANGE_SPEED, 200, [1.0, 1.0, -1.0, 0.0], 0, 0);
        assert_eq!(
            validate_plan(MissionType::Mission, vec![home, bad_frame]),
            Err((1, MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME))
        );
    }

    #[test]
    fn fence_polygons_are_checked_across_items() {
        let v = |seq| {
            item(
                seq,
                cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                frame::GLOBAL,
                [3.0, 0.0, 0.0, 0.0],
                1,
                1,
            )
        };
        assert!(validate_plan(MissionType::Fence, vec![v(0), v(1), v(2)]).is_ok());
        assert_eq!(
            validate_plan(MissionType::Fence, vec![v(0), v(1)]),
            Err((2, MavMissionResult::MAV_MISSION_INVALID_PARAM1))
        );
    }

    #[test]
    fn nans_are_canonical_so_the_plan_id_survives_a_file() {
        let home = item(0, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, 1);
        let odd_nan = f32::from_bits(0xffc0_1234);
        let mut wp = item(1, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0, 0.0, 0.0, odd_nan], 2, 2);
        wp.z = -f32::NAN;
        let plan = validate_plan(MissionType::Mission, vec![home, wp]).unwrap();
        let text = crate::files::wpl::render(&plan);
        let back = validate_plan(MissionType::Mission, crate::files::wpl::parse(&text).unwrap()).unwrap();
        assert_eq!(back.opaque_id(), plan.opaque_id());
        assert_eq!(plan.items()[1].params[3].to_bits(), f32::NAN.to_bits());
    }

    #[test]
    fn float_coordinates() {
        assert_eq!(xy_from_float(frame::GLOBAL, 29.133_541_3), Some(291_335_413));
        assert_eq!(xy_from_float(frame::LOCAL_NED, -1.234_56), Some(-12_346));
        assert_eq!(xy_from_float(frame::GLOBAL, f64::NAN), None);
        assert_eq!(xy_from_float(frame::MISSION, f64::NAN), Some(0));
        assert_eq!(xy_from_float(frame::GLOBAL, 1e10), None);
        assert_eq!(xy_to_float(frame::LOCAL_ENU, 12_345), 1.2345);
        assert_eq!(command_name(16), "NAV_WAYPOINT");
        assert_eq!(command_name(31_999), "CMD 31999");
        assert_eq!(frame_name(3), "GLOBAL_RELATIVE_ALT");
        assert_eq!(
            result_name(MavMissionResult::MAV_MISSION_INVALID_PARAM1),
            "INVALID_PARAM1 (param 1 invalid)"
        );
    }
}
