//! Reassembly of RTK corrections that a GCS injects over MAVLink
//! (`GPS_RTCM_DATA`, message 233), plus the RTCM 3 frame check both the
//! reassembler and the NTRIP client use. Sans-IO: bytes in, messages out.
//!
//! # Wire rule (MAVLink common.xml)
//! `flags` bit 0 = fragmented, bits 1–2 = fragment id (0..=3), bits 3–7 =
//! sequence id of the whole message; `len` ≤ 180. A fragmented message is
//! complete when all fragments before the first one shorter than 180 bytes
//! are present, or when all four (full) fragments are present. A message
//! that is an exact multiple of 180 bytes (and shorter than 720) therefore
//! needs a trailing zero-length fragment.
//!
//! # What this implements (ArduPilot `AP_GPS::handle_gps_rtcm_fragment`,
//! plus the differences marked ≠)
//! - Unfragmented data is a complete message at once and does not touch a
//!   pending fragmented one. Zero-length messages are ignored.
//! - Fragments may arrive in any order. A fragment with a new sequence id
//!   ends the pending message: it is dropped (`dropped_incomplete`).
//! - A fragment equal (same sequence, id and bytes) to one already held is a
//!   duplicate and ignored (`duplicates`). ≠ ArduPilot forgets a message
//!   once it is complete, so a late copy of it starts a fresh partial that
//!   either completes again (injected twice) or supersedes the message
//!   being assembled; here the last [`RECENT_MESSAGES_REMEMBERED`]
//!   completed messages are remembered, so their late copies (a slower
//!   redundant link) are duplicates too.
//! - A fragment that cannot belong to the pending message (same id, other
//!   bytes; beyond the short fragment that ended it; a second short one)
//!   drops the pending message and starts a new one with itself, as
//!   ArduPilot does for the first case.
//! - `len` > 180 is rejected (`rejected`).
//! - ≠ Senders that omit the zero-length terminator: QGroundControl's
//!   `RTCMMavlink` (2024 releases) fragments anything ≥ 180 bytes and never
//!   sends one, so even a single 180-byte message is left pending (its
//!   newer code adds the terminator); MAVProxy's current DGPS module sends
//!   none either (an older version did). ArduPilot drops those messages. Here
//!   a pending message made only of full fragments 0..n is passed on when a
//!   new sequence id supersedes it, if its bytes are whole RTCM 3 frames
//!   with good CRCs (counted in `unterminated`); anything else is dropped.
//!   That costs one message of latency and cannot pass on a truncated frame.
//!
//! Where duplicates come from: neither QGroundControl (one copy per vehicle
//! link, deduplicated by link) nor MAVProxy sends a message twice; copies
//! appear when corrections travel over redundant links (Wi-Fi plus a SiK
//! radio, several MAVLink routers), the case ArduPilot PR #21218 fixed.
//! Copies of unfragmented messages cannot be told apart from a repeated
//! message (many senders leave the sequence id at 0 for them, and 1005 base
//! positions repeat byte for byte) and are passed on; GNSS receivers accept
//! a repeated RTCM message.

use std::collections::VecDeque;

/// Largest `data` payload of one `GPS_RTCM_DATA`.
pub const RTCM_FRAGMENT_MAX_LEN: usize = 180;
/// The fragment id has two bits.
pub const RTCM_MAX_FRAGMENTS: usize = 4;
/// Largest message that can be carried in fragments.
pub const RTCM_MAX_MESSAGE_LEN: usize = RTCM_FRAGMENT_MAX_LEN * RTCM_MAX_FRAGMENTS;
/// Completed fragmented messages kept to recognise late copies. A quarter
/// of the 32 sequence ids: a copy older than that is not expected, and a
/// remembered one is only matched with identical bytes, so a reused
/// sequence id with new content is still a new message.
pub const RECENT_MESSAGES_REMEMBERED: usize = 8;

/// Counters since the reassembler was made; all monotonic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RtcmStats {
    /// Complete messages passed on (unfragmented ones included).
    pub messages: u64,
    /// Fragments taken into a message (not duplicates, not rejected).
    pub fragments: u64,
    /// Incomplete messages discarded because another one started.
    pub dropped_incomplete: u64,
    /// Packets with `len` > 180.
    pub rejected: u64,
    /// Fragments already held (or part of the last completed message).
    pub duplicates: u64,
    /// Messages without their zero-length terminator passed on when the next
    /// sequence id arrived (also counted in `messages`).
    pub unterminated: u64,
}

/// One message's fragments as they arrive.
#[derive(Clone, Debug)]
struct Assembly {
    sequence: u8,
    fragments: [Option<Vec<u8>>; RTCM_MAX_FRAGMENTS],
    /// Id of the fragment shorter than 180 bytes, once it has arrived.
    last_id: Option<usize>,
}

impl Assembly {
    fn new(sequence: u8) -> Self {
        Self {
            sequence,
            fragments: Default::default(),
            last_id: None,
        }
    }

    fn holds(&self, id: usize, data: &[u8]) -> bool {
        self.fragments[id].as_deref() == Some(data)
    }

    /// Whether `data` as fragment `id` contradicts what is held.
    fn conflicts(&self, id: usize, data: &[u8]) -> bool {
        if self.fragments[id].is_some() {
            return true;
        }
        let short = data.len() < RTCM_FRAGMENT_MAX_LEN;
        match self.last_id {
            Some(last) => id > last || short,
            None => short && self.fragments[id + 1..].iter().any(Option::is_some),
        }
    }

    fn insert(&mut self, id: usize, data: &[u8]) {
        self.fragments[id] = Some(data.to_vec());
        if data.len() < RTCM_FRAGMENT_MAX_LEN {
            self.last_id = Some(id);
        }
    }

    /// Number of fragments making up the message, once all are here.
    fn complete_count(&self) -> Option<usize> {
        let count = match self.last_id {
            Some(last) => last + 1,
            None => RTCM_MAX_FRAGMENTS,
        };
        self.fragments[..count].iter().all(Option::is_some).then_some(count)
    }

    /// Full fragments 0..n with nothing after them: an unterminated message
    /// if the sender skipped the zero-length fragment.
    fn full_prefix_count(&self) -> Option<usize> {
        if self.last_id.is_some() {
            return None;
        }
        let n = self.fragments.iter().take_while(|f| f.is_some()).count();
        (n > 0 && self.fragments[n..].iter().all(Option::is_none)).then_some(n)
    }

    fn concat(&self, count: usize) -> Vec<u8> {
        self.fragments[..count].iter().flatten().flatten().copied().collect()
    }
}

/// Turns `GPS_RTCM_DATA` packets back into the messages the GCS split.
#[derive(Clone, Debug, Default)]
pub struct RtcmReassembler {
    pending: Option<Assembly>,
    /// Newest last.
    recent: VecDeque<Assembly>,
    stats: RtcmStats,
}

impl RtcmReassembler {
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes one packet (`data` = the first `len` bytes of its payload) and
    /// appends any message it completes to `out`: none, one, or two when it
    /// also passes on an unterminated predecessor (that one first).
    pub fn push(&mut self, flags: u8, data: &[u8], out: &mut Vec<Vec<u8>>) {
        if data.len() > RTCM_FRAGMENT_MAX_LEN {
            self.stats.rejected += 1;
            return;
        }
        if flags & 1 == 0 {
            self.emit(data.to_vec(), out);
            return;
        }
        let id = usize::from((flags >> 1) & 0x03);
        let sequence = flags >> 3;
        let is_copy = |a: &Assembly| a.sequence == sequence && a.holds(id, data);
        if self.pending.iter().chain(&self.recent).any(is_copy) {
            self.stats.duplicates += 1;
            return;
        }
        if let Some(pending) = self.pending.take() {
            if pending.sequence == sequence && !pending.conflicts(id, data) {
                self.pending = Some(pending);
            } else {
                self.supersede(pending, sequence, out);
            }
        }
        let assembly = self.pending.get_or_insert_with(|| Assembly::new(sequence));
        assembly.insert(id, data);
        self.stats.fragments += 1;
        if let Some(count) = assembly.complete_count() {
            let message = assembly.concat(count);
            if let Some(done) = self.pending.take() {
                self.remember(done);
            }
            self.emit(message, out);
        }
    }

    pub fn stats(&self) -> RtcmStats {
        self.stats
    }

    fn supersede(&mut self, old: Assembly, new_sequence: u8, out: &mut Vec<Vec<u8>>) {
        if old.sequence != new_sequence
            && let Some(count) = old.full_prefix_count()
        {
            let message = old.concat(count);
            if is_whole_rtcm3_frames(&message) {
                self.stats.unterminated += 1;
                self.remember(old);
                self.emit(message, out);
                return;
            }
        }
        self.stats.dropped_incomplete += 1;
    }

    fn remember(&mut self, done: Assembly) {
        if self.recent.len() == RECENT_MESSAGES_REMEMBERED {
            self.recent.pop_front();
        }
        self.recent.push_back(done);
    }

    fn emit(&mut self, message: Vec<u8>, out: &mut Vec<Vec<u8>>) {
        if !message.is_empty() {
            self.stats.messages += 1;
            out.push(message);
        }
    }
}

/// RTCM 3 frame preamble.
pub const RTCM3_PREAMBLE: u8 = 0xD3;
/// Preamble and 10-bit length (3 bytes) plus CRC-24Q (3 bytes).
pub const RTCM3_OVERHEAD: usize = 6;

/// CRC-24Q (Qualcomm), as RTCM 3 uses over the preamble, length and payload.
pub fn crc24q(bytes: &[u8]) -> u32 {
    const POLY: u32 = 0x0186_4CFB;
    let mut crc: u32 = 0;
    for &b in bytes {
        crc ^= u32::from(b) << 16;
        for _ in 0..8 {
            crc <<= 1;
            if crc & 0x0100_0000 != 0 {
                crc ^= POLY;
            }
        }
    }
    crc & 0x00FF_FFFF
}

/// What the start of a byte buffer holds, read as RTCM 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rtcm3Frame {
    /// A whole frame of this many bytes (overhead included) with a good CRC.
    Valid(usize),
    /// A whole frame of this many bytes whose CRC does not match.
    BadCrc(usize),
    /// Starts like a frame but more bytes are needed.
    Incomplete,
    /// No frame starts here (wrong preamble or reserved length bits set).
    NotAFrame,
}

/// Reads the frame at the start of `bytes`.
pub fn rtcm3_frame_at(bytes: &[u8]) -> Rtcm3Frame {
    match bytes {
        [] => Rtcm3Frame::Incomplete,
        [first, ..] if *first != RTCM3_PREAMBLE => Rtcm3Frame::NotAFrame,
        [_] | [_, _] => Rtcm3Frame::Incomplete,
        [_, high, low, ..] => {
            // The six bits above the length are reserved as zero; checking
            // them halves false preamble matches inside binary data.
            if high & 0xFC != 0 {
                return Rtcm3Frame::NotAFrame;
            }
            let payload_len = usize::from(high & 0x03) << 8 | usize::from(*low);
            let frame_len = payload_len + RTCM3_OVERHEAD;
            if bytes.len() < frame_len {
                return Rtcm3Frame::Incomplete;
            }
            let body_len = frame_len - 3;
            let sent = bytes[body_len..frame_len]
                .iter()
                .fold(0u32, |acc, &b| acc << 8 | u32::from(b));
            if crc24q(&bytes[..body_len]) == sent {
                Rtcm3Frame::Valid(frame_len)
            } else {
                Rtcm3Frame::BadCrc(frame_len)
            }
        }
    }
}

/// Whether `bytes` is one or more complete RTCM 3 frames with good CRCs and
/// nothing else.
pub fn is_whole_rtcm3_frames(bytes: &[u8]) -> bool {
    let mut rest = bytes;
    while !rest.is_empty() {
        match rtcm3_frame_at(rest) {
            Rtcm3Frame::Valid(len) => rest = &rest[len..],
            _ => return false,
        }
    }
    !bytes.is_empty()
}

/// Counts RTCM 3 frames in a byte stream that arrives in arbitrary pieces,
/// for health reporting; the bytes themselves are passed on untouched.
#[derive(Clone, Debug, Default)]
pub struct Rtcm3FrameCounter {
    /// Bytes of a frame not yet complete (at most one frame long).
    partial: Vec<u8>,
}

/// What [`Rtcm3FrameCounter::push`] found in one piece of the stream.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rtcm3Count {
    pub frames: u64,
    pub bad_crc: u64,
    /// Bytes outside any frame (not RTCM 3, or resynchronisation).
    pub skipped_bytes: u64,
}

impl Rtcm3FrameCounter {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, bytes: &[u8]) -> Rtcm3Count {
        let mut count = Rtcm3Count::default();
        self.partial.extend_from_slice(bytes);
        let mut start = 0;
        while start < self.partial.len() {
            match rtcm3_frame_at(&self.partial[start..]) {
                Rtcm3Frame::Valid(len) => {
                    count.frames += 1;
                    start += len;
                }
                Rtcm3Frame::BadCrc(_) => {
                    // The preamble may have been a data byte: resync from
                    // the next byte rather than skip the claimed length.
                    count.bad_crc += 1;
                    count.skipped_bytes += 1;
                    start += 1;
                }
                Rtcm3Frame::NotAFrame => {
                    count.skipped_bytes += 1;
                    start += 1;
                }
                Rtcm3Frame::Incomplete => break,
            }
        }
        self.partial.drain(..start);
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Splits `message` the way the spec asks a sender to: unfragmented up
    /// to 180 bytes, else 180-byte fragments plus a zero-length terminator
    /// when the length is an exact multiple below 720.
    fn split_per_spec(message: &[u8], sequence: u8) -> Vec<(u8, Vec<u8>)> {
        if message.len() <= RTCM_FRAGMENT_MAX_LEN {
            return vec![((sequence & 0x1F) << 3, message.to_vec())];
        }
        let mut chunks: Vec<Vec<u8>> = message.chunks(RTCM_FRAGMENT_MAX_LEN).map(<[u8]>::to_vec).collect();
        if message.len().is_multiple_of(RTCM_FRAGMENT_MAX_LEN) && chunks.len() < RTCM_MAX_FRAGMENTS {
            chunks.push(Vec::new());
        }
        chunks
            .into_iter()
            .enumerate()
            .map(|(id, chunk)| (1 | (id as u8) << 1 | (sequence & 0x1F) << 3, chunk))
            .collect()
    }

    fn frag(id: u8, sequence: u8) -> u8 {
        1 | id << 1 | sequence << 3
    }

    /// A well-formed RTCM 3 frame carrying `payload`.
    fn rtcm3_frame(payload: &[u8]) -> Vec<u8> {
        let mut frame = vec![RTCM3_PREAMBLE, (payload.len() >> 8) as u8, payload.len() as u8];
        frame.extend_from_slice(payload);
        let crc = crc24q(&frame);
        frame.extend_from_slice(&[(crc >> 16) as u8, (crc >> 8) as u8, crc as u8]);
        frame
    }

    fn push_all(r: &mut RtcmReassembler, packets: &[(u8, Vec<u8>)]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for (flags, data) in packets {
            r.push(*flags, data, &mut out);
        }
        out
    }

    #[test]
    fn crc24q_matches_the_published_check_value() {
        // CRC-24/LTE-A (same polynomial, init 0, no reflection): check value
        // for "123456789" from the CRC catalogue.
        assert_eq!(crc24q(b"123456789"), 0xCDE703);
    }

    #[test]
    fn unfragmented_is_passed_at_once_and_leaves_pending_alone() {
        let mut r = RtcmReassembler::new();
        let mut out = Vec::new();
        r.push(frag(0, 3), &[1; 180], &mut out);
        r.push(5 << 3, &[9, 8, 7], &mut out);
        assert_eq!(out, vec![vec![9, 8, 7]]);
        r.push(frag(1, 3), &[2; 10], &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[1].len(), 190);
        assert_eq!(r.stats().messages, 2);
        assert_eq!(r.stats().dropped_incomplete, 0);
    }

    #[test]
    fn exact_multiple_waits_for_the_zero_length_terminator() {
        let message: Vec<u8> = (0..360u32).map(|i| (i * 7) as u8).collect();
        let mut r = RtcmReassembler::new();
        let mut out = Vec::new();
        r.push(frag(1, 9), &message[180..], &mut out);
        r.push(frag(0, 9), &message[..180], &mut out);
        assert!(out.is_empty(), "two full fragments are not yet a message");
        r.push(frag(2, 9), &[], &mut out);
        assert_eq!(out, vec![message]);
    }

    #[test]
    fn four_full_fragments_complete_without_terminator() {
        let message: Vec<u8> = (0..720u32).map(|i| (i % 251) as u8).collect();
        let mut r = RtcmReassembler::new();
        let packets: Vec<_> = [3u8, 0, 2, 1]
            .iter()
            .map(|&id| (frag(id, 1), message[usize::from(id) * 180..][..180].to_vec()))
            .collect();
        assert_eq!(push_all(&mut r, &packets), vec![message]);
    }

    #[test]
    fn new_sequence_drops_an_incomplete_message() {
        let mut r = RtcmReassembler::new();
        let out = push_all(
            &mut r,
            &[
                (frag(1, 4), vec![1; 20]),
                (frag(0, 5), vec![2; 180]),
                (frag(1, 5), vec![3; 5]),
            ],
        );
        assert_eq!(out.len(), 1);
        assert_eq!(out[0][..180], [2; 180]);
        assert_eq!(r.stats().dropped_incomplete, 1);
        assert_eq!(r.stats().messages, 1);
    }

    #[test]
    fn oversized_packet_is_rejected() {
        let mut r = RtcmReassembler::new();
        let mut out = Vec::new();
        r.push(0, &[0; 181], &mut out);
        r.push(frag(0, 0), &[0; 200], &mut out);
        assert!(out.is_empty());
        assert_eq!(r.stats().rejected, 2);
        assert_eq!(r.stats().fragments, 0);
    }

    #[test]
    fn copies_are_ignored_while_pending_and_after_completion() {
        let mut r = RtcmReassembler::new();
        let a = vec![5u8; 180];
        let b = vec![6u8; 30];
        let next = vec![7u8; 180];
        let out = push_all(
            &mut r,
            &[
                (frag(0, 2), a.clone()),
                (frag(0, 2), a.clone()),
                (frag(1, 2), b.clone()),
                (frag(0, 3), next.clone()),
                // Late copies over a slower link, after the next message began.
                (frag(1, 2), b.clone()),
                (frag(0, 2), a.clone()),
                (frag(1, 3), vec![8; 1]),
            ],
        );
        assert_eq!(out.len(), 2, "{out:?}");
        assert_eq!(out[0], [a, b].concat());
        assert_eq!(out[1].len(), 181);
        assert_eq!(r.stats().duplicates, 3);
        assert_eq!(r.stats().dropped_incomplete, 0);
    }

    #[test]
    fn same_id_with_other_bytes_restarts_the_message() {
        let mut r = RtcmReassembler::new();
        let out = push_all(
            &mut r,
            &[
                (frag(0, 1), vec![1; 180]),
                (frag(0, 1), vec![2; 180]),
                (frag(1, 1), vec![3; 4]),
            ],
        );
        assert_eq!(out, vec![[vec![2; 180], vec![3; 4]].concat()]);
        assert_eq!(r.stats().dropped_incomplete, 1);
    }

    #[test]
    fn fragment_beyond_the_short_one_restarts_the_message() {
        let mut r = RtcmReassembler::new();
        let out = push_all(
            &mut r,
            &[
                (frag(1, 1), vec![1; 10]),
                (frag(2, 1), vec![2; 180]),
                (frag(0, 1), vec![3; 180]),
            ],
        );
        assert!(out.is_empty(), "{out:?}");
        assert_eq!(r.stats().dropped_incomplete, 1);
    }

    #[test]
    fn unterminated_rtcm_message_is_passed_when_the_next_one_starts() {
        // QGroundControl ≤ 5.x: a 360-byte RTCM frame in two full fragments
        // and no terminator.
        let frame = rtcm3_frame(&(0..354u32).map(|i| (i * 3) as u8).collect::<Vec<_>>());
        assert_eq!(frame.len(), 360);
        let mut r = RtcmReassembler::new();
        let mut out = Vec::new();
        r.push(frag(0, 6), &frame[..180], &mut out);
        r.push(frag(1, 6), &frame[180..], &mut out);
        assert!(out.is_empty());
        r.push(frag(0, 7), &[0xAA; 180], &mut out);
        assert_eq!(out, vec![frame.clone()]);
        assert_eq!(r.stats().unterminated, 1);
        // A late copy of the flushed message is a duplicate: it neither
        // passes the message on again nor disturbs the one being assembled.
        r.push(frag(1, 6), &frame[180..], &mut out);
        assert_eq!(r.stats().duplicates, 1);
        r.push(frag(1, 7), &[0xBB; 3], &mut out);
        assert_eq!(out, vec![frame, [vec![0xAA; 180], vec![0xBB; 3]].concat()]);
        assert_eq!(r.stats().messages, 2);
        assert_eq!(r.stats().dropped_incomplete, 0);
    }

    #[test]
    fn unterminated_non_rtcm_or_truncated_message_is_dropped() {
        let frame = rtcm3_frame(&[0x42; 400]);
        let mut r = RtcmReassembler::new();
        let mut out = Vec::new();
        // The short last fragment was lost: 360 bytes of a 406-byte frame.
        r.push(frag(0, 6), &frame[..180], &mut out);
        r.push(frag(1, 6), &frame[180..360], &mut out);
        r.push(frag(0, 7), &[0x55; 180], &mut out);
        r.push(frag(1, 7), &[0x55; 180], &mut out);
        r.push(frag(0, 8), &[1], &mut out);
        assert_eq!(out, vec![vec![1]]);
        assert_eq!(r.stats().dropped_incomplete, 2);
        assert_eq!(r.stats().unterminated, 0);
    }

    #[test]
    fn frame_counter_finds_frames_across_pieces_and_skips_noise() {
        let a = rtcm3_frame(&[1, 2, 3, b'\r', b'\n', 0]);
        let b = rtcm3_frame(&[0xD3; 50]);
        let mut corrupt = rtcm3_frame(&[9; 20]);
        corrupt[10] ^= 0xFF;
        let stream = [b"junk".as_slice(), &a, &corrupt, &b].concat();
        let mut counter = Rtcm3FrameCounter::new();
        let mut total = Rtcm3Count::default();
        for piece in stream.chunks(7) {
            let c = counter.push(piece);
            total.frames += c.frames;
            total.bad_crc += c.bad_crc;
            total.skipped_bytes += c.skipped_bytes;
        }
        assert_eq!(total.frames, 2);
        assert_eq!(total.bad_crc, 1);
        assert_eq!(total.skipped_bytes, 4 + corrupt.len() as u64);
    }

    proptest! {
        // Failures are reported with their input; no regression file.
        #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn shuffled_fragments_give_the_message_exactly_once(
            message in proptest::collection::vec(any::<u8>(), 1..=RTCM_MAX_MESSAGE_LEN),
            sequence in 0u8..32,
            order in any::<proptest::sample::Index>(),
        ) {
            let mut packets = split_per_spec(&message, sequence);
            // Every permutation of at most 5 packets, picked by `order`.
            let mut shuffled = Vec::new();
            let mut pick = order.index(usize::MAX);
            while !packets.is_empty() {
                shuffled.push(packets.remove(pick % packets.len()));
                pick /= 5;
            }
            let mut r = RtcmReassembler::new();
            let out = push_all(&mut r, &shuffled);
            prop_assert_eq!(out, vec![message]);
            prop_assert_eq!(r.stats().messages, 1);
            prop_assert_eq!(r.stats().dropped_incomplete, 0);
        }

        #[test]
        fn a_stream_with_copies_and_reordering_comes_out_once_in_order(
            messages in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 1..=RTCM_MAX_MESSAGE_LEN), 1..6),
            first_sequence in 0u8..32,
            seed in any::<u64>(),
        ) {
            use rand::{Rng, SeedableRng, seq::SliceRandom};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut packets = Vec::new();
            let mut previous: Vec<(u8, Vec<u8>)> = Vec::new();
            for (k, message) in messages.iter().enumerate() {
                let sequence = first_sequence.wrapping_add(k as u8) & 0x1F;
                let mut fragments = split_per_spec(message, sequence);
                let fragmented = fragments[0].0 & 1 == 1;
                if fragmented {
                    // Copies of this message's fragments and late copies of
                    // the previous message's, all mixed in.
                    let copies: Vec<_> = fragments.iter().filter(|_| rng.random_bool(0.5)).cloned().collect();
                    fragments.extend(copies);
                    fragments.extend(previous.iter().filter(|_| rng.random_bool(0.3)).cloned());
                    fragments.shuffle(&mut rng);
                    previous = split_per_spec(message, sequence);
                }
                packets.extend(fragments);
            }
            let mut r = RtcmReassembler::new();
            let out = push_all(&mut r, &packets);
            prop_assert_eq!(&out, &messages);
            prop_assert_eq!(r.stats().dropped_incomplete, 0);
        }
    }
}
