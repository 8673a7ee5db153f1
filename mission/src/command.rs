//! What items mean, and which are refused at upload.
//!
//! [`interpret_mission`], [`interpret_fence`] and [`interpret_rally`] turn a
//! stored item into a typed command or the MAV_MISSION_RESULT a GCS is told
//! when it uploads it: UNSUPPORTED (a command Furrow does not execute),
//! UNSUPPORTED_FRAME, INVALID_PARAMn (a NaN or out-of-range value where one
//! is needed), INVALID_PARAM5_X/6_Y (latitude/longitude out of range).
//!
//! Frames: global (absolute, relative-altitude or terrain, float or int —
//! altitude does not steer a rover) and local (MAV_FRAME_LOCAL_NED /
//! LOCAL_ENU: metres × 1e4 about the vehicle's local origin, 0.1 mm
//! resolution, so docking points are not quantised to 1e-7°). Items without
//! a position accept any frame, as QGC (MISSION) and Mission Planner
//! (GLOBAL_RELATIVE_ALT) send them differently. NAV_TAKEOFF, which some
//! GCSs insist on, is driven as a waypoint.

use mavlink::dialects::ardupilotmega::MavMissionResult;

pub mod cmd {
    pub const NAV_WAYPOINT: u16 = 16;
    pub const NAV_LOITER_UNLIM: u16 = 17;
    pub const NAV_LOITER_TIME: u16 = 19;
    pub const NAV_RETURN_TO_LAUNCH: u16 = 20;
    pub const NAV_TAKEOFF: u16 = 22;
    pub const NAV_DELAY: u16 = 93;
    pub const CONDITION_DELAY: u16 = 112;
    pub const CONDITION_DISTANCE: u16 = 114;
    pub const DO_JUMP: u16 = 177;
    pub const DO_CHANGE_SPEED: u16 = 178;
    pub const DO_SET_HOME: u16 = 179;
    pub const DO_SET_RELAY: u16 = 181;
    pub const DO_SET_SERVO: u16 = 183;
    pub const DO_REPEAT_SERVO: u16 = 184;
    pub const DO_SET_REVERSE: u16 = 194;
    pub const NAV_FENCE_RETURN_POINT: u16 = 5000;
    pub const NAV_FENCE_POLYGON_VERTEX_INCLUSION: u16 = 5001;
    pub const NAV_FENCE_POLYGON_VERTEX_EXCLUSION: u16 = 5002;
    pub const NAV_FENCE_CIRCLE_INCLUSION: u16 = 5003;
    pub const NAV_FENCE_CIRCLE_EXCLUSION: u16 = 5004;
    pub const NAV_RALLY_POINT: u16 = 5100;
}

pub mod frame {
    pub const GLOBAL: u8 = 0;
    pub const LOCAL_NED: u8 = 1;
    pub const MISSION: u8 = 2;
    pub const GLOBAL_RELATIVE_ALT: u8 = 3;
    pub const LOCAL_ENU: u8 = 4;
    pub const GLOBAL_INT: u8 = 5;
    pub const GLOBAL_RELATIVE_ALT_INT: u8 = 6;
    pub const GLOBAL_TERRAIN_ALT: u8 = 10;
    pub const GLOBAL_TERRAIN_ALT_INT: u8 = 11;
}

use crate::item::MissionItem;

/// Where a positional item points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Position {
    /// Latitude/longitude in degrees × 1e7 (altitude ignored by a rover).
    Global { lat_e7: i32, lon_e7: i32 },
    /// Metres about the vehicle's local origin (north, east).
    Local { north_m: f64, east_m: f64 },
    /// Latitude and longitude 0: where the vehicle is when the item starts
    /// (ArduPilot's convention).
    Current,
}

/// A mission item's meaning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MissionCommand {
    /// NAV_WAYPOINT (and NAV_TAKEOFF): drive there; `hold_s` > 0 stops and
    /// waits. `yaw_deg`: param 4, the true heading to stop facing (NaN:
    /// none); the vehicle decides whether it honours it.
    Waypoint {
        position: Position,
        hold_s: f32,
        yaw_deg: Option<f32>,
    },
    /// NAV_LOITER_UNLIM: drive there, stop, never complete.
    LoiterUnlimited {
        position: Position,
    },
    /// NAV_LOITER_TIME: drive there, stop, wait.
    LoiterTime {
        position: Position,
        seconds: f32,
    },
    ReturnToLaunch,
    /// NAV_DELAY: stop for `seconds`, or until a UTC time of day.
    Delay {
        seconds: Option<f32>,
        until_utc_s: Option<u32>,
    },
    /// DO_CHANGE_SPEED: `None` returns to the default speed.
    ChangeSpeed {
        speed_mps: Option<f32>,
    },
    SetReverse {
        reverse: bool,
    },
    /// DO_JUMP to item `target`; `repeat` -1 repeats forever.
    Jump {
        target: u16,
        repeat: i32,
    },
    SetHome {
        position: Option<Position>,
    },
    SetServo {
        channel: u8,
        pwm_us: u16,
    },
    /// DO_SET_RELAY: `state` 0 off, 1 on, 2 toggle.
    SetRelay {
        relay: u8,
        state: u8,
    },
    RepeatServo {
        channel: u8,
        pwm_us: u16,
        count: u16,
        period_s: f32,
    },
    ConditionDelay {
        seconds: f32,
    },
    ConditionDistance {
        metres: f32,
    },
}

impl MissionCommand {
    /// Navigation commands drive the vehicle; the others act at once or
    /// gate what follows.
    pub fn is_nav(&self) -> bool {
        matches!(
            self,
            MissionCommand::Waypoint { .. }
                | MissionCommand::LoiterUnlimited { .. }
                | MissionCommand::LoiterTime { .. }
                | MissionCommand::ReturnToLaunch
                | MissionCommand::Delay { .. }
        )
    }
}

/// A geofence item.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FenceItem {
    /// A vertex of an inclusion polygon with `vertex_count` vertices;
    /// polygons sharing `group` together form one allowed area.
    PolygonInclusion {
        vertex_count: u16,
        group: u8,
        position: Position,
    },
    PolygonExclusion {
        vertex_count: u16,
        position: Position,
    },
    CircleInclusion {
        radius_m: f32,
        group: u8,
        position: Position,
    },
    CircleExclusion {
        radius_m: f32,
        position: Position,
    },
    ReturnPoint {
        position: Position,
    },
}

/// A rally point (where RTL may go instead of home).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RallyItem {
    pub position: Position,
}

type Result<T> = std::result::Result<T, MavMissionResult>;

/// Limits on what an item may ask of the vehicle: generous for any use a
/// rover has, small enough that every value converts and adds without
/// overflow. ArduPilot keeps waypoint hold and loiter times in 16 bits
/// (at most 65 535 s, about 18 h), DO_JUMP repeats in 16 signed bits and
/// a rover's WP_SPEED at most 100 m/s.
pub mod limits {
    /// Longest hold, loiter, delay or servo repeat period: one day.
    pub const MAX_DURATION_S: f32 = 86_400.0;
    /// Shortest servo repeat period: faster toggles than 100 Hz mean nothing
    /// to a servo or relay and would flood the outputs.
    pub const MIN_REPEAT_PERIOD_S: f32 = 0.01;
    /// Fastest DO_CHANGE_SPEED.
    pub const MAX_SPEED_MPS: f32 = 100.0;
    /// Longest CONDITION_DISTANCE and largest fence circle radius: 100 km.
    pub const MAX_DISTANCE_M: f32 = 100_000.0;
    /// Most DO_JUMP repeats (ArduPilot's int16).
    pub const MAX_JUMP_REPEAT: f32 = 32_767.0;
}

const INVALID_PARAM: [MavMissionResult; 4] = [
    MavMissionResult::MAV_MISSION_INVALID_PARAM1,
    MavMissionResult::MAV_MISSION_INVALID_PARAM2,
    MavMissionResult::MAV_MISSION_INVALID_PARAM3,
    MavMissionResult::MAV_MISSION_INVALID_PARAM4,
];

/// Param `n` (1-based), which must be a finite number.
fn finite(item: &MissionItem, n: usize) -> Result<f32> {
    let v = item.params[n - 1];
    if v.is_finite() {
        Ok(v)
    } else {
        Err(INVALID_PARAM[n - 1])
    }
}

/// Param `n` where NaN means "not given" (MAVLink's convention).
fn optional(item: &MissionItem, n: usize) -> Result<Option<f32>> {
    let v = item.params[n - 1];
    if v.is_nan() {
        Ok(None)
    } else if v.is_finite() {
        Ok(Some(v))
    } else {
        Err(INVALID_PARAM[n - 1])
    }
}

fn is_global(frame: u8) -> bool {
    matches!(
        frame,
        frame::GLOBAL
            | frame::GLOBAL_RELATIVE_ALT
            | frame::GLOBAL_INT
            | frame::GLOBAL_RELATIVE_ALT_INT
            | frame::GLOBAL_TERRAIN_ALT
            | frame::GLOBAL_TERRAIN_ALT_INT
    )
}

/// The item's position in its frame.
pub fn position(item: &MissionItem) -> Result<Position> {
    match item.frame {
        f if is_global(f) => {
            if item.x == 0 && item.y == 0 {
                return Ok(Position::Current);
            }
            if item.x.unsigned_abs() > 900_000_000 {
                return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X);
            }
            if item.y.unsigned_abs() > 1_800_000_000 {
                return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y);
            }
            Ok(Position::Global {
                lat_e7: item.x,
                lon_e7: item.y,
            })
        }
        frame::LOCAL_NED => Ok(Position::Local {
            north_m: f64::from(item.x) / 1e4,
            east_m: f64::from(item.y) / 1e4,
        }),
        frame::LOCAL_ENU => Ok(Position::Local {
            north_m: f64::from(item.y) / 1e4,
            east_m: f64::from(item.x) / 1e4,
        }),
        _ => Err(MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME),
    }
}

/// Param `n` within `range`, a finite number.
fn within(item: &MissionItem, n: usize, range: std::ops::RangeInclusive<f32>) -> Result<f32> {
    let v = finite(item, n)?;
    if range.contains(&v) {
        Ok(v)
    } else {
        Err(INVALID_PARAM[n - 1])
    }
}

/// Param `n` as a duration the vehicle can wait: 0 to a day.
fn duration_s(item: &MissionItem, n: usize) -> Result<f32> {
    within(item, n, 0.0..=limits::MAX_DURATION_S)
}

/// Interprets an item of the mission plan. `count` is the plan's length
/// (DO_JUMP targets must lie inside it). Item 0 is home (ArduPilot's
/// convention) and is not interpreted.
pub fn interpret_mission(item: &MissionItem, count: u16) -> Result<MissionCommand> {
    use MissionCommand as C;
    Ok(match item.command {
        cmd::NAV_WAYPOINT | cmd::NAV_TAKEOFF => waypoint(item)?,
        cmd::NAV_LOITER_UNLIM => C::LoiterUnlimited {
            position: position(item)?,
        },
        cmd::NAV_LOITER_TIME => C::LoiterTime {
            seconds: duration_s(item, 1)?,
            position: position(item)?,
        },
        cmd::NAV_RETURN_TO_LAUNCH => C::ReturnToLaunch,
        cmd::NAV_DELAY => nav_delay(item)?,
        cmd::DO_CHANGE_SPEED => change_speed(item)?,
        cmd::DO_SET_REVERSE => match finite(item, 1)? {
            0.0 => C::SetReverse { reverse: false },
            1.0 => C::SetReverse { reverse: true },
            _ => return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1),
        },
        cmd::DO_JUMP => jump(item, count)?,
        cmd::DO_SET_HOME => {
            let use_current = finite(item, 1)?;
            if use_current == 1.0 {
                C::SetHome { position: None }
            } else {
                C::SetHome {
                    position: Some(position(item)?),
                }
            }
        }
        cmd::DO_SET_SERVO | cmd::DO_REPEAT_SERVO => servo(item)?,
        cmd::DO_SET_RELAY => relay(item)?,
        cmd::CONDITION_DELAY => C::ConditionDelay {
            seconds: duration_s(item, 1)?,
        },
        cmd::CONDITION_DISTANCE => C::ConditionDistance {
            metres: within(item, 1, 0.0..=limits::MAX_DISTANCE_M)?,
        },
        _ => return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED),
    })
}

/// NAV_WAYPOINT (param 1: hold seconds) or NAV_TAKEOFF (a waypoint for a rover).
fn waypoint(item: &MissionItem) -> Result<MissionCommand> {
    let hold_s = if item.command == cmd::NAV_WAYPOINT {
        optional(item, 1)?.unwrap_or(0.0)
    } else {
        0.0
    };
    if !(0.0..=limits::MAX_DURATION_S).contains(&hold_s) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let yaw_deg = if item.command == cmd::NAV_WAYPOINT {
        optional(item, 4)?
    } else {
        None
    };
    Ok(MissionCommand::Waypoint {
        position: position(item)?,
        hold_s,
        yaw_deg,
    })
}

/// NAV_DELAY: param 1 seconds, or -1 and an hour/minute/second of UTC
/// (-1 hour or minute: any).
fn nav_delay(item: &MissionItem) -> Result<MissionCommand> {
    let p1 = finite(item, 1)?;
    if p1 > limits::MAX_DURATION_S {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    if p1 >= 0.0 {
        return Ok(MissionCommand::Delay {
            seconds: Some(p1),
            until_utc_s: None,
        });
    }
    if p1 != -1.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let hour = finite(item, 2)?;
    let minute = finite(item, 3)?;
    let second = finite(item, 4)?;
    if !(-1.0..24.0).contains(&hour) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2);
    }
    if !(-1.0..60.0).contains(&minute) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM3);
    }
    if !(0.0..60.0).contains(&second) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM4);
    }
    let secs = (hour.max(0.0) as u32) * 3600 + (minute.max(0.0) as u32) * 60 + second as u32;
    Ok(MissionCommand::Delay {
        seconds: None,
        until_utc_s: Some(secs),
    })
}

fn change_speed(item: &MissionItem) -> Result<MissionCommand> {
    // 0 airspeed (treated as ground speed, as ArduPilot), 1 ground;
    // climb/descent speeds mean nothing to a rover.
    let kind = finite(item, 1)?;
    if kind != 0.0 && kind != 1.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let speed = finite(item, 2)?;
    let speed_mps = match speed {
        s if s > 0.0 && s <= limits::MAX_SPEED_MPS => Some(Some(s)),
        -2.0 => Some(None),
        -1.0 => None,
        _ => return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2),
    };
    Ok(match speed_mps {
        Some(speed_mps) => MissionCommand::ChangeSpeed { speed_mps },
        // -1: no change — an item that does nothing.
        None => MissionCommand::ConditionDelay { seconds: 0.0 },
    })
}

/// DO_JUMP: the target must lie inside a plan of `count` items.
fn jump(item: &MissionItem, count: u16) -> Result<MissionCommand> {
    let target = finite(item, 1)?;
    if target < 1.0 || target >= f32::from(count) || target.fract() != 0.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let repeat = finite(item, 2)?;
    if !(-1.0..=limits::MAX_JUMP_REPEAT).contains(&repeat) || repeat.fract() != 0.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2);
    }
    Ok(MissionCommand::Jump {
        target: target as u16,
        repeat: repeat as i32,
    })
}

/// DO_SET_SERVO, or DO_REPEAT_SERVO with its count and period.
fn servo(item: &MissionItem) -> Result<MissionCommand> {
    let channel = finite(item, 1)?;
    if !(1.0..=16.0).contains(&channel) || channel.fract() != 0.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let pwm = finite(item, 2)?;
    if !(500.0..=2500.0).contains(&pwm) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2);
    }
    if item.command == cmd::DO_SET_SERVO {
        return Ok(MissionCommand::SetServo {
            channel: channel as u8,
            pwm_us: pwm as u16,
        });
    }
    let count = within(item, 3, 1.0..=65535.0)?;
    let period_s = within(item, 4, limits::MIN_REPEAT_PERIOD_S..=limits::MAX_DURATION_S)?;
    Ok(MissionCommand::RepeatServo {
        channel: channel as u8,
        pwm_us: pwm as u16,
        count: count as u16,
        period_s,
    })
}

fn relay(item: &MissionItem) -> Result<MissionCommand> {
    let relay = finite(item, 1)?;
    if !(0.0..=15.0).contains(&relay) || relay.fract() != 0.0 {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    }
    let state = finite(item, 2)?;
    if ![0.0, 1.0, 2.0].contains(&state) {
        return Err(MavMissionResult::MAV_MISSION_INVALID_PARAM2);
    }
    Ok(MissionCommand::SetRelay {
        relay: relay as u8,
        state: state as u8,
    })
}

/// Interprets an item of the geofence plan.
pub fn interpret_fence(item: &MissionItem) -> Result<FenceItem> {
    let vertex_count = |item: &MissionItem| -> Result<u16> {
        let n = finite(item, 1)?;
        if (3.0..=1000.0).contains(&n) && n.fract() == 0.0 {
            Ok(n as u16)
        } else {
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1)
        }
    };
    let radius = |item: &MissionItem| -> Result<f32> {
        let r = finite(item, 1)?;
        if r > 0.0 && r <= limits::MAX_DISTANCE_M {
            Ok(r)
        } else {
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1)
        }
    };
    let group = |item: &MissionItem| -> Result<u8> { Ok(optional(item, 2)?.map_or(0, |g| g.clamp(0.0, 255.0) as u8)) };
    let at = |item: &MissionItem| -> Result<Position> {
        match position(item)? {
            Position::Current => Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X),
            p => Ok(p),
        }
    };
    Ok(match item.command {
        cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION => FenceItem::PolygonInclusion {
            vertex_count: vertex_count(item)?,
            group: group(item)?,
            position: at(item)?,
        },
        cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => FenceItem::PolygonExclusion {
            vertex_count: vertex_count(item)?,
            position: at(item)?,
        },
        cmd::NAV_FENCE_CIRCLE_INCLUSION => FenceItem::CircleInclusion {
            radius_m: radius(item)?,
            group: group(item)?,
            position: at(item)?,
        },
        cmd::NAV_FENCE_CIRCLE_EXCLUSION => FenceItem::CircleExclusion {
            radius_m: radius(item)?,
            position: at(item)?,
        },
        cmd::NAV_FENCE_RETURN_POINT => FenceItem::ReturnPoint { position: at(item)? },
        _ => return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED),
    })
}

/// Interprets an item of the rally plan.
pub fn interpret_rally(item: &MissionItem) -> Result<RallyItem> {
    if item.command != cmd::NAV_RALLY_POINT {
        return Err(MavMissionResult::MAV_MISSION_UNSUPPORTED);
    }
    match position(item)? {
        Position::Current => Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X),
        position => Ok(RallyItem { position }),
    }
}

/// Checks a whole fence plan: polygon vertices come in runs of exactly
/// `vertex_count` items. Returns the seq of the first bad item.
pub fn check_fence_polygons(items: &[FenceItem]) -> std::result::Result<(), (u16, MavMissionResult)> {
    let mut i = 0;
    while i < items.len() {
        let (count, inclusion) = match items[i] {
            FenceItem::PolygonInclusion { vertex_count, .. } => (vertex_count, true),
            FenceItem::PolygonExclusion { vertex_count, .. } => (vertex_count, false),
            _ => {
                i += 1;
                continue;
            }
        };
        for k in 0..usize::from(count) {
            let same = match items.get(i + k) {
                Some(FenceItem::PolygonInclusion { vertex_count, .. }) => inclusion && *vertex_count == count,
                Some(FenceItem::PolygonExclusion { vertex_count, .. }) => !inclusion && *vertex_count == count,
                _ => false,
            };
            if !same {
                return Err(((i + k) as u16, MavMissionResult::MAV_MISSION_INVALID_PARAM1));
            }
        }
        i += usize::from(count);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(command: u16, frame: u8, params: [f32; 4], x: i32, y: i32) -> MissionItem {
        MissionItem {
            seq: 1,
            frame,
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
    fn waypoint_in_global_and_local_frames() {
        let wp = item(
            cmd::NAV_WAYPOINT,
            frame::GLOBAL_RELATIVE_ALT_INT,
            [5.0, 0.0, 0.0, f32::NAN],
            291_330_000,
            1_196_400_000,
        );
        assert_eq!(
            interpret_mission(&wp, 10),
            Ok(MissionCommand::Waypoint {
                position: Position::Global {
                    lat_e7: 291_330_000,
                    lon_e7: 1_196_400_000
                },
                hold_s: 5.0,
                yaw_deg: None,
            })
        );
        // ENU: x east, y north, 0.1 mm units.
        let local = item(cmd::NAV_WAYPOINT, frame::LOCAL_ENU, [0.0; 4], 12_345, -67_891);
        assert_eq!(
            interpret_mission(&local, 10),
            Ok(MissionCommand::Waypoint {
                position: Position::Local {
                    north_m: -6.7891,
                    east_m: 1.2345
                },
                hold_s: 0.0,
                yaw_deg: Some(0.0),
            })
        );
        // Param 4: the heading to stop facing, NaN for none; infinite is
        // refused.
        let facing_east = item(cmd::NAV_WAYPOINT, frame::LOCAL_ENU, [0.0, 0.0, 0.0, 90.0], 1, 1);
        assert!(matches!(
            interpret_mission(&facing_east, 10),
            Ok(MissionCommand::Waypoint {
                yaw_deg: Some(90.0),
                ..
            })
        ));
        let bad_yaw = item(
            cmd::NAV_WAYPOINT,
            frame::LOCAL_ENU,
            [0.0, 0.0, 0.0, f32::INFINITY],
            1,
            1,
        );
        assert_eq!(
            interpret_mission(&bad_yaw, 10),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM4)
        );
    }

    #[test]
    fn precise_results_for_bad_items() {
        let bad = |c, f, p, x, y| interpret_mission(&item(c, f, p, x, y), 10).unwrap_err();
        assert_eq!(
            bad(21, frame::GLOBAL, [0.0; 4], 1, 1),
            MavMissionResult::MAV_MISSION_UNSUPPORTED,
            "NAV_LAND"
        );
        assert_eq!(
            bad(cmd::NAV_WAYPOINT, frame::MISSION, [0.0; 4], 1, 1),
            MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME
        );
        assert_eq!(
            bad(cmd::NAV_WAYPOINT, 7, [0.0; 4], 1, 1),
            MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME
        );
        assert_eq!(
            bad(cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 950_000_000, 1),
            MavMissionResult::MAV_MISSION_INVALID_PARAM5_X
        );
        assert_eq!(
            bad(cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, -1_900_000_000),
            MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y
        );
        assert_eq!(
            bad(cmd::NAV_WAYPOINT, frame::GLOBAL, [-1.0, 0.0, 0.0, 0.0], 1, 1),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1
        );
        assert_eq!(
            bad(cmd::DO_CHANGE_SPEED, frame::MISSION, [1.0, f32::NAN, 0.0, 0.0], 0, 0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM2
        );
        assert_eq!(
            bad(cmd::DO_SET_REVERSE, frame::MISSION, [2.0, 0.0, 0.0, 0.0], 0, 0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1
        );
        assert_eq!(
            bad(cmd::DO_JUMP, frame::MISSION, [10.0, 1.0, 0.0, 0.0], 0, 0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1,
            "past the end"
        );
        assert_eq!(
            bad(cmd::DO_SET_SERVO, frame::MISSION, [0.0, 1500.0, 0.0, 0.0], 0, 0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1
        );
        assert_eq!(
            bad(
                cmd::CONDITION_DELAY,
                frame::MISSION,
                [f32::INFINITY, 0.0, 0.0, 0.0],
                0,
                0
            ),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1
        );
    }

    #[test]
    fn durations_speeds_counts_and_distances_are_bounded() {
        use MavMissionResult as R;
        let mission = |c, p: [f32; 4]| interpret_mission(&item(c, frame::MISSION, p, 0, 0), 10);
        let at = |c, p: [f32; 4]| interpret_mission(&item(c, frame::GLOBAL, p, 1, 1), 10);
        for bad in [1e20, f32::INFINITY, f32::NEG_INFINITY, -2.0, 86_401.0] {
            assert_eq!(
                at(cmd::NAV_WAYPOINT, [bad, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                at(cmd::NAV_LOITER_TIME, [bad, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::NAV_DELAY, [bad, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::CONDITION_DELAY, [bad, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::DO_REPEAT_SERVO, [9.0, 1500.0, 2.0, bad]),
                Err(R::MAV_MISSION_INVALID_PARAM4)
            );
        }
        for nan in [f32::NAN, -f32::NAN] {
            assert_eq!(
                at(cmd::NAV_LOITER_TIME, [nan, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::NAV_DELAY, [nan, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::CONDITION_DELAY, [nan, 0.0, 0.0, 0.0]),
                Err(R::MAV_MISSION_INVALID_PARAM1)
            );
            assert_eq!(
                mission(cmd::DO_REPEAT_SERVO, [9.0, 1500.0, 2.0, nan]),
                Err(R::MAV_MISSION_INVALID_PARAM4)
            );
        }
        // A day is allowed: generous for any rover.
        assert!(at(cmd::NAV_LOITER_TIME, [86_400.0, 0.0, 0.0, 0.0]).is_ok());
        assert!(mission(cmd::NAV_DELAY, [86_400.0, 0.0, 0.0, 0.0]).is_ok());
        assert_eq!(
            mission(cmd::DO_REPEAT_SERVO, [9.0, 1500.0, 2.0, 0.001]),
            Err(R::MAV_MISSION_INVALID_PARAM4),
            "faster than 100 Hz"
        );
        assert_eq!(
            mission(cmd::DO_REPEAT_SERVO, [9.0, 1500.0, 1e9, 1.0]),
            Err(R::MAV_MISSION_INVALID_PARAM3)
        );
        assert_eq!(
            mission(cmd::DO_CHANGE_SPEED, [1.0, 1e20, 0.0, 0.0]),
            Err(R::MAV_MISSION_INVALID_PARAM2)
        );
        assert!(mission(cmd::DO_CHANGE_SPEED, [1.0, 100.0, 0.0, 0.0]).is_ok());
        assert_eq!(
            mission(cmd::DO_JUMP, [1.0, 1e20, 0.0, 0.0]),
            Err(R::MAV_MISSION_INVALID_PARAM2)
        );
        assert_eq!(
            mission(cmd::CONDITION_DISTANCE, [1e20, 0.0, 0.0, 0.0]),
            Err(R::MAV_MISSION_INVALID_PARAM1)
        );
        let circle = item(
            cmd::NAV_FENCE_CIRCLE_INCLUSION,
            frame::GLOBAL,
            [1e20, 0.0, 0.0, 0.0],
            1,
            1,
        );
        assert_eq!(interpret_fence(&circle), Err(R::MAV_MISSION_INVALID_PARAM1));
    }

    #[test]
    fn zero_zero_is_no_position_as_in_ardupilot() {
        let here = item(cmd::NAV_WAYPOINT, frame::GLOBAL_RELATIVE_ALT_INT, [0.0; 4], 0, 0);
        assert_eq!(
            interpret_mission(&here, 5),
            Ok(MissionCommand::Waypoint {
                position: Position::Current,
                hold_s: 0.0,
                yaw_deg: Some(0.0),
            })
        );
        let rally = item(cmd::NAV_RALLY_POINT, frame::GLOBAL, [0.0; 4], 0, 0);
        assert_eq!(
            interpret_rally(&rally),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X)
        );
        let one_cm_away = item(cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, 0);
        assert!(matches!(
            interpret_mission(&one_cm_away, 5),
            Ok(MissionCommand::Waypoint {
                position: Position::Global { lat_e7: 1, lon_e7: 0 },
                ..
            })
        ));
    }

    #[test]
    fn non_positional_items_take_any_frame() {
        for f in [frame::MISSION, frame::GLOBAL, frame::GLOBAL_RELATIVE_ALT] {
            let speed = item(cmd::DO_CHANGE_SPEED, f, [1.0, 0.5, -1.0, 0.0], 0, 0);
            assert_eq!(
                interpret_mission(&speed, 5),
                Ok(MissionCommand::ChangeSpeed { speed_mps: Some(0.5) })
            );
        }
        let rtl = item(cmd::NAV_RETURN_TO_LAUNCH, frame::MISSION, [0.0; 4], 0, 0);
        assert_eq!(interpret_mission(&rtl, 5), Ok(MissionCommand::ReturnToLaunch));
    }

    #[test]
    fn fence_polygons_must_be_complete() {
        let v = |n| FenceItem::PolygonInclusion {
            vertex_count: n,
            group: 0,
            position: Position::Current,
        };
        assert!(check_fence_polygons(&[v(3), v(3), v(3)]).is_ok());
        assert_eq!(check_fence_polygons(&[v(3), v(3)]).unwrap_err().0, 2);
        assert_eq!(check_fence_polygons(&[v(3), v(4), v(3)]).unwrap_err().0, 1);
    }

    #[test]
    fn fence_and_rally_items() {
        let circle = item(
            cmd::NAV_FENCE_CIRCLE_EXCLUSION,
            frame::GLOBAL,
            [12.5, 0.0, 0.0, 0.0],
            291_330_000,
            1_196_400_000,
        );
        assert!(
            matches!(interpret_fence(&circle), Ok(FenceItem::CircleExclusion { radius_m, .. }) if radius_m == 12.5)
        );
        let bad_radius = item(
            cmd::NAV_FENCE_CIRCLE_EXCLUSION,
            frame::GLOBAL,
            [-1.0, 0.0, 0.0, 0.0],
            1,
            1,
        );
        assert_eq!(
            interpret_fence(&bad_radius),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM1)
        );
        let rally = item(
            cmd::NAV_RALLY_POINT,
            frame::GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            291_330_000,
            1_196_400_000,
        );
        assert!(interpret_rally(&rally).is_ok());
        assert_eq!(
            interpret_rally(&item(cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 1, 1)),
            Err(MavMissionResult::MAV_MISSION_UNSUPPORTED)
        );
    }
}
