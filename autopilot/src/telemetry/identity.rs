//! HEARTBEAT, AUTOPILOT_VERSION and PROTOCOL_VERSION: how a ground station
//! recognises Furrow as an ArduPilot Rover (docs/architecture.md §MAVLink identity).
//!
//! PROTOCOL_VERSION is deprecated (2025-11) but QGroundControl still asks for
//! it and falls back to MAVLink 1 when it gets no answer.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::{
    AUTOPILOT_VERSION_DATA, HEARTBEAT_DATA, MavAutopilot, MavModeFlag, MavProtocolCapability, MavState, MavType,
    PROTOCOL_VERSION_DATA,
};

use crate::modes::Mode;

/// What HEARTBEAT reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VehicleStatus {
    pub mode: Mode,
    pub armed: bool,
    /// A failsafe is active (HEARTBEAT system_status CRITICAL).
    pub failsafe: bool,
}

/// HEARTBEAT as ArduPilot Rover sends it (`GCS_MAVLINK_Rover::base_mode`,
/// `vehicle_system_status`).
pub fn heartbeat(status: &VehicleStatus) -> HEARTBEAT_DATA {
    let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if status.mode.has_manual_input() {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED;
    }
    if status.mode.is_autopilot() {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED;
    }
    if status.armed && status.mode != Mode::Initialising {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    let system_status = if status.failsafe {
        MavState::MAV_STATE_CRITICAL
    } else if status.mode == Mode::Initialising {
        MavState::MAV_STATE_CALIBRATING
    } else if status.mode == Mode::Hold {
        MavState::MAV_STATE_STANDBY
    } else {
        MavState::MAV_STATE_ACTIVE
    };
    HEARTBEAT_DATA {
        custom_mode: status.mode.number(),
        mavtype: MavType::MAV_TYPE_GROUND_ROVER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode,
        system_status,
        mavlink_version: 3,
    }
}

/// The protocol capabilities Furrow implements. Bits are added here as the
/// services land (parameters, missions, fence, rally).
pub fn capabilities() -> MavProtocolCapability {
    MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        | MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
}

/// The build's git hash, eight lowercase hex digits (from build.rs).
pub const GIT_HASH: &str = env!("FURROW_GIT_HASH");

/// `major.minor.patch` of this build in ArduPilot's packing
/// (`major<<24 | minor<<16 | patch<<8 | type`, type 0 =
/// FIRMWARE_VERSION_TYPE_DEV).
pub fn packed_version() -> u32 {
    let part = |s: &str| s.parse::<u32>().unwrap_or(0) & 0xff;
    let major = part(env!("CARGO_PKG_VERSION_MAJOR"));
    let minor = part(env!("CARGO_PKG_VERSION_MINOR"));
    let patch = part(env!("CARGO_PKG_VERSION_PATCH"));
    (major << 24) | (minor << 16) | (patch << 8)
}

/// AUTOPILOT_VERSION as ArduPilot fills it: the git hash's first eight
/// characters (ASCII, as ArduPilot's `fw_hash_str`) in
/// `flight_custom_version`.
pub fn autopilot_version(sysid: u8) -> AUTOPILOT_VERSION_DATA {
    let mut custom = [b'0'; 8];
    for (byte, hex) in custom.iter_mut().zip(GIT_HASH.bytes()) {
        *byte = hex;
    }
    AUTOPILOT_VERSION_DATA {
        capabilities: capabilities(),
        uid: u64::from(sysid),
        flight_sw_version: packed_version(),
        middleware_sw_version: 0,
        os_sw_version: 0,
        board_version: 0,
        vendor_id: 0,
        product_id: 0,
        flight_custom_version: custom,
        middleware_custom_version: [0; 8],
        os_custom_version: [0; 8],
        uid2: [0; 18],
    }
}

pub fn protocol_version() -> PROTOCOL_VERSION_DATA {
    PROTOCOL_VERSION_DATA {
        version: 200,
        min_version: 100,
        max_version: 200,
        spec_version_hash: [0; 8],
        library_version_hash: [0; 8],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn armed_guided_rover() {
        let hb = heartbeat(&VehicleStatus {
            mode: Mode::Guided,
            armed: true,
            failsafe: false,
        });
        assert_eq!(hb.custom_mode, 15);
        assert_eq!(hb.mavtype, MavType::MAV_TYPE_GROUND_ROVER);
        assert_eq!(hb.autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
        assert!(
            hb.base_mode
                .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED | MavModeFlag::MAV_MODE_FLAG_GUIDED_ENABLED)
        );
        assert_eq!(hb.system_status, MavState::MAV_STATE_ACTIVE);
    }

    #[test]
    fn version_is_packed_as_ardupilot_and_the_custom_version_is_the_git_hash() {
        let v = autopilot_version(1);
        let [major, minor, patch, kind] = v.flight_sw_version.to_be_bytes();
        let expect = |s: &str| s.parse::<u8>().unwrap();
        assert_eq!(major, expect(env!("CARGO_PKG_VERSION_MAJOR")));
        assert_eq!(minor, expect(env!("CARGO_PKG_VERSION_MINOR")));
        assert_eq!(patch, expect(env!("CARGO_PKG_VERSION_PATCH")));
        assert_eq!(kind, 0, "FIRMWARE_VERSION_TYPE_DEV");
        assert_eq!(GIT_HASH.len(), 8);
        assert_eq!(&v.flight_custom_version[..], GIT_HASH.as_bytes());
        assert!(
            v.flight_custom_version.iter().all(u8::is_ascii_hexdigit),
            "no NUL bytes"
        );
        // Built in a checkout: the hash is the checkout's (a prefix of HEAD).
        if let Ok(out) = std::process::Command::new("git").args(["rev-parse", "HEAD"]).output() {
            let head = String::from_utf8_lossy(&out.stdout);
            if out.status.success() && std::env::var("FURROW_GIT_HASH").is_err() {
                assert!(head.starts_with(GIT_HASH), "{head} vs {GIT_HASH}");
            }
        }
    }

    #[test]
    fn disarmed_hold_is_standby() {
        let hb = heartbeat(&VehicleStatus {
            mode: Mode::Hold,
            armed: false,
            failsafe: false,
        });
        assert!(!hb.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED));
        assert_eq!(hb.system_status, MavState::MAV_STATE_STANDBY);
        let hb = heartbeat(&VehicleStatus {
            mode: Mode::Manual,
            armed: false,
            failsafe: true,
        });
        assert!(hb.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_MANUAL_INPUT_ENABLED));
        assert_eq!(hb.system_status, MavState::MAV_STATE_CRITICAL);
    }
}
