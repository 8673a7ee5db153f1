//! MAVLink 2 message signing (mavlink.io "Message Signing"), without I/O:
//! the secret key, our signing timestamp and the last timestamp of every
//! stream heard. The wall clock is passed in (time since the Unix epoch),
//! never read here, so every rule is testable.
//!
//! Timestamps are 48-bit counts of 10 µs since 2015-01-01 00:00 UTC. Ours
//! never goes back: at start it is the later of the stored one (plus a
//! margin, see [`SigningState::start`]) and the clock; every frame we sign
//! gets a larger one than the frame before; a correctly signed packet with
//! a later timestamp moves ours up to it.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MAVLinkMessageRaw, MAVLinkV2MessageRaw, Message, calculate_crc, consts};

/// Bytes in a secret key.
pub const KEY_LEN: usize = 32;
/// 10 µs units in a second.
pub const UNITS_PER_S: u64 = 100_000;
/// A stream we have not heard yet is accepted only this close behind our
/// timestamp (one minute, the spec's figure).
pub const NEW_STREAM_WINDOW: u64 = 60 * UNITS_PER_S;
/// Added to the stored timestamp at start: it covers what was signed
/// between the last save and a crash (saves are at most 30 s apart, see
/// [`TimestampSaver`]), so a vehicle whose clock restarts in the past
/// (no RTC) never repeats a timestamp.
pub const START_MARGIN: u64 = 60 * UNITS_PER_S;
/// Seconds from the Unix epoch to 2015-01-01 00:00 UTC.
const UNIX_TO_SIGNING_EPOCH_S: u64 = 1_420_070_400;
const TIMESTAMP_MAX: u64 = (1 << 48) - 1;
/// Streams remembered; beyond this the stalest is forgotten. Only correctly
/// signed packets create streams, so only a key holder can fill the table.
const MAX_STREAMS: usize = 64;

/// A 32-byte signing key. Its `Debug` never shows the bytes.
#[derive(Clone, PartialEq, Eq)]
pub struct SecretKey([u8; KEY_LEN]);

impl SecretKey {
    pub fn new(bytes: [u8; KEY_LEN]) -> Self {
        SecretKey(bytes)
    }

    /// All zeros: the spec's "disable signing" value, never a usable key.
    pub fn is_zero(&self) -> bool {
        self.0.iter().all(|b| *b == 0)
    }

    /// For the key file only.
    pub fn bytes(&self) -> &[u8; KEY_LEN] {
        &self.0
    }
}

impl fmt::Debug for SecretKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("SecretKey(..)")
    }
}

/// The signing timestamp of a wall-clock time (0 before 2015, as a board
/// without a clock reports).
pub fn timestamp_at(since_unix_epoch: Duration) -> u64 {
    let since_2015 = since_unix_epoch.saturating_sub(Duration::from_secs(UNIX_TO_SIGNING_EPOCH_S));
    u64::try_from(since_2015.as_micros() / 10)
        .unwrap_or(TIMESTAMP_MAX)
        .min(TIMESTAMP_MAX)
}

/// What an inbound frame's signature says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No key is set: nothing is checked.
    SigningOff,
    /// Correct signature, newer than anything before from its stream.
    Signed,
    /// No signature: MAVLink 1, or MAVLink 2 without the signed flag.
    Unsigned,
    BadSignature,
    /// Correctly signed but not newer than the last packet of its stream.
    Replayed,
    /// Correctly signed, from a stream not heard before, more than
    /// [`NEW_STREAM_WINDOW`] behind our timestamp.
    OutOfWindow,
}

/// What a SETUP_SIGNING did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyChange {
    Set,
    Disabled,
}

/// (link id in the signature, system id, component id).
type StreamId = (u8, u32, u8);

pub struct SigningState {
    key: Option<SecretKey>,
    /// The last timestamp we signed with or adopted.
    timestamp: u64,
    streams: BTreeMap<StreamId, u64>,
}

impl SigningState {
    /// Signing as stored (key and last saved timestamp) at time `now`.
    pub fn start(key: Option<SecretKey>, stored_timestamp: u64, now: Duration) -> Self {
        let key = key.filter(|k| !k.is_zero());
        let from_store = if stored_timestamp == 0 {
            0
        } else {
            stored_timestamp.saturating_add(START_MARGIN).min(TIMESTAMP_MAX)
        };
        SigningState {
            key,
            timestamp: from_store.max(timestamp_at(now)),
            streams: BTreeMap::new(),
        }
    }

    pub fn is_enabled(&self) -> bool {
        self.key.is_some()
    }

    pub fn key(&self) -> Option<&SecretKey> {
        self.key.as_ref()
    }

    /// Our timestamp: what the next signed frame gets at least, and what
    /// is saved.
    pub fn timestamp(&self) -> u64 {
        self.timestamp
    }

    /// SETUP_SIGNING: an all-zero key disables signing (the spec pairs it
    /// with timestamp 0; a zero key is public, so any zero key disables).
    /// Streams heard under the old key mean nothing under the new one.
    pub fn set_key(&mut self, key: SecretKey, initial_timestamp: u64, now: Duration) -> KeyChange {
        self.streams.clear();
        if key.is_zero() {
            self.key = None;
            return KeyChange::Disabled;
        }
        self.key = Some(key);
        self.timestamp = self
            .timestamp
            .max(initial_timestamp.min(TIMESTAMP_MAX))
            .max(timestamp_at(now));
        KeyChange::Set
    }

    /// Checks an inbound frame and, when it is correctly signed and new,
    /// records its stream's timestamp and adopts a later one as ours.
    pub fn verify(&mut self, frame: &MAVLinkMessageRaw, now: Duration) -> Verdict {
        let Some(key) = &self.key else {
            return Verdict::SigningOff;
        };
        let MAVLinkMessageRaw::V2(raw) = frame else {
            return Verdict::Unsigned;
        };
        if raw.incompatibility_flags() & consts::v2::IFLAG_SIGNED == 0 {
            return Verdict::Unsigned;
        }
        let mut expected = [0u8; consts::v2::SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(key.bytes(), &mut expected);
        // Constant time: the comparison must not tell an attacker how many
        // leading bytes of a forged signature were right.
        let difference = expected
            .iter()
            .zip(raw.signature_value())
            .fold(0u8, |acc, (a, b)| acc | (a ^ b));
        if difference != 0 {
            return Verdict::BadSignature;
        }
        let stamp = raw.signature_timestamp();
        let stream = (raw.signature_link_id(), raw.system_id(), raw.component_id());
        match self.streams.get(&stream) {
            Some(last) if stamp <= *last => return Verdict::Replayed,
            Some(_) => {}
            None => {
                if stamp.saturating_add(NEW_STREAM_WINDOW) < self.now_timestamp(now) {
                    return Verdict::OutOfWindow;
                }
                if self.streams.len() >= MAX_STREAMS
                    && let Some(stalest) = self.streams.iter().min_by_key(|(_, t)| **t).map(|(s, _)| *s)
                {
                    self.streams.remove(&stalest);
                }
            }
        }
        self.streams.insert(stream, stamp);
        self.timestamp = self.timestamp.max(stamp);
        Verdict::Signed
    }

    /// Signs an unsigned MAVLink 2 frame for a link with `link_id`. `None`
    /// when no key is set or the bytes are not an unsigned MAVLink 2 frame
    /// (a forwarded signed frame keeps its sender's signature).
    pub fn sign(&mut self, frame: &[u8], link_id: u8, now: Duration) -> Option<Vec<u8>> {
        let key = self.key.as_ref()?;
        if frame.first() != Some(&mavlink::MAV_STX_V2)
            || frame.len() + consts::v2::SIGNATURE_SIZE > consts::MAX_FRAME_SIZE
        {
            return None;
        }
        let mut buffer = [0u8; consts::MAX_FRAME_SIZE];
        buffer[..frame.len()].copy_from_slice(frame);
        let mut raw = MAVLinkV2MessageRaw::from_bytes_unparsed(buffer);
        let crc_end = consts::STX_SIZE + raw.header().len() + usize::from(raw.payload_length());
        if raw.incompatibility_flags() & consts::v2::IFLAG_SIGNED != 0 || crc_end + consts::CHECKSUM_SIZE != frame.len()
        {
            return None;
        }
        // The flag is inside the CRC, so the CRC changes with it.
        *raw.incompatibility_flags_mut() |= consts::v2::IFLAG_SIGNED;
        let crc = calculate_crc(
            &raw.as_slice()[consts::STX_SIZE..crc_end],
            MavMessage::extra_crc(raw.message_id()),
        );
        raw.as_mut_slice()[crc_end..crc_end + consts::CHECKSUM_SIZE].copy_from_slice(&crc.to_le_bytes());
        let stamp = self
            .timestamp
            .saturating_add(1)
            .max(timestamp_at(now))
            .min(TIMESTAMP_MAX);
        self.timestamp = stamp;
        *raw.signature_link_id_mut() = link_id;
        raw.signature_timestamp_bytes_mut()
            .copy_from_slice(&stamp.to_le_bytes()[..consts::v2::SIGNATURE_TIMESTAMP_SIZE]);
        let mut signature = [0u8; consts::v2::SIGNATURE_VALUE_SIZE];
        raw.calculate_signature(key.bytes(), &mut signature);
        raw.signature_value_mut().copy_from_slice(&signature);
        Some(raw.raw_bytes().to_vec())
    }

    fn now_timestamp(&self, now: Duration) -> u64 {
        self.timestamp.max(timestamp_at(now))
    }
}

/// When to save our timestamp: once it has moved 30 s worth past the saved
/// one (the clock, or a jump adopted from a peer), or 30 s of wall time
/// after a smaller change. With checks every few seconds, what a crash can
/// lose stays under [`START_MARGIN`].
#[derive(Debug)]
pub struct TimestampSaver {
    saved: u64,
    saved_at: Duration,
}

impl TimestampSaver {
    pub const EVERY: Duration = Duration::from_secs(30);
    const STEP: u64 = 30 * UNITS_PER_S;

    pub fn new(saved: u64, now: Duration) -> Self {
        TimestampSaver { saved, saved_at: now }
    }

    /// True when `timestamp` should be written now (and notes it as saved).
    pub fn due(&mut self, timestamp: u64, now: Duration) -> bool {
        let moved = timestamp > self.saved;
        let far = timestamp >= self.saved.saturating_add(Self::STEP);
        let late = now.saturating_sub(self.saved_at) >= Self::EVERY;
        if far || (moved && late) {
            self.saved = timestamp;
            self.saved_at = now;
            return true;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::encode::encode_v2;
    use crate::link::frame::{ReceivedFrame, StreamFramer};
    use mavlink::MavHeader;
    use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, HEARTBEAT_DATA, MavCmd};

    const KEY: [u8; KEY_LEN] = [7; KEY_LEN];
    /// 2026-01-01 00:00 UTC.
    const NOW_S: u64 = 1_767_225_600;

    fn at(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    fn header(sysid: u32, seq: u8) -> MavHeader {
        MavHeader {
            system_id: sysid,
            component_id: 190,
            sequence: seq,
        }
    }

    fn arm_frame(seq: u8) -> Vec<u8> {
        let command = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            target_system: 1,
            target_component: 1,
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            param1: 1.0,
            ..COMMAND_LONG_DATA::default()
        });
        encode_v2(header(255, seq), &command)
    }

    /// The frames the reader makes of `bytes` (the CRC must hold).
    fn read(bytes: &[u8]) -> Vec<ReceivedFrame> {
        let mut framer = StreamFramer::new();
        let mut frames = Vec::new();
        framer.push(bytes, |f| frames.push(f));
        frames
    }

    fn verify_bytes(state: &mut SigningState, bytes: &[u8], now: Duration) -> Verdict {
        let frames = read(bytes);
        assert_eq!(frames.len(), 1, "one CRC-valid frame");
        state.verify(&frames[0].raw, now)
    }

    /// A sender (a GCS) and a receiver (the vehicle) sharing a key.
    fn pair() -> (SigningState, SigningState) {
        let key = SecretKey::new(KEY);
        (
            SigningState::start(Some(key.clone()), 0, at(NOW_S)),
            SigningState::start(Some(key), 0, at(NOW_S)),
        )
    }

    #[test]
    fn a_good_signature_is_accepted_and_the_frame_still_decodes() {
        let (mut gcs, mut vehicle) = pair();
        let signed = gcs.sign(&arm_frame(0), 3, at(NOW_S)).expect("signs");
        assert_eq!(signed.len(), arm_frame(0).len() + consts::v2::SIGNATURE_SIZE);
        let frames = read(&signed);
        assert!(matches!(frames[0].message, Ok(MavMessage::COMMAND_LONG(_))));
        assert_eq!(vehicle.verify(&frames[0].raw, at(NOW_S)), Verdict::Signed);
    }

    #[test]
    fn pymavlink_compatible_layout() {
        // The signature trailer: link id, 48-bit little-endian timestamp,
        // then the signature; the signed flag is set.
        let (mut gcs, _) = pair();
        let signed = gcs.sign(&arm_frame(0), 9, at(NOW_S)).expect("signs");
        assert_eq!(signed[2] & 1, 1);
        let trailer = &signed[signed.len() - 13..];
        assert_eq!(trailer[0], 9);
        let mut stamp = [0u8; 8];
        stamp[..6].copy_from_slice(&trailer[1..7]);
        // One past the clock: the state started at the clock's value.
        assert_eq!(u64::from_le_bytes(stamp), timestamp_at(at(NOW_S)) + 1);
    }

    #[test]
    fn any_flipped_byte_is_rejected() {
        let (mut gcs, _) = pair();
        let signed = gcs.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        let crc_end = signed.len() - consts::v2::SIGNATURE_SIZE - consts::CHECKSUM_SIZE;
        // Payload bytes and signature/timestamp bytes: the CRC does not
        // cover the trailer, so those frames still reach the check.
        let payload_start = 10;
        for index in (payload_start..crc_end).chain(crc_end + consts::CHECKSUM_SIZE..signed.len()) {
            let mut bytes = signed.clone();
            bytes[index] ^= 0x01;
            if index < crc_end {
                // Re-CRC so the framer passes it on: only the signature can
                // catch the change now.
                let extra = MavMessage::extra_crc(76);
                let crc = calculate_crc(&bytes[1..crc_end], extra);
                bytes[crc_end..crc_end + 2].copy_from_slice(&crc.to_le_bytes());
            }
            let (_, mut vehicle) = pair();
            assert_eq!(
                verify_bytes(&mut vehicle, &bytes, at(NOW_S)),
                Verdict::BadSignature,
                "byte {index} flipped"
            );
        }
    }

    #[test]
    fn a_wrong_key_is_a_bad_signature() {
        let mut other = SigningState::start(Some(SecretKey::new([8; KEY_LEN])), 0, at(NOW_S));
        let (_, mut vehicle) = pair();
        let signed = other.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &signed, at(NOW_S)), Verdict::BadSignature);
    }

    #[test]
    fn a_replayed_frame_is_rejected_and_later_ones_pass() {
        let (mut gcs, mut vehicle) = pair();
        let first = gcs.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        let second = gcs.sign(&arm_frame(1), 0, at(NOW_S)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &first, at(NOW_S)), Verdict::Signed);
        assert_eq!(verify_bytes(&mut vehicle, &first, at(NOW_S + 1)), Verdict::Replayed);
        assert_eq!(verify_bytes(&mut vehicle, &second, at(NOW_S + 1)), Verdict::Signed);
        assert_eq!(verify_bytes(&mut vehicle, &first, at(NOW_S + 2)), Verdict::Replayed);
        // The same bytes under another link id are another stream, but the
        // link id is signed: changing it breaks the signature.
        let mut moved = first.clone();
        let link_id_at = moved.len() - consts::v2::SIGNATURE_SIZE;
        moved[link_id_at] = 1;
        assert_eq!(verify_bytes(&mut vehicle, &moved, at(NOW_S + 2)), Verdict::BadSignature);
    }

    #[test]
    fn a_new_stream_more_than_a_minute_old_is_rejected() {
        let key = SecretKey::new(KEY);
        // A sender whose clock is 61 s behind the vehicle's.
        let mut late = SigningState::start(Some(key.clone()), 0, at(NOW_S - 61));
        let mut vehicle = SigningState::start(Some(key.clone()), 0, at(NOW_S));
        let frame = late.sign(&arm_frame(0), 0, at(NOW_S - 61)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &frame, at(NOW_S)), Verdict::OutOfWindow);
        // 59 s behind is inside the window.
        let mut close = SigningState::start(Some(key), 0, at(NOW_S - 59));
        let frame = close.sign(&arm_frame(0), 1, at(NOW_S - 59)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &frame, at(NOW_S)), Verdict::Signed);
    }

    #[test]
    fn a_bad_signature_does_not_move_any_timestamp() {
        let (mut gcs, mut vehicle) = pair();
        let before = vehicle.timestamp();
        let mut forged = gcs.sign(&arm_frame(0), 0, at(NOW_S + 3600)).expect("signs");
        let last = forged.len() - 1;
        forged[last] ^= 0xff;
        assert_eq!(verify_bytes(&mut vehicle, &forged, at(NOW_S)), Verdict::BadSignature);
        assert_eq!(vehicle.timestamp(), before);
        // The genuine frame from the same stream still passes.
        let genuine = gcs.sign(&arm_frame(1), 0, at(NOW_S)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &genuine, at(NOW_S)), Verdict::Signed);
    }

    #[test]
    fn a_later_timestamp_from_a_good_packet_is_adopted() {
        let key = SecretKey::new(KEY);
        let mut ahead = SigningState::start(Some(key.clone()), 0, at(NOW_S + 3600));
        let mut vehicle = SigningState::start(Some(key), 0, at(NOW_S));
        let frame = ahead.sign(&arm_frame(0), 0, at(NOW_S + 3600)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &frame, at(NOW_S)), Verdict::Signed);
        assert_eq!(vehicle.timestamp(), trailer_stamp(&frame));
        assert!(vehicle.timestamp() >= timestamp_at(at(NOW_S + 3600)));
    }

    #[test]
    fn timestamps_strictly_increase_across_a_restart_with_the_store_ahead_of_the_clock() {
        let key = SecretKey::new(KEY);
        let mut before = SigningState::start(Some(key.clone()), 0, at(NOW_S));
        let mut stamps = Vec::new();
        // A burst faster than the clock: each frame still gets a new stamp.
        for seq in 0..100 {
            let frame = before.sign(&arm_frame(seq), 0, at(NOW_S)).expect("signs");
            stamps.push(trailer_stamp(&frame));
        }
        let stored = before.timestamp();
        // The process restarts with a clock an hour behind (no RTC).
        let mut after = SigningState::start(Some(key), stored, at(NOW_S - 3600));
        for seq in 0..100 {
            let frame = after.sign(&arm_frame(seq), 0, at(NOW_S - 3600)).expect("signs");
            stamps.push(trailer_stamp(&frame));
        }
        assert!(stamps.windows(2).all(|w| w[0] < w[1]), "not strictly increasing");
        assert!(stamps[100] > stored + START_MARGIN);
    }

    fn trailer_stamp(frame: &[u8]) -> u64 {
        let mut stamp = [0u8; 8];
        let start = frame.len() - 12;
        stamp[..6].copy_from_slice(&frame[start..start + 6]);
        u64::from_le_bytes(stamp)
    }

    #[test]
    fn an_all_zero_key_disables_signing() {
        let (mut gcs, mut vehicle) = pair();
        assert_eq!(
            vehicle.set_key(SecretKey::new([0; KEY_LEN]), 0, at(NOW_S)),
            KeyChange::Disabled
        );
        assert!(!vehicle.is_enabled());
        assert_eq!(vehicle.sign(&arm_frame(0), 0, at(NOW_S)), None);
        let signed = gcs.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &signed, at(NOW_S)), Verdict::SigningOff);
        // A stored zero key is no key either.
        let stored = SigningState::start(Some(SecretKey::new([0; KEY_LEN])), 5, at(NOW_S));
        assert!(!stored.is_enabled());
    }

    #[test]
    fn a_new_key_replaces_the_old_and_keeps_the_timestamp_rising() {
        let (_, mut vehicle) = pair();
        let before = vehicle.timestamp();
        let new_key = SecretKey::new([9; KEY_LEN]);
        assert_eq!(vehicle.set_key(new_key.clone(), 1, at(NOW_S)), KeyChange::Set);
        assert!(vehicle.timestamp() >= before);
        let mut gcs = SigningState::start(Some(new_key), 0, at(NOW_S));
        let signed = gcs.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        assert_eq!(verify_bytes(&mut vehicle, &signed, at(NOW_S)), Verdict::Signed);
    }

    #[test]
    fn unsigned_and_mavlink1_frames_are_unsigned() {
        let (_, mut vehicle) = pair();
        assert_eq!(verify_bytes(&mut vehicle, &arm_frame(0), at(NOW_S)), Verdict::Unsigned);
        assert_eq!(
            verify_bytes(&mut vehicle, &v1_heartbeat(), at(NOW_S)),
            Verdict::Unsigned
        );
        let (mut off, _) = pair();
        off.set_key(SecretKey::new([0; KEY_LEN]), 0, at(NOW_S));
        assert_eq!(verify_bytes(&mut off, &arm_frame(0), at(NOW_S)), Verdict::SigningOff);
    }

    fn v1_heartbeat() -> Vec<u8> {
        let mut raw = mavlink::MAVLinkV1MessageRaw::new();
        raw.serialize_message(header(255, 0), &heartbeat());
        raw.raw_bytes().to_vec()
    }

    #[test]
    fn signed_or_foreign_bytes_are_not_signed_again() {
        let (mut gcs, _) = pair();
        let signed = gcs.sign(&arm_frame(0), 0, at(NOW_S)).expect("signs");
        assert_eq!(gcs.sign(&signed, 0, at(NOW_S)), None);
        assert_eq!(gcs.sign(&[0xfe, 0, 0], 0, at(NOW_S)), None);
        assert_eq!(gcs.sign(&arm_frame(0)[..10], 0, at(NOW_S)), None);
    }

    #[test]
    fn the_stream_table_stays_bounded() {
        let key = SecretKey::new(KEY);
        let mut vehicle = SigningState::start(Some(key.clone()), 0, at(NOW_S));
        for sysid in 0..(MAX_STREAMS as u32 + 10) {
            let mut gcs = SigningState::start(Some(key.clone()), 0, at(NOW_S));
            let frame = gcs.sign(&encode_v2(header(sysid + 1, 0), &heartbeat()), 0, at(NOW_S));
            let frame = frame.expect("signs");
            assert_eq!(verify_bytes(&mut vehicle, &frame, at(NOW_S)), Verdict::Signed);
        }
        assert_eq!(vehicle.streams.len(), MAX_STREAMS);
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())
    }

    #[test]
    fn the_timestamp_is_saved_every_30_s_or_after_a_jump() {
        let start = timestamp_at(at(NOW_S));
        let mut saver = TimestampSaver::new(start, at(10));
        assert!(!saver.due(start + 10, at(20)), "small change, not yet 30 s");
        assert!(saver.due(start + 10, at(40)), "30 s after the last save");
        assert!(!saver.due(start + 10, at(100)), "unchanged: nothing to save");
        assert!(saver.due(start + 10 + 30 * UNITS_PER_S, at(101)), "a 30 s jump");
    }

    #[test]
    fn the_key_never_shows_in_debug_output() {
        let key = SecretKey::new([0xab; KEY_LEN]);
        let text = format!("{key:?}");
        assert!(!text.contains("ab") && !text.contains("171"), "{text}");
    }
}
