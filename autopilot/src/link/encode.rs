//! Messages → bytes. Furrow always sends MAVLink 2.

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MAVLinkV2MessageRaw, MavHeader, calculate_crc};

/// One MAVLink 2 frame.
pub fn encode_v2(header: MavHeader, message: &MavMessage) -> Vec<u8> {
    let mut raw = MAVLinkV2MessageRaw::new();
    raw.serialize_message(header, message);
    raw.raw_bytes().to_vec()
}

/// COMMAND_ACK for a command id the dialect does not know (its COMMAND_LONG
/// or COMMAND_INT cannot be decoded into a typed message, so the ACK cannot
/// be built as one either). Payload per common.xml, trailing zeros trimmed
/// as MAVLink 2 requires.
pub fn encode_raw_command_ack(
    header: MavHeader,
    command: u16,
    result: u8,
    target_system: u8,
    target_component: u8,
) -> Vec<u8> {
    const COMMAND_ACK_ID: u32 = 77;
    const COMMAND_ACK_CRC_EXTRA: u8 = 143;
    let mut payload = vec![0u8; 10];
    payload[0..2].copy_from_slice(&command.to_le_bytes());
    payload[2] = result;
    payload[3] = 0; // progress
    payload[4..8].copy_from_slice(&0i32.to_le_bytes()); // result_param2
    payload[8] = target_system;
    payload[9] = target_component;
    encode_raw_v2(header, COMMAND_ACK_ID, COMMAND_ACK_CRC_EXTRA, payload)
}

/// MISSION_ACK answering a mission message whose `mission_type` the dialect
/// does not know (so neither it nor its ACK can be typed messages): the
/// type is echoed as it came, as ArduPilot does.
pub fn encode_raw_mission_ack(
    header: MavHeader,
    result: u8,
    mission_type: u8,
    target_system: u8,
    target_component: u8,
) -> Vec<u8> {
    const MISSION_ACK_ID: u32 = 47;
    const MISSION_ACK_CRC_EXTRA: u8 = 153;
    // target_system, target_component, type, then the extensions
    // mission_type and opaque_id (0).
    let payload = vec![target_system, target_component, result, mission_type, 0, 0, 0, 0];
    encode_raw_v2(header, MISSION_ACK_ID, MISSION_ACK_CRC_EXTRA, payload)
}

/// A MAVLink 2 frame around `payload` (trailing zeros trimmed, as MAVLink 2
/// requires).
fn encode_raw_v2(header: MavHeader, message_id: u32, crc_extra: u8, mut payload: Vec<u8>) -> Vec<u8> {
    while payload.len() > 1 && payload.last() == Some(&0) {
        payload.pop();
    }
    let mut frame = vec![
        0xfd,
        payload.len() as u8,
        0,
        0,
        header.sequence,
        header.system_id as u8,
        header.component_id,
        (message_id & 0xff) as u8,
        ((message_id >> 8) & 0xff) as u8,
        ((message_id >> 16) & 0xff) as u8,
    ];
    frame.extend_from_slice(&payload);
    let crc = calculate_crc(&frame[1..], crc_extra);
    frame.extend_from_slice(&crc.to_le_bytes());
    frame
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::frame::StreamFramer;
    use mavlink::dialects::ardupilotmega::{MavMissionResult, MavMissionType, MavResult};

    #[test]
    fn raw_command_ack_decodes_as_a_command_ack() {
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 9,
        };
        // 400 (ARM_DISARM) so the typed decoder can check every field.
        let bytes = encode_raw_command_ack(header, 400, MavResult::MAV_RESULT_UNSUPPORTED as u8, 255, 190);
        let mut framer = StreamFramer::new();
        let mut got = None;
        framer.push(&bytes, |f| got = Some(f.message.expect("decodes")));
        let Some(MavMessage::COMMAND_ACK(ack)) = got else {
            panic!("no ack")
        };
        assert_eq!(ack.command as u16, 400);
        assert_eq!(ack.result, MavResult::MAV_RESULT_UNSUPPORTED);
        assert_eq!((ack.target_system, ack.target_component), (255, 190));
    }

    #[test]
    fn raw_mission_ack_decodes_as_a_mission_ack() {
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 3,
        };
        // A known type (2, rally) so the typed decoder can check every field.
        let bytes = encode_raw_mission_ack(header, MavMissionResult::MAV_MISSION_UNSUPPORTED as u8, 2, 255, 190);
        let mut framer = StreamFramer::new();
        let mut got = None;
        framer.push(&bytes, |f| got = Some(f.message.expect("decodes")));
        let Some(MavMessage::MISSION_ACK(ack)) = got else {
            panic!("no ack")
        };
        assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_UNSUPPORTED);
        assert_eq!(ack.mission_type, MavMissionType::MAV_MISSION_TYPE_RALLY);
        assert_eq!((ack.target_system, ack.target_component), (255, 190));
    }
}
