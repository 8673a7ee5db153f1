//! Framing: bytes in any chunking → CRC-valid MAVLink 1/2 frames, each
//! decoded into a message of the ardupilotmega dialect when possible.
//!
//! Uses the `mavlink` crate's incremental reader over an in-memory queue so
//! parsing is independent of the transport and resynchronises after garbage.

use std::collections::VecDeque;
use std::io::{self, Read};

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::error::{MessageReadError, ParserError};
use mavlink::{MAVLinkMessageRaw, MavHeader, MavlinkReader, MavlinkVersion, Message};

/// A CRC-valid frame and what it decoded to.
pub struct ReceivedFrame {
    pub raw: MAVLinkMessageRaw,
    pub header: MavHeader,
    pub version: MavlinkVersion,
    /// Decoding fails for valid frames whose payload has an enum value the
    /// dialect lacks (an unknown command id, say).
    pub message: Result<MavMessage, ParserError>,
}

impl ReceivedFrame {
    pub fn message_id(&self) -> u32 {
        self.raw.message_id()
    }

    pub fn bytes(&self) -> &[u8] {
        match &self.raw {
            MAVLinkMessageRaw::V1(r) => r.raw_bytes(),
            MAVLinkMessageRaw::V2(r) => r.raw_bytes(),
        }
    }
}

/// Per-link receive counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    pub bytes: u64,
    pub frames: u64,
    pub frames_v1: u64,
    pub decode_errors: u64,
    /// Bytes not (yet) part of a valid frame: garbage, bad CRCs, frames of
    /// unknown message ids, and at most one partial frame still buffered.
    pub bytes_unframed: u64,
}

/// A `Read` that hands out what was pushed and reports `WouldBlock` when
/// empty, so the reader keeps partial frames between pushes.
#[derive(Default)]
struct Pending {
    queue: VecDeque<u8>,
}

impl Read for Pending {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.queue.is_empty() {
            return Err(io::ErrorKind::WouldBlock.into());
        }
        let n = self.queue.len().min(buf.len());
        for (dst, src) in buf.iter_mut().zip(self.queue.drain(..n)) {
            *dst = src;
        }
        Ok(n)
    }
}

/// Frames a byte stream (TCP, serial).
pub struct StreamFramer {
    reader: MavlinkReader<Pending>,
    stats: FrameStats,
    framed_bytes: u64,
}

impl Default for StreamFramer {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamFramer {
    pub fn new() -> Self {
        StreamFramer {
            reader: MavlinkReader::with_capacity(4096, Pending::default()),
            stats: FrameStats::default(),
            framed_bytes: 0,
        }
    }

    pub fn stats(&self) -> FrameStats {
        self.stats
    }

    /// Appends `bytes` and hands every complete frame to `sink`.
    pub fn push(&mut self, bytes: &[u8], mut sink: impl FnMut(ReceivedFrame)) {
        self.stats.bytes += bytes.len() as u64;
        self.reader.get_mut().queue.extend(bytes);
        loop {
            match self.reader.read_any_raw_message::<MavMessage>() {
                Ok(raw) => sink(self.accept(raw)),
                Err(MessageReadError::Io(_)) => break,
                // Raw reads do not decode; nothing else can come back.
                Err(MessageReadError::Parse(_)) => break,
            }
        }
        self.stats.bytes_unframed = self.stats.bytes - self.framed_bytes;
    }

    fn accept(&mut self, raw: MAVLinkMessageRaw) -> ReceivedFrame {
        let frame = decode(raw);
        self.framed_bytes += frame.bytes().len() as u64;
        self.stats.frames += 1;
        if frame.version == MavlinkVersion::V1 {
            self.stats.frames_v1 += 1;
        }
        if frame.message.is_err() {
            self.stats.decode_errors += 1;
        }
        frame
    }
}

/// Frames one datagram: frames never span datagrams, so a truncated one
/// cannot delay the next.
pub fn frame_datagram(datagram: &[u8], stats: &mut FrameStats, mut sink: impl FnMut(ReceivedFrame)) {
    stats.bytes += datagram.len() as u64;
    let mut framed = 0u64;
    let mut reader = MavlinkReader::with_capacity(datagram.len(), datagram);
    while let Ok(raw) = reader.read_any_raw_message::<MavMessage>() {
        let frame = decode(raw);
        framed += frame.bytes().len() as u64;
        stats.frames += 1;
        if frame.version == MavlinkVersion::V1 {
            stats.frames_v1 += 1;
        }
        if frame.message.is_err() {
            stats.decode_errors += 1;
        }
        sink(frame);
    }
    stats.bytes_unframed += datagram.len() as u64 - framed;
}

fn decode(raw: MAVLinkMessageRaw) -> ReceivedFrame {
    let version = raw.version();
    let header = MavHeader {
        system_id: raw.system_id(),
        component_id: raw.component_id(),
        sequence: raw.sequence(),
    };
    let message = MavMessage::parse(version, raw.message_id(), raw.payload())
        .or_else(|e| lenient_param_set(version, raw.message_id(), raw.payload()).ok_or(e));
    ReceivedFrame {
        raw,
        header,
        version,
        message,
    }
}

/// PARAM_SET with a `param_type` the dialect does not know (0, say) is still
/// a valid request: Furrow ignores the type (the declared one rules, as in
/// ArduPilot), so decode it as REAL32 rather than leave it unanswered.
fn lenient_param_set(version: MavlinkVersion, message_id: u32, payload: &[u8]) -> Option<MavMessage> {
    const PARAM_SET_ID: u32 = 23;
    const TYPE_OFFSET: usize = 22;
    const REAL32: u8 = 9;
    if message_id != PARAM_SET_ID {
        return None;
    }
    let mut patched = [0u8; TYPE_OFFSET + 1];
    let n = payload.len().min(TYPE_OFFSET);
    patched[..n].copy_from_slice(&payload[..n]);
    patched[TYPE_OFFSET] = REAL32;
    MavMessage::parse(version, message_id, &patched).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::encode::encode_v2;
    use mavlink::dialects::ardupilotmega::HEARTBEAT_DATA;

    fn heartbeat_bytes(seq: u8) -> Vec<u8> {
        let header = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: seq,
        };
        encode_v2(header, &MavMessage::HEARTBEAT(HEARTBEAT_DATA::default()))
    }

    #[test]
    fn frames_survive_any_chunking_and_garbage() {
        // 0xfd with an unsupported incompat flag (0x80), then noise.
        let mut stream = vec![0x55, 0x00, 0xfd, 0x01, 0x80, 0x01];
        for seq in 0..5 {
            stream.extend(heartbeat_bytes(seq));
            stream.extend([0xfd, 0x09, 0x00]);
        }
        for chunk in [1, 3, 7, 64, 1000] {
            let mut framer = StreamFramer::new();
            let mut seqs = Vec::new();
            for part in stream.chunks(chunk) {
                framer.push(part, |f| seqs.push(f.header.sequence));
            }
            assert_eq!(seqs, vec![0, 1, 2, 3, 4], "chunk size {chunk}");
            assert_eq!(framer.stats().frames, 5);
            assert!(framer.stats().bytes_unframed >= 4);
        }
    }

    /// A stray MAVLink 1 marker with a large length byte makes the parser
    /// wait for that many bytes (as every MAVLink parser does); once they
    /// arrive the CRC fails and the frames behind it are recovered.
    #[test]
    fn a_stray_marker_delays_but_loses_nothing() {
        let mut stream = vec![0xfe, 0xff];
        for seq in 0..20 {
            stream.extend(heartbeat_bytes(seq));
        }
        let mut framer = StreamFramer::new();
        let mut seqs = Vec::new();
        for part in stream.chunks(5) {
            framer.push(part, |f| seqs.push(f.header.sequence));
        }
        assert_eq!(seqs, (0..20).collect::<Vec<u8>>());
    }

    #[test]
    fn bad_crc_is_dropped() {
        let mut bytes = heartbeat_bytes(0);
        let last = bytes.len() - 1;
        bytes[last] ^= 0xff;
        bytes.extend(heartbeat_bytes(1));
        let mut framer = StreamFramer::new();
        let mut seqs = Vec::new();
        framer.push(&bytes, |f| seqs.push(f.header.sequence));
        assert_eq!(seqs, vec![1]);
    }

    #[test]
    fn a_truncated_datagram_does_not_swallow_the_next() {
        let mut stats = FrameStats::default();
        let full = heartbeat_bytes(7);
        let mut got = Vec::new();
        frame_datagram(&full[..full.len() - 3], &mut stats, |f| got.push(f.header.sequence));
        frame_datagram(&full, &mut stats, |f| got.push(f.header.sequence));
        assert_eq!(got, vec![7]);
        assert_eq!(stats.frames, 1);
    }
}
