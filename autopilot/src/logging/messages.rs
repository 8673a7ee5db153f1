//! The message types Furrow logs. ArduPilot Rover's names, fields and units
//! where the concept matches (so MAVExplorer's graphs and users' scripts
//! find them); Furrow's own for what Rover has no record of.

use super::format::MessageDef;

const fn def(
    id: u8,
    name: &'static str,
    format: &'static str,
    labels: &'static str,
    units: &'static str,
    mults: &'static str,
) -> MessageDef {
    MessageDef {
        id,
        name,
        format,
        labels,
        units,
        mults,
    }
}

/// A parameter's value at the start of the log.
pub const PARM: MessageDef = def(64, "PARM", "QNff", "TimeUS,Name,Value,Default", "s---", "F---");
/// The mode (ArduPilot Rover's numbers) and why it changed.
pub const MODE: MessageDef = def(65, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn", "s---", "F---");
/// A STATUSTEXT the vehicle sent.
pub const MSG: MessageDef = def(66, "MSG", "QZ", "TimeUS,Message", "s-", "F-");
/// An event (ArduPilot's ids: 10 armed, 11 disarmed).
pub const EV: MessageDef = def(67, "EV", "QB", "TimeUS,Id", "s-", "F-");
/// A failsafe raised (code 1) or cleared (code 0), by subsystem.
pub const ERR: MessageDef = def(68, "ERR", "QBB", "TimeUS,Subsys,ECode", "s--", "F--");
/// A mission item of the mission in force.
pub const CMD: MessageDef = def(
    69,
    "CMD",
    "QHHHffffLLfB",
    "TimeUS,CTot,CNum,CId,Prm1,Prm2,Prm3,Prm4,Lat,Lng,Alt,Frame",
    "s-------DUm-",
    "F-------GG0-",
);
/// A GNSS sample as received.
pub const GPS: MessageDef = def(
    70,
    "GPS",
    "QBBIHBcLLeffffB",
    "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U",
    "s#---SmDUmnhnh-",
    "F--C--BGGB000--",
);
/// The estimated position.
pub const POS: MessageDef = def(
    71,
    "POS",
    "QLLfff",
    "TimeUS,Lat,Lng,Alt,RelHomeAlt,RelOriginAlt",
    "sDUmmm",
    "FGG000",
);
/// Attitude: a ground vehicle has only yaw (true heading) and its demand.
pub const ATT: MessageDef = def(
    72,
    "ATT",
    "QccccCCCCB",
    "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF",
    "sddddhhdh-",
    "FBBBBBBBB-",
);
/// Steering: normalised demand, lateral acceleration and turn rate.
pub const STER: MessageDef = def(
    73,
    "STER",
    "Qhfffff",
    "TimeUS,SteerIn,SteerOut,DesLatAcc,LatAcc,DesTurnRate,TurnRate",
    "s--ookk",
    "F--0000",
);
/// Throttle and speed.
pub const THR: MessageDef = def(
    74,
    "THR",
    "Qhffff",
    "TimeUS,ThrIn,ThrOut,DesSpeed,Speed,AccY",
    "s--nno",
    "F--000",
);
/// Navigation: distance and bearing to the waypoint, heading demand, and
/// the cross-track error (positive: right of the path).
pub const NTUN: MessageDef = def(
    75,
    "NTUN",
    "Qfffff",
    "TimeUS,WpDist,WpBrg,DesYaw,Yaw,XTrack",
    "smhhhm",
    "F00000",
);
/// The speed controller (ArduPilot's throttle-speed PID): target and actual
/// speed, error, the P, I and D terms and the feed-forward throttle.
pub const PIDA: MessageDef = def(
    76,
    "PIDA",
    "Qfffffff",
    "TimeUS,Tar,Act,Err,P,I,D,FF",
    "snnn----",
    "F000----",
);
/// The battery.
pub const BAT: MessageDef = def(
    77,
    "BAT",
    "QBfffffcfB",
    "TimeUS,Inst,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res,RemPct",
    "s#vvAaXO-%",
    "F-000?0B-?",
);
/// Furrow: the preview tracker's lateral PID on the lateral error at the
/// preview point (target 0), with the curvature feed-forward.
pub const PIDL: MessageDef = def(
    80,
    "PIDL",
    "Qfffffff",
    "TimeUS,Tar,Act,Err,P,I,D,FF",
    "smmmrrrr",
    "F0000000",
);
/// Furrow: the preview tracker's yaw PID on the heading error at the
/// preview point.
pub const PIDY: MessageDef = def(
    81,
    "PIDY",
    "Qfffffff",
    "TimeUS,Tar,Act,Err,P,I,D,FF",
    "srrrrrrr",
    "F0000000",
);
/// Furrow: the preview point (local north/east of the frame origin), how far
/// ahead it is, and the errors the tracker steers on there.
pub const PREV: MessageDef = def(
    82,
    "PREV",
    "Qffffffb",
    "TimeUS,PN,PE,Dist,LatErr,YawErr,Steer,Capt",
    "smmmmrr-",
    "F000000-",
);
/// Furrow: the filter's innovations (GNSS position north/east, velocity
/// north/east, heading) and test ratios (1 = at the gate).
pub const EKFI: MessageDef = def(
    83,
    "EKFI",
    "QffffffffB",
    "TimeUS,IPN,IPE,IVN,IVE,IYaw,TRP,TRV,TRY,Hlth",
    "smmnnr----",
    "F00000----",
);
/// Furrow: the obstacle pipeline's state (a stop for an obstacle is
/// Stop = 1).
pub const OBST: MessageDef = def(
    84,
    "OBST",
    "QBBBBHHff",
    "TimeUS,En,Fresh,Stop,Detr,Conf,Tent,Near,SpdLim",
    "s------mn",
    "F------00",
);
/// Furrow: one obstacle track (local north/east, velocity, size).
pub const OBTK: MessageDef = def(
    85,
    "OBTK",
    "QIBffffff",
    "TimeUS,Id,Conf,PN,PE,VN,VE,Rad,Age",
    "s--mmnnms",
    "F--000000",
);
/// Furrow: how a precision stop ended (along and across the path, yaw).
pub const PSTP: MessageDef = def(
    86,
    "PSTP",
    "QhffffB",
    "TimeUS,Seq,Along,XTrack,YawErr,PosErr,Ok",
    "s-mmrm-",
    "F-0000-",
);

/// Every message type a log holds, described in its header.
pub const ALL: &[MessageDef] = &[
    PARM, MODE, MSG, EV, ERR, CMD, GPS, POS, ATT, STER, THR, NTUN, PIDA, BAT, PIDL, PIDY, PREV, EKFI, OBST, OBTK, PSTP,
];

/// ArduPilot's event ids.
pub const EV_ARMED: u8 = 10;
pub const EV_DISARMED: u8 = 11;

#[cfg(test)]
mod tests {
    use super::super::format::{MULTS, UNITS, field_size};
    use super::*;

    #[test]
    fn every_message_is_consistent_and_unique() {
        let mut ids = std::collections::BTreeSet::new();
        let mut names = std::collections::BTreeSet::new();
        for d in ALL {
            assert!(ids.insert(d.id), "{} id reused", d.name);
            assert!(names.insert(d.name), "{} twice", d.name);
            assert!(
                d.name.len() <= 4 && d.format.len() <= 16 && d.labels.len() <= 64,
                "{}",
                d.name
            );
            assert!(d.format.chars().all(|c| field_size(c).is_some()), "{}", d.name);
            let n = d.format.len();
            assert_eq!(d.labels.split(',').count(), n, "{} labels", d.name);
            assert_eq!(d.units.len(), n, "{} units", d.name);
            assert_eq!(d.mults.len(), n, "{} mults", d.name);
            assert!(
                d.units.chars().all(|u| UNITS.iter().any(|x| x.0 == u)),
                "{} unit",
                d.name
            );
            assert!(
                d.mults.chars().all(|m| MULTS.iter().any(|x| x.0 == m)),
                "{} mult",
                d.name
            );
            assert!(d.length() <= 255, "{}", d.name);
        }
    }
}
