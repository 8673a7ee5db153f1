//! Per-link telemetry rates.
//!
//! Messages are grouped into ArduPilot's streams (`SRn_EXT_STAT`,
//! `SRn_POSITION`, …). A link starts with its slot's `SRn_*` rates;
//! REQUEST_DATA_STREAM overrides a group on that link (what MAVProxy and
//! Mission Planner send) and SET_MESSAGE_INTERVAL overrides one message.
//! Rates are in wall time: a GCS sees the same rates whatever the speedup.

use std::time::Duration;

/// ArduPilot's stream groups, in `SRn_*` parameter order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamGroup {
    RawSens,
    ExtStat,
    RcChan,
    RawCtrl,
    Position,
    Extra1,
    Extra2,
    Extra3,
    Params,
    Adsb,
}

impl StreamGroup {
    pub const COUNT: usize = 10;
    pub const ALL: [StreamGroup; Self::COUNT] = [
        StreamGroup::RawSens,
        StreamGroup::ExtStat,
        StreamGroup::RcChan,
        StreamGroup::RawCtrl,
        StreamGroup::Position,
        StreamGroup::Extra1,
        StreamGroup::Extra2,
        StreamGroup::Extra3,
        StreamGroup::Params,
        StreamGroup::Adsb,
    ];

    pub fn param_suffix(self) -> &'static str {
        match self {
            StreamGroup::RawSens => "RAW_SENS",
            StreamGroup::ExtStat => "EXT_STAT",
            StreamGroup::RcChan => "RC_CHAN",
            StreamGroup::RawCtrl => "RAW_CTRL",
            StreamGroup::Position => "POSITION",
            StreamGroup::Extra1 => "EXTRA1",
            StreamGroup::Extra2 => "EXTRA2",
            StreamGroup::Extra3 => "EXTRA3",
            StreamGroup::Params => "PARAMS",
            StreamGroup::Adsb => "ADSB",
        }
    }

    /// Defaults: ArduPilot Rover's 1 Hz, with position, attitude and HUD at
    /// 4 Hz so a map and HUD move smoothly without a stream request.
    pub fn default_rate_hz(self) -> i16 {
        match self {
            StreamGroup::Position | StreamGroup::Extra1 | StreamGroup::Extra2 => 4,
            StreamGroup::Params => 10,
            StreamGroup::Adsb => 0,
            _ => 1,
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            StreamGroup::RawSens => "Raw sensor stream rate",
            StreamGroup::ExtStat => "SYS_STATUS, GPS_RAW_INT, NAV_CONTROLLER_OUTPUT stream rate",
            StreamGroup::RcChan => "SERVO_OUTPUT_RAW stream rate",
            StreamGroup::RawCtrl => "Raw controller stream rate",
            StreamGroup::Position => "GLOBAL_POSITION_INT, LOCAL_POSITION_NED stream rate",
            StreamGroup::Extra1 => "ATTITUDE (and SIMSTATE in SITL) stream rate",
            StreamGroup::Extra2 => "VFR_HUD stream rate",
            StreamGroup::Extra3 => "SYSTEM_TIME, BATTERY_STATUS, EKF_STATUS_REPORT, OBSTACLE_DISTANCE stream rate",
            StreamGroup::Params => "Parameter streaming rate",
            StreamGroup::Adsb => "ADS-B stream rate",
        }
    }

    /// The groups a `MAV_DATA_STREAM` id of REQUEST_DATA_STREAM selects.
    pub fn from_data_stream(id: u8) -> &'static [StreamGroup] {
        use StreamGroup::*;
        match id {
            0 => &[RawSens, ExtStat, RcChan, RawCtrl, Position, Extra1, Extra2, Extra3],
            1 => &[RawSens],
            2 => &[ExtStat],
            3 => &[RcChan],
            4 => &[RawCtrl],
            6 => &[Position],
            10 => &[Extra1],
            11 => &[Extra2],
            12 => &[Extra3],
            _ => &[],
        }
    }
}

/// The telemetry messages Furrow streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamMsg {
    SysStatus,
    GpsRawInt,
    NavControllerOutput,
    PositionTargetGlobalInt,
    ServoOutputRaw,
    GlobalPositionInt,
    LocalPositionNed,
    Attitude,
    SimState,
    VfrHud,
    SystemTime,
    BatteryStatus,
    EkfStatusReport,
    ExtendedSysState,
    HomePosition,
    MissionCurrent,
    FenceStatus,
    RelayStatus,
    ObstacleDistance,
}

impl StreamMsg {
    pub const COUNT: usize = 19;
    pub const ALL: [StreamMsg; Self::COUNT] = [
        StreamMsg::SysStatus,
        StreamMsg::GpsRawInt,
        StreamMsg::NavControllerOutput,
        StreamMsg::PositionTargetGlobalInt,
        StreamMsg::ServoOutputRaw,
        StreamMsg::GlobalPositionInt,
        StreamMsg::LocalPositionNed,
        StreamMsg::Attitude,
        StreamMsg::SimState,
        StreamMsg::VfrHud,
        StreamMsg::SystemTime,
        StreamMsg::BatteryStatus,
        StreamMsg::EkfStatusReport,
        StreamMsg::ExtendedSysState,
        StreamMsg::HomePosition,
        StreamMsg::MissionCurrent,
        StreamMsg::FenceStatus,
        StreamMsg::RelayStatus,
        StreamMsg::ObstacleDistance,
    ];

    pub fn message_id(self) -> u32 {
        match self {
            StreamMsg::SysStatus => 1,
            StreamMsg::SystemTime => 2,
            StreamMsg::GpsRawInt => 24,
            StreamMsg::Attitude => 30,
            StreamMsg::LocalPositionNed => 32,
            StreamMsg::GlobalPositionInt => 33,
            StreamMsg::ServoOutputRaw => 36,
            StreamMsg::NavControllerOutput => 62,
            StreamMsg::VfrHud => 74,
            StreamMsg::PositionTargetGlobalInt => 87,
            StreamMsg::BatteryStatus => 147,
            StreamMsg::SimState => 164,
            StreamMsg::EkfStatusReport => 193,
            StreamMsg::HomePosition => 242,
            StreamMsg::ExtendedSysState => 245,
            StreamMsg::MissionCurrent => 42,
            StreamMsg::FenceStatus => 162,
            StreamMsg::RelayStatus => 376,
            StreamMsg::ObstacleDistance => 330,
        }
    }

    pub fn from_message_id(id: u32) -> Option<StreamMsg> {
        Self::ALL.iter().copied().find(|m| m.message_id() == id)
    }

    /// The group whose rate the message follows (None: only on request or
    /// with SET_MESSAGE_INTERVAL).
    pub fn group(self) -> Option<StreamGroup> {
        match self {
            StreamMsg::SysStatus
            | StreamMsg::GpsRawInt
            | StreamMsg::NavControllerOutput
            | StreamMsg::PositionTargetGlobalInt
            | StreamMsg::MissionCurrent
            | StreamMsg::FenceStatus
            | StreamMsg::RelayStatus => Some(StreamGroup::ExtStat),
            StreamMsg::ServoOutputRaw => Some(StreamGroup::RcChan),
            // As ArduPilot: the local position beside the global one, the
            // simulator's truth beside the attitude.
            StreamMsg::GlobalPositionInt | StreamMsg::LocalPositionNed => Some(StreamGroup::Position),
            StreamMsg::Attitude | StreamMsg::SimState => Some(StreamGroup::Extra1),
            StreamMsg::VfrHud => Some(StreamGroup::Extra2),
            StreamMsg::SystemTime
            | StreamMsg::BatteryStatus
            | StreamMsg::EkfStatusReport
            | StreamMsg::ExtendedSysState
            | StreamMsg::ObstacleDistance => Some(StreamGroup::Extra3),
            StreamMsg::HomePosition => None,
        }
    }
}

/// A rate set for one message on one link by SET_MESSAGE_INTERVAL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MessageInterval {
    Disabled,
    Every(Duration),
}

/// One link's telemetry schedule.
#[derive(Clone, Debug)]
pub struct LinkStreams {
    slot: u8,
    group_rate_hz: [Option<f64>; StreamGroup::COUNT],
    message_interval: [Option<MessageInterval>; StreamMsg::COUNT],
    next_due: [Option<Duration>; StreamMsg::COUNT],
}

impl LinkStreams {
    pub fn new(slot: u8) -> Self {
        LinkStreams {
            slot,
            group_rate_hz: [None; StreamGroup::COUNT],
            message_interval: [None; StreamMsg::COUNT],
            next_due: [None; StreamMsg::COUNT],
        }
    }

    pub fn slot(&self) -> u8 {
        self.slot
    }

    /// REQUEST_DATA_STREAM on this link: start at `rate_hz` or stop.
    pub fn request_data_stream(&mut self, stream_id: u8, rate_hz: u16, start: bool) {
        let rate = if start { f64::from(rate_hz) } else { 0.0 };
        for group in StreamGroup::from_data_stream(stream_id) {
            self.group_rate_hz[*group as usize] = Some(rate);
        }
    }

    /// SET_MESSAGE_INTERVAL: `None` returns the message to its group's rate.
    pub fn set_message_interval(&mut self, msg: StreamMsg, interval: Option<MessageInterval>) {
        self.message_interval[msg as usize] = interval;
        self.next_due[msg as usize] = None;
    }

    /// The interval `msg` has on this link now (None: not sent).
    pub fn interval(&self, msg: StreamMsg, slot_rate_hz: impl Fn(StreamGroup) -> f64) -> Option<Duration> {
        match self.message_interval[msg as usize] {
            Some(MessageInterval::Disabled) => None,
            Some(MessageInterval::Every(d)) => Some(d),
            None => {
                let group = msg.group()?;
                let hz = self.group_rate_hz[group as usize].unwrap_or_else(|| slot_rate_hz(group));
                (hz > 0.0).then(|| crate::time::duration_from_secs(1.0 / hz))
            }
        }
    }

    /// Appends the messages due at `wall` and schedules their next time.
    pub fn due(&mut self, wall: Duration, slot_rate_hz: impl Fn(StreamGroup) -> f64, out: &mut Vec<StreamMsg>) {
        for msg in StreamMsg::ALL {
            let Some(interval) = self.interval(msg, &slot_rate_hz) else {
                self.next_due[msg as usize] = None;
                continue;
            };
            let slot = &mut self.next_due[msg as usize];
            match *slot {
                Some(due) if wall < due => {}
                Some(due) => {
                    let next = due + interval;
                    *slot = Some(if next <= wall { wall + interval } else { next });
                    out.push(msg);
                }
                None => {
                    *slot = Some(wall + interval);
                    out.push(msg);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn defaults(group: StreamGroup) -> f64 {
        f64::from(group.default_rate_hz())
    }

    fn count(streams: &mut LinkStreams, msg: StreamMsg, seconds: u64) -> usize {
        let mut out = Vec::new();
        for ms in (0..seconds * 1000).step_by(10) {
            streams.due(Duration::from_millis(ms), defaults, &mut out);
        }
        out.iter().filter(|m| **m == msg).count()
    }

    #[test]
    fn default_rates_follow_the_slot_parameters() {
        let mut s = LinkStreams::new(0);
        assert_eq!(count(&mut s, StreamMsg::GlobalPositionInt, 10), 40);
        let mut s = LinkStreams::new(0);
        assert_eq!(count(&mut s, StreamMsg::SysStatus, 10), 10);
        let mut s = LinkStreams::new(0);
        assert_eq!(count(&mut s, StreamMsg::HomePosition, 10), 0);
        let mut s = LinkStreams::new(0);
        assert_eq!(count(&mut s, StreamMsg::LocalPositionNed, 10), 40);
    }

    #[test]
    fn request_data_stream_changes_a_group_on_this_link() {
        let mut s = LinkStreams::new(0);
        s.request_data_stream(6, 10, true);
        assert_eq!(count(&mut s, StreamMsg::GlobalPositionInt, 10), 100);
        s.request_data_stream(0, 0, false);
        assert_eq!(count(&mut s, StreamMsg::GlobalPositionInt, 10), 0);
        assert_eq!(count(&mut s, StreamMsg::Attitude, 10), 0);
    }

    #[test]
    fn message_interval_overrides_and_resets() {
        let mut s = LinkStreams::new(0);
        s.set_message_interval(
            StreamMsg::Attitude,
            Some(MessageInterval::Every(Duration::from_millis(50))),
        );
        assert_eq!(count(&mut s, StreamMsg::Attitude, 10), 200);
        s.set_message_interval(StreamMsg::Attitude, Some(MessageInterval::Disabled));
        assert_eq!(count(&mut s, StreamMsg::Attitude, 10), 0);
        s.set_message_interval(StreamMsg::Attitude, None);
        assert_eq!(count(&mut s, StreamMsg::Attitude, 10), 40);
    }

    #[test]
    fn message_ids_round_trip() {
        for m in StreamMsg::ALL {
            assert_eq!(StreamMsg::from_message_id(m.message_id()), Some(m));
        }
    }
}
