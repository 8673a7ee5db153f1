//! Byte stream → lines. The buffer is a fixed array so a receiver that never
//! sends a line end (or a stream of noise) cannot grow memory.

use std::time::Duration;

use super::sentences::{LineOutcome, parse_line};
use super::{GnssSample, NmeaStats};

/// Longest line accepted, from `$` to the checksum inclusive, without the
/// line end. NMEA 0183 says 82 with CR LF, but real RTK receivers send up to
/// ~100 (high-precision GGA, the `nmea` crate's limit) and an IMU's
/// `$VNYMR` about 125.
pub const MAX_SENTENCE_LEN: usize = 160;

/// Incremental NMEA 0183 reader.
///
/// Lines end at CR or LF; a `$` always starts a new line, so a sentence cut
/// short by a glitch costs only itself, not the next one. Each line is counted
/// in exactly one field of [`NmeaStats`].
#[derive(Clone, Debug)]
pub struct NmeaReader {
    line: [u8; MAX_SENTENCE_LEN],
    len: usize,
    /// The current line crossed the limit (already counted): drop its rest.
    discarding: bool,
    stats: NmeaStats,
}

impl Default for NmeaReader {
    fn default() -> Self {
        Self::new()
    }
}

impl NmeaReader {
    pub fn new() -> Self {
        Self {
            line: [0; MAX_SENTENCE_LEN],
            len: 0,
            discarding: false,
            stats: NmeaStats::default(),
        }
    }

    /// Bytes as they arrive, in any chunking. Every sentence completed by
    /// these bytes appends its samples to `out`, stamped `t`.
    pub fn push(&mut self, t: Duration, bytes: &[u8], out: &mut Vec<GnssSample>) {
        for &byte in bytes {
            match byte {
                b'\r' | b'\n' => self.end_line(t, out),
                b'$' => {
                    self.end_line(t, out);
                    self.append(byte);
                }
                _ => self.append(byte),
            }
        }
    }

    pub fn stats(&self) -> NmeaStats {
        self.stats
    }

    /// Bytes held for an unfinished line (never more than [`MAX_SENTENCE_LEN`]).
    pub fn pending_len(&self) -> usize {
        self.len
    }

    fn append(&mut self, byte: u8) {
        if self.discarding {
            return;
        }
        if self.len == MAX_SENTENCE_LEN {
            self.stats.overlong += 1;
            self.discarding = true;
            self.len = 0;
            return;
        }
        self.line[self.len] = byte;
        self.len += 1;
    }

    fn end_line(&mut self, t: Duration, out: &mut Vec<GnssSample>) {
        if self.discarding {
            self.discarding = false;
            return;
        }
        if self.len == 0 {
            return;
        }
        let outcome = parse_line(&self.line[..self.len], t, out);
        self.len = 0;
        let counter = match outcome {
            LineOutcome::Parsed => &mut self.stats.sentences,
            LineOutcome::ChecksumError => &mut self.stats.checksum_errors,
            LineOutcome::Malformed => &mut self.stats.malformed,
            LineOutcome::Unsupported => &mut self.stats.unsupported,
        };
        *counter += 1;
    }
}
