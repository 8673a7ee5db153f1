//! SICK CoLa-A ("Command Language A", ASCII) as spoken by the LMS1xx over TCP
//! (port 2111): framing, the `LMDscandata` scan telegram, and the few
//! commands the client sends. Pure: bytes in, values out, no I/O.
//!
//! # Wire format
//!
//! Every telegram is `STX` (0x02), space-separated tokens, `ETX` (0x03); CoLa-A
//! carries no checksum. Numbers are hexadecimal without a prefix; floats are
//! their IEEE-754 bit pattern in hex; signed values are two's complement.
//! The first token is the command type (`sRN` read request, `sRA` read answer,
//! `sEN`/`sEA` event subscribe/acknowledge, `sSN` event telegram, `sFA` error
//! answer), the second the variable or event name.
//!
//! The `LMDscandata` layout below follows SICK AG's *Telegram Listing* for the
//! LMS1xx/LMS5xx/TiM family (CoLa-A, telegram `LMDscandata`), checked against
//! captured LMS1xx telegrams and the field walk of public drivers
//! (clearpathrobotics/LMS1xx `LMS1xx::getData`, SICKAG/sick_scan). After
//! `sRA`/`sSN LMDscandata`:
//!
//! | # | field | type |
//! |---|---|---|
//! | 1 | version number | uint16 |
//! | 2 | device number | uint16 |
//! | 3 | serial number | uint32 |
//! | 4–5 | device status | 2 × uint8 |
//! | 6 | telegram counter | uint16 |
//! | 7 | scan counter | uint16 |
//! | 8 | time since start-up | uint32, µs |
//! | 9 | time of transmission | uint32, µs |
//! | 10–11 | digital inputs | 2 × uint8 |
//! | 12–13 | digital outputs | 2 × uint8 |
//! | 14 | reserved | uint16 |
//! | 15 | scan frequency | uint32, 1/100 Hz |
//! | 16 | measurement frequency | uint32, 100 Hz |
//! | 17 | number of encoders `E`, then `E` × (position uint32, speed uint16) | |
//! | … | number of 16-bit channels `C16`, then per channel: | |
//! |   | content (`DIST1`, `DIST2`, `RSSI1`, `RSSI2`) | string |
//! |   | scale factor | float32 |
//! |   | scale offset | float32 |
//! |   | start angle | int32, 1/10000° |
//! |   | angular step | uint16, 1/10000° |
//! |   | number of data `N` | uint16 |
//! |   | `N` data | uint16 each |
//! | … | number of 8-bit channels, then channels laid out as above (uint8 data) | |
//! | … | position block, device name, comment, time stamp, event info (each a 0/1 flag and, when 1, its content) | |
//!
//! Distances are `raw · scale factor + scale offset` millimetres; raw 0 means
//! no echo. SICK's LMS1xx angles have 90° straight ahead and grow
//! anticlockwise seen from above (a 270° scan runs from −45° to 225°).
//! Furrow's [`Scan`] measures clockwise from the forward axis, so
//! `ours = 90° − sick` and a positive SICK step becomes a negative `step_rad`.

use std::collections::VecDeque;
use std::fmt;
use std::time::Duration;

use super::Scan;

pub const STX: u8 = 0x02;
pub const ETX: u8 = 0x03;

/// Longest telegram body accepted. An LMS1xx at 0.25° with DIST1, RSSI1 and
/// every optional block is ≈ 11 KB, so this leaves room for DIST2/RSSI2 and
/// LMS5xx multi-echo while bounding what a babbling peer can make us hold.
pub const MAX_TELEGRAM_LEN: usize = 64 * 1024;

/// Complete telegrams held until popped. A reader pops after every push, so
/// this is only reached by a caller that stops popping; the oldest go first.
pub const MAX_PENDING_TELEGRAMS: usize = 32;

/// Buffers kept from [`ColaFramer::pop_into`] for reuse.
const MAX_SPARE_BUFFERS: usize = 2;

const SCAN_DATA: &[u8] = b"LMDscandata";
const DIST1: &[u8] = b"DIST1";
/// SICK's LMS1xx angle of the scanner's forward axis, 1/10000°.
const SICK_FORWARD_1E4DEG: f64 = 90.0 * 1e4;

// ---------------------------------------------------------------------------
// Framing

/// What the framer has done with the bytes it was given. Every byte lands in
/// exactly one of: a delivered telegram (with its STX/ETX), `skipped_bytes`,
/// or the body of an `oversized` telegram.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramerStats {
    /// Complete telegrams framed (including any later lost to `overrun`).
    pub telegrams: u64,
    /// Bytes outside any telegram: noise before an STX, or a telegram cut
    /// short by a new STX before its ETX (e.g. after a reconnect mid-stream).
    pub skipped_bytes: u64,
    /// Telegrams dropped for exceeding the length bound.
    pub oversized: u64,
    /// Complete telegrams dropped because the caller did not pop them.
    pub overrun: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FramerState {
    /// Waiting for an STX.
    Hunting,
    /// Inside a telegram, collecting its body.
    InTelegram,
    /// The current telegram crossed the bound: drop the rest of it.
    DiscardingOversized,
}

/// Byte stream → CoLa-A telegram bodies (without STX/ETX). Memory is bounded
/// by `max_len · (MAX_PENDING_TELEGRAMS + 1)` whatever the input.
#[derive(Clone, Debug)]
pub struct ColaFramer {
    state: FramerState,
    body: Vec<u8>,
    pending: VecDeque<Vec<u8>>,
    /// Buffers handed back by [`ColaFramer::pop_into`], for the next bodies.
    spare: Vec<Vec<u8>>,
    max_len: usize,
    stats: FramerStats,
}

impl Default for ColaFramer {
    fn default() -> Self {
        Self::new()
    }
}

impl ColaFramer {
    pub fn new() -> Self {
        Self::with_max_len(MAX_TELEGRAM_LEN)
    }

    /// `max_len`: longest body accepted, bytes between STX and ETX.
    pub fn with_max_len(max_len: usize) -> Self {
        Self {
            state: FramerState::Hunting,
            body: Vec::new(),
            pending: VecDeque::new(),
            spare: Vec::new(),
            max_len,
            stats: FramerStats::default(),
        }
    }

    /// Bytes as they arrive, in any chunking.
    pub fn push(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            match self.state {
                // memchr: a scan telegram is kilobytes, scanned a word at a time.
                FramerState::Hunting => match memchr::memchr(STX, bytes) {
                    Some(at) => {
                        self.stats.skipped_bytes += at as u64;
                        self.body.clear();
                        self.state = FramerState::InTelegram;
                        bytes = &bytes[at + 1..];
                    }
                    None => {
                        self.stats.skipped_bytes += bytes.len() as u64;
                        bytes = &[];
                    }
                },
                FramerState::InTelegram => {
                    let end = memchr::memchr2(STX, ETX, bytes);
                    let chunk = &bytes[..end.unwrap_or(bytes.len())];
                    if self.body.len() + chunk.len() > self.max_len {
                        self.stats.oversized += 1;
                        self.body.clear();
                        self.state = FramerState::DiscardingOversized;
                        // The marker (if any) is handled in the discarding state.
                        bytes = &bytes[chunk.len()..];
                        continue;
                    }
                    self.body.extend_from_slice(chunk);
                    bytes = &bytes[chunk.len()..];
                    match bytes.first() {
                        Some(&ETX) => {
                            self.complete();
                            bytes = &bytes[1..];
                        }
                        Some(_) => {
                            // A new STX before ETX: the telegram was cut short
                            // (its ETX lost). Resynchronise on the new one.
                            self.stats.skipped_bytes += self.body.len() as u64 + 1;
                            self.body.clear();
                            bytes = &bytes[1..];
                        }
                        None => {}
                    }
                }
                FramerState::DiscardingOversized => match memchr::memchr2(STX, ETX, bytes) {
                    Some(at) => {
                        self.state = if bytes[at] == STX {
                            self.body.clear();
                            FramerState::InTelegram
                        } else {
                            FramerState::Hunting
                        };
                        bytes = &bytes[at + 1..];
                    }
                    None => bytes = &[],
                },
            }
        }
    }

    fn complete(&mut self) {
        self.stats.telegrams += 1;
        if self.pending.len() >= MAX_PENDING_TELEGRAMS {
            self.pending.pop_front();
            self.stats.overrun += 1;
        }
        let next_body = self.spare.pop().unwrap_or_default();
        self.pending.push_back(std::mem::replace(&mut self.body, next_body));
        self.state = FramerState::Hunting;
    }

    /// The oldest complete telegram body, without STX/ETX.
    pub fn pop(&mut self) -> Option<Vec<u8>> {
        self.pending.pop_front()
    }

    /// The oldest complete telegram body into `out`, whose old buffer the
    /// framer keeps for a later body: a reader that pops this way frames
    /// without allocating once the buffers have grown. False if none.
    pub fn pop_into(&mut self, out: &mut Vec<u8>) -> bool {
        let Some(body) = self.pending.pop_front() else {
            return false;
        };
        let mut old = std::mem::replace(out, body);
        // A reader that pops after every push needs one spare; keeping
        // a couple at most bounds what the framer holds.
        if self.spare.len() < MAX_SPARE_BUFFERS {
            old.clear();
            self.spare.push(old);
        }
        true
    }

    pub fn stats(&self) -> FramerStats {
        self.stats
    }

    /// Bytes currently held (partial body plus pending telegrams).
    pub fn buffered_len(&self) -> usize {
        self.body.len() + self.pending.iter().map(Vec::len).sum::<usize>()
    }
}

// ---------------------------------------------------------------------------
// Errors

/// Why a telegram could not be understood. Tokens quoted in messages are cut
/// to a few characters so a hostile peer cannot flood the log.
#[derive(Clone, Debug, PartialEq)]
pub enum ColaError {
    /// No tokens at all.
    Empty,
    /// Not the telegram the caller asked for.
    UnexpectedCommand { command_type: String, name: String },
    /// The telegram ended before this field.
    MissingField { field: &'static str },
    /// Not 1–8 hexadecimal digits.
    BadHex { field: &'static str, token: String },
    /// Valid hex, but beyond the field's width.
    OutOfRange { field: &'static str, value: u32, max: u32 },
    /// A count announces more items than there are tokens left.
    CountExceedsTokens {
        field: &'static str,
        count: usize,
        remaining: usize,
    },
    /// Neither the 16-bit nor the 8-bit channels contain `DIST1`.
    NoDistanceChannel,
    /// The DIST1 scale factor is non-finite or not positive, its offset is
    /// non-finite, or together they put an echo below 0 m or beyond what an
    /// `f32` holds: no distance could be trusted.
    InvalidScale { scale_factor: f32, scale_offset: f32 },
    /// More than one beam but an angular step of 0.
    ZeroAngularStep,
    /// A 0/1 flag that is neither.
    BadFlag { field: &'static str, token: String },
}

impl fmt::Display for ColaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ColaError::Empty => write!(f, "empty CoLa-A telegram"),
            ColaError::UnexpectedCommand { command_type, name } => {
                write!(
                    f,
                    "unexpected telegram `{command_type} {name}` (wanted sRA/sSN LMDscandata)"
                )
            }
            ColaError::MissingField { field } => write!(f, "telegram ends before field `{field}`"),
            ColaError::BadHex { field, token } => write!(f, "field `{field}`: `{token}` is not 1-8 hex digits"),
            ColaError::OutOfRange { field, value, max } => {
                write!(f, "field `{field}`: value {value} exceeds its maximum {max}")
            }
            ColaError::CountExceedsTokens {
                field,
                count,
                remaining,
            } => write!(
                f,
                "field `{field}` announces {count} items but only {remaining} tokens remain"
            ),
            ColaError::NoDistanceChannel => write!(f, "scan telegram has no DIST1 channel"),
            ColaError::InvalidScale {
                scale_factor,
                scale_offset,
            } => write!(
                f,
                "DIST1 scale factor {scale_factor} / offset {scale_offset} unusable (need finite factor > 0, finite offset)"
            ),
            ColaError::ZeroAngularStep => write!(f, "DIST1 has several beams but an angular step of 0"),
            ColaError::BadFlag { field, token } => write!(f, "field `{field}`: `{token}` is not 0 or 1"),
        }
    }
}

impl std::error::Error for ColaError {}

fn quote(token: &[u8]) -> String {
    const SHOWN: usize = 16;
    let mut s = String::from_utf8_lossy(&token[..token.len().min(SHOWN)]).into_owned();
    if token.len() > SHOWN {
        s.push('…');
    }
    s
}

// ---------------------------------------------------------------------------
// Tokens

/// The tokens of one telegram, read in order without collecting them. How
/// many are left is counted only when a count field needs it, and only as
/// far as that count reaches, so a count is checked against what is left
/// before anything is sized from it without a pass over the whole telegram.
#[derive(Clone, Copy)]
struct Tokens<'a> {
    rest: &'a [u8],
}

impl<'a> Tokens<'a> {
    /// Accepts a body with or without its STX/ETX.
    fn new(telegram: &'a [u8]) -> Self {
        let body = telegram.strip_prefix(&[STX]).unwrap_or(telegram);
        let body = body.strip_suffix(&[ETX]).unwrap_or(body);
        Self { rest: body }
    }

    fn remaining(&self) -> usize {
        self.remaining_up_to(usize::MAX)
    }

    /// The tokens left, counted until `needed` are found (the count is then
    /// at least `needed`, not necessarily all of them).
    fn remaining_up_to(&self, needed: usize) -> usize {
        // A token starts at each non-space byte after a space (or at the
        // start; the rest of a telegram always starts at a space or ends).
        let first = usize::from(self.rest.first().is_some_and(|&b| b != b' '));
        first + token_starts_after_spaces(self.rest, needed.saturating_sub(first))
    }

    /// The next token without taking it.
    fn peek(&self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|&b| b != b' ')?;
        let rest = &self.rest[start..];
        let len = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
        Some(&rest[..len])
    }

    fn next_token(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|&b| b != b' ')?;
        let rest = &self.rest[start..];
        let len = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
        self.rest = &rest[len..];
        Some(&rest[..len])
    }

    fn raw(&mut self, field: &'static str) -> Result<&'a [u8], ColaError> {
        match self.next_token() {
            Some(token) => Ok(token),
            None => Err(ColaError::MissingField { field }),
        }
    }

    fn skip(&mut self, field: &'static str) -> Result<(), ColaError> {
        self.raw(field).map(|_| ())
    }

    /// The next token as 1–8 hex digits, decoded as it is scanned.
    fn hex_u32(&mut self, field: &'static str) -> Result<u32, ColaError> {
        let (value, at) = next_hex(self.rest);
        self.take_hex(field, value, at)
    }

    /// `count` tokens of hex no greater than `max` (the data of a channel,
    /// hundreds of them), each into `out` if given: one tight loop, an
    /// error built only for a bad token.
    fn hex_run(
        &mut self,
        field: &'static str,
        count: usize,
        max: u32,
        mut out: Option<&mut Vec<u16>>,
    ) -> Result<(), ColaError> {
        // The position is kept in a local, stored back once at the end.
        let mut rest = self.rest;
        let mut left = count;
        while left > 0 {
            if left >= NO_ECHO_RUN_BEAMS && starts_with_no_echo_run(rest) {
                if let Some(out) = out.as_deref_mut() {
                    out.extend_from_slice(&[0; NO_ECHO_RUN_BEAMS]);
                }
                rest = &rest[NO_ECHO_RUN.len()..];
                left -= NO_ECHO_RUN_BEAMS;
                continue;
            }
            left -= 1;
            let ((value, invalid), at) = next_hex(rest);
            if invalid || at.1 - at.0 > 8 || at.0 == at.1 || value > max {
                self.rest = rest;
                let value = self.take_hex(field, (value, invalid), at)?;
                return Err(ColaError::OutOfRange { field, value, max });
            }
            rest = &rest[at.1..];
            if let Some(out) = out.as_deref_mut() {
                // Bounded by max ≤ u16::MAX above.
                out.push(value as u16);
            }
        }
        self.rest = rest;
        Ok(())
    }

    /// Consumes the token [`next_hex`] found at `at` (start, end): its value,
    /// or why it is not one.
    fn take_hex(
        &mut self,
        field: &'static str,
        (value, invalid): (u32, bool),
        at: (usize, usize),
    ) -> Result<u32, ColaError> {
        let (start, end) = at;
        if start == end {
            return Err(ColaError::MissingField { field });
        }
        let token = &self.rest[start..end];
        self.rest = &self.rest[end..];
        if invalid || token.len() > 8 {
            return Err(ColaError::BadHex {
                field,
                token: quote(token),
            });
        }
        Ok(value)
    }

    fn hex_max(&mut self, field: &'static str, max: u32) -> Result<u32, ColaError> {
        let value = self.hex_u32(field)?;
        if value > max {
            return Err(ColaError::OutOfRange { field, value, max });
        }
        Ok(value)
    }

    fn hex_u16(&mut self, field: &'static str) -> Result<u16, ColaError> {
        // hex_max has bounded the value, so the conversion cannot fail.
        self.hex_max(field, u32::from(u16::MAX)).map(|v| v as u16)
    }

    fn hex_f32(&mut self, field: &'static str) -> Result<f32, ColaError> {
        self.hex_u32(field).map(f32::from_bits)
    }

    /// A count of items of `tokens_each` tokens that must all be present.
    fn count(&mut self, field: &'static str, tokens_each: usize) -> Result<usize, ColaError> {
        let count = usize::from(self.hex_u16(field)?);
        self.check_count(field, count, tokens_each)?;
        Ok(count)
    }

    /// Whether `count` items of `tokens_each` tokens are all present.
    fn check_count(&self, field: &'static str, count: usize, tokens_each: usize) -> Result<(), ColaError> {
        let needed = count.saturating_mul(tokens_each);
        if self.remaining_up_to(needed) < needed {
            return Err(ColaError::CountExceedsTokens {
                field,
                count,
                remaining: self.remaining(),
            });
        }
        Ok(())
    }
}

/// The high bit of each byte of `word` that is a space (exact, no carries
/// between bytes).
fn space_bytes(word: u64) -> u64 {
    const HIGH_BITS: u64 = 0x8080_8080_8080_8080;
    let x = word ^ 0x2020_2020_2020_2020;
    !(((x & !HIGH_BITS) + !HIGH_BITS) | x) & HIGH_BITS
}

/// How many bytes of `body` are a space followed by a non-space, counted
/// eight pairs at a time (a scan telegram is kilobytes), the tail one by
/// one; the count stops once it reaches `needed` (then it is at least that).
fn token_starts_after_spaces(body: &[u8], needed: usize) -> usize {
    let word_at = |i: usize| u64::from_le_bytes(body[i..i + 8].try_into().unwrap_or_default());
    let mut count = 0;
    let mut i = 0;
    while i + 9 <= body.len() {
        if count >= needed {
            return count;
        }
        let pairs = space_bytes(word_at(i)) & !space_bytes(word_at(i + 1));
        count += pairs.count_ones() as usize;
        i += 8;
    }
    let tail = &body[i..];
    count
        + tail
            .windows(2)
            .filter(|pair| pair[0] == b' ' && pair[1] != b' ')
            .count()
}

/// The first token of `rest` read as hex: (value, whether a byte was not a
/// hex digit) and where it lies, (start, end) (equal when there is none).
/// The value is meaningful only for 1–8 valid digits.
#[inline(always)]
fn next_hex(rest: &[u8]) -> ((u32, bool), (usize, usize)) {
    let mut at = 0;
    while at < rest.len() && rest[at] == b' ' {
        at += 1;
    }
    let start = at;
    let (mut value, mut invalid) = (0u32, 0u8);
    while at < rest.len() && rest[at] != b' ' {
        let digit = HEX_VALUES[usize::from(rest[at])];
        // 0xFF has the high bit set; no digit does.
        invalid |= digit;
        value = (value << 4) | u32::from(digit & 0xF);
        at += 1;
    }
    ((value, invalid & 0x80 != 0), (start, at))
}

/// Four no-echo beams as sent: a scan often has long runs of them (open
/// space beyond the scanner's reach), read and written a word at a time.
const NO_ECHO_RUN: &[u8; 8] = b" 0 0 0 0";
const NO_ECHO_RUN_BEAMS: usize = NO_ECHO_RUN.len() / 2;

/// Whether `rest` starts with [`NO_ECHO_RUN`] as four whole tokens (the
/// last one ends there: a space or the end follows).
#[inline(always)]
fn starts_with_no_echo_run(rest: &[u8]) -> bool {
    rest.starts_with(NO_ECHO_RUN) && rest.get(NO_ECHO_RUN.len()).is_none_or(|&b| b == b' ')
}

/// Each byte's value as a hex digit (either case), 0xFF for any other byte.
const HEX_VALUES: [u8; 256] = {
    let mut table = [0xFF; 256];
    let mut i = 0;
    while i < 10 {
        table[b'0' as usize + i] = i as u8;
        i += 1;
    }
    let mut i = 0;
    while i < 6 {
        table[b'A' as usize + i] = 10 + i as u8;
        table[b'a' as usize + i] = 10 + i as u8;
        i += 1;
    }
    table
};

// ---------------------------------------------------------------------------
// Scan telegram

/// One encoder entry of a scan telegram (raw, as the scanner reports it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderReading {
    pub position_ticks: u32,
    pub speed_raw: u16,
}

/// The fields of one `LMDscandata` telegram that Furrow uses, in SICK's own
/// units; [`ScanTelegram::to_scan`] converts to Furrow's frame and metres.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScanTelegram {
    pub version: u16,
    pub device_number: u16,
    pub serial_number: u32,
    /// Raw; both 0 when the device reports no fault.
    pub device_status: [u16; 2],
    pub telegram_counter: u32,
    pub scan_counter: u32,
    pub time_since_startup_us: u32,
    pub time_of_transmission_us: u32,
    pub digital_inputs: [u16; 2],
    pub digital_outputs: [u16; 2],
    pub scan_frequency_hz: f64,
    /// Beams per second over the full revolution (SICK sends it in 100 Hz).
    pub measurement_frequency_hz: f64,
    pub encoders: Vec<EncoderReading>,
    /// SICK convention: 90° ahead, anticlockwise positive.
    pub start_angle_sick_1e4deg: i32,
    /// SICK convention: anticlockwise positive.
    pub step_1e4deg: u32,
    pub scale_factor: f32,
    pub scale_offset: f32,
    /// DIST1 values; 0 = no echo.
    pub dist_raw: Vec<u16>,
}

/// A channel's header; its data went to the caller's buffer, if kept.
struct ChannelHeader<'a> {
    name: &'a [u8],
    scale_factor: f32,
    scale_offset: f32,
    start_angle_1e4deg: i32,
    step_1e4deg: u32,
}

/// Reads one channel; its data goes into `keep` (cleared first) if given
/// and the channel is `DIST1`, else it is validated and skipped.
fn parse_channel<'a>(
    tokens: &mut Tokens<'a>,
    data_max: u32,
    keep: Option<&mut Vec<u16>>,
) -> Result<ChannelHeader<'a>, ColaError> {
    let name = tokens.raw("channel content")?;
    let keep = keep.filter(|_| name == DIST1);
    let scale_factor = tokens.hex_f32("scale factor")?;
    let scale_offset = tokens.hex_f32("scale offset")?;
    // Two's complement: the bit pattern is the signed value.
    let start_angle_1e4deg = tokens.hex_u32("start angle")? as i32;
    let step_1e4deg = u32::from(tokens.hex_u16("angular step")?);
    let count = usize::from(tokens.hex_u16("number of data")?);
    let mut keep = keep;
    if let Some(data) = keep.as_deref_mut() {
        data.clear();
        // Each token but the last takes two bytes at least: the telegram
        // bounds what is reserved, whatever the count says.
        data.reserve(count.min(tokens.rest.len() / 2 + 1));
    }
    // The count is checked against the tokens left only if the data do not
    // read (a pass over the data otherwise spent on every scan): a run that
    // reads `count` tokens had them, and one that fails reports a short
    // count first, as a check beforehand would.
    let before = *tokens;
    if let Err(error) = tokens.hex_run("channel data", count, data_max, keep) {
        before.check_count("number of data", count, 1)?;
        return Err(error);
    }
    Ok(ChannelHeader {
        name,
        scale_factor,
        scale_offset,
        start_angle_1e4deg,
        step_1e4deg,
    })
}

/// Whether every echo of the channel scales to a range
/// [`ScanTelegram::to_scan`] can hold: finite in `f32` metres and not
/// negative. A factor near `f32::MAX` made infinite ranges, a negative
/// offset negative ones (found by fuzzing): neither is a calibration a
/// scanner has, so the scan is refused rather than half believed.
fn echoes_in_range(channel: &ChannelHeader<'_>, data: &[u16]) -> bool {
    let (factor, offset) = (f64::from(channel.scale_factor), f64::from(channel.scale_offset));
    // One branch-free pass each (they vectorise): 0 (no echo) becomes the
    // largest value for the minimum and adds nothing to the maximum.
    let max = data.iter().copied().max().unwrap_or(0);
    if max == 0 {
        return true;
    }
    let min = data.iter().map(|&raw| raw.wrapping_sub(1)).min().unwrap_or(0) + 1;
    let range_m = |raw: u16| (f64::from(raw) * factor + offset) / 1000.0;
    range_m(min) >= 0.0 && (range_m(max) as f32).is_finite()
}

fn check_scan_header(tokens: &mut Tokens<'_>) -> Result<(), ColaError> {
    let command_type = tokens.raw("command type").map_err(|_| ColaError::Empty)?;
    let name = tokens.raw("command name").unwrap_or(b"");
    if !matches!(command_type, b"sRA" | b"sSN") || name != SCAN_DATA {
        return Err(ColaError::UnexpectedCommand {
            command_type: quote(command_type),
            name: quote(name),
        });
    }
    Ok(())
}

/// Parses an `sRA LMDscandata` (answer to a poll) or `sSN LMDscandata`
/// (subscribed event) telegram, with or without its STX/ETX. Takes the first
/// `DIST1` channel (16-bit, else 8-bit); other channels are checked and
/// skipped, and the optional trailing blocks are ignored.
pub fn parse_lmd_scandata(telegram: &[u8]) -> Result<ScanTelegram, ColaError> {
    let mut scan = ScanTelegram::default();
    parse_lmd_scandata_into(telegram, &mut scan)?;
    Ok(scan)
}

/// [`parse_lmd_scandata`] into `scan`, reusing its buffers: a reader that
/// keeps one telegram parses every scan without allocating. On an error
/// `scan` holds a partial parse and must not be used.
pub fn parse_lmd_scandata_into(telegram: &[u8], scan: &mut ScanTelegram) -> Result<(), ColaError> {
    let mut tokens = Tokens::new(telegram);
    check_scan_header(&mut tokens)?;
    parse_scan_fields(&mut tokens, scan)
}

fn parse_scan_fields(tokens: &mut Tokens<'_>, scan: &mut ScanTelegram) -> Result<(), ColaError> {
    scan.version = tokens.hex_u16("version number")?;
    scan.device_number = tokens.hex_u16("device number")?;
    scan.serial_number = tokens.hex_u32("serial number")?;
    scan.device_status = [tokens.hex_u16("device status")?, tokens.hex_u16("device status")?];
    scan.telegram_counter = tokens.hex_u32("telegram counter")?;
    scan.scan_counter = tokens.hex_u32("scan counter")?;
    scan.time_since_startup_us = tokens.hex_u32("time since start-up")?;
    scan.time_of_transmission_us = tokens.hex_u32("time of transmission")?;
    scan.digital_inputs = [tokens.hex_u16("digital inputs")?, tokens.hex_u16("digital inputs")?];
    scan.digital_outputs = [tokens.hex_u16("digital outputs")?, tokens.hex_u16("digital outputs")?];
    // Reserved: content undefined across firmware versions, only its slot.
    tokens.skip("reserved")?;
    scan.scan_frequency_hz = f64::from(tokens.hex_u32("scan frequency")?) / 100.0;
    scan.measurement_frequency_hz = f64::from(tokens.hex_u32("measurement frequency")?) * 100.0;

    let encoder_count = tokens.count("number of encoders", 2)?;
    scan.encoders.clear();
    for _ in 0..encoder_count {
        scan.encoders.push(EncoderReading {
            position_ticks: tokens.hex_u32("encoder position")?,
            speed_raw: tokens.hex_u16("encoder speed")?,
        });
    }

    let dist = parse_channels(tokens, &mut scan.dist_raw)?;
    if !dist.scale_factor.is_finite()
        || dist.scale_factor <= 0.0
        || !dist.scale_offset.is_finite()
        || !echoes_in_range(&dist, &scan.dist_raw)
    {
        return Err(ColaError::InvalidScale {
            scale_factor: dist.scale_factor,
            scale_offset: dist.scale_offset,
        });
    }
    if dist.step_1e4deg == 0 && scan.dist_raw.len() > 1 {
        return Err(ColaError::ZeroAngularStep);
    }
    scan.start_angle_sick_1e4deg = dist.start_angle_1e4deg;
    scan.step_1e4deg = dist.step_1e4deg;
    scan.scale_factor = dist.scale_factor;
    scan.scale_offset = dist.scale_offset;
    Ok(())
}

/// The 16-bit then the 8-bit channels: the first `DIST1`'s header, its data
/// in `dist_raw`.
fn parse_channels<'a>(tokens: &mut Tokens<'a>, dist_raw: &mut Vec<u16>) -> Result<ChannelHeader<'a>, ColaError> {
    let mut dist: Option<ChannelHeader<'a>> = None;
    // A channel is at least 6 tokens (content … number of data).
    for data_max in [u32::from(u16::MAX), u32::from(u8::MAX)] {
        let field = if data_max == u32::from(u16::MAX) {
            "number of 16-bit channels"
        } else {
            "number of 8-bit channels"
        };
        for _ in 0..tokens.count(field, 6)? {
            let keep = dist.is_none().then_some(&mut *dist_raw);
            let channel = parse_channel(tokens, data_max, keep)?;
            if dist.is_none() && channel.name == DIST1 {
                dist = Some(channel);
            }
        }
    }
    dist.ok_or(ColaError::NoDistanceChannel)
}

impl ScanTelegram {
    /// The scan in Furrow's scanner frame (clockwise from forward, metres),
    /// stamped `t` (the receiver's clock at arrival).
    pub fn to_scan(&self, t: Duration) -> Scan {
        let mut scan = Scan {
            t,
            scan_counter: 0,
            start_angle_rad: 0.0,
            step_rad: 0.0,
            ranges_m: Vec::with_capacity(self.dist_raw.len()),
        };
        self.to_scan_into(t, &mut scan);
        scan
    }

    /// [`Self::to_scan`] into `scan`, reusing its range buffer.
    pub fn to_scan_into(&self, t: Duration, scan: &mut Scan) {
        let start_deg = (SICK_FORWARD_1E4DEG - f64::from(self.start_angle_sick_1e4deg)) / 1e4;
        let step_deg = -f64::from(self.step_1e4deg) / 1e4;
        let scale = f64::from(self.scale_factor);
        let offset = f64::from(self.scale_offset);
        scan.ranges_m.clear();
        if scale == 1.0 && offset == 0.0 {
            // Millimetres as sent (what the LMS1xx sends): the f32 quotient
            // is the f64 one rounded to f32 (a double holds more than twice
            // a float's digits, so rounding twice changes nothing), and
            // twice as many fit a vector.
            scan.ranges_m.extend(
                self.dist_raw
                    .iter()
                    .map(|&raw| if raw == 0 { f32::NAN } else { f32::from(raw) / 1000.0 }),
            );
        } else {
            scan.ranges_m.extend(self.dist_raw.iter().map(|&raw| {
                if raw == 0 {
                    f32::NAN
                } else {
                    ((f64::from(raw) * scale + offset) / 1000.0) as f32
                }
            }));
        }
        scan.t = t;
        scan.scan_counter = self.scan_counter;
        scan.start_angle_rad = start_deg.to_radians();
        scan.step_rad = step_deg.to_radians();
    }
}

/// Millimetres for one range; 0 (no echo) for NaN, negative, or beyond the
/// 16-bit field (65.535 m: further than any LMS1xx sees). A finite range that
/// rounds to 0 mm becomes 1 mm so an echo at the window is never read as
/// "nothing there".
fn range_to_mm(range_m: f32) -> u16 {
    let mm = f64::from(range_m) * 1000.0;
    // NaN, negative and too far all fail this one test. Branch-free below,
    // so a scan's ranges convert several at a time.
    let representable = mm >= 0.0 && mm < f64::from(u16::MAX) + 0.5;
    // What `mm.round()` gives (half away from zero), without the libm call
    // per beam: the fraction of a non-negative double below 2^16 is exact.
    let whole = mm as u16;
    let rounded = whole.saturating_add(u16::from(mm - f64::from(whole) >= 0.5)).max(1);
    if representable { rounded } else { 0 }
}

/// The telegram an LMS1xx would send for `scan` (inverse of
/// [`ScanTelegram::to_scan`]; scale factor 1, offset 0, ranges rounded to mm,
/// NaN → 0). Used by the simulator so SITL drives the real parser.
///
/// The format can only say what the scanner can: angles are quantised to
/// 1/10000° (a step that is not a multiple of it drifts by up to
/// n · 0.5e-4° at beam n, so simulate real steps such as 0.5°), the step is
/// unsigned anticlockwise (a clockwise scan, `step_rad > 0`, is sent
/// reversed, last beam first, as the same set of beams), at most 6.5535°
/// and at most 65535 beams (further ones are left out).
pub fn telegram_from_scan(scan: &Scan, scan_frequency_hz: f64, telegram_counter: u32) -> ScanTelegram {
    let mut telegram = ScanTelegram::default();
    telegram.set_from_scan(scan, scan_frequency_hz, telegram_counter);
    telegram
}

impl ScanTelegram {
    /// [`telegram_from_scan`] into this telegram, reusing its buffers.
    pub fn set_from_scan(&mut self, scan: &Scan, scan_frequency_hz: f64, telegram_counter: u32) {
        let n = scan.ranges_m.len().min(usize::from(u16::MAX));
        let clockwise = scan.step_rad > 0.0 && n > 1;
        let (start_rad, step_rad) = if clockwise {
            (scan.angle_rad(n - 1), -scan.step_rad)
        } else {
            (scan.start_angle_rad, scan.step_rad)
        };
        self.set_ranges(&scan.ranges_m[..n], clockwise);
        // `as` saturates (NaN → 0), which is the clamping wanted here.
        let start_angle_sick_1e4deg = (SICK_FORWARD_1E4DEG - start_rad.to_degrees() * 1e4).round() as i32;
        let step_1e4deg = ((-step_rad.to_degrees() * 1e4).round() as u32).min(u32::from(u16::MAX));
        let scan_frequency_hz = (scan_frequency_hz * 100.0).round().max(0.0) / 100.0;
        let measurement_frequency_hz = if step_1e4deg > 0 {
            // Beams per revolution × revolutions per second, in SICK's 100 Hz unit.
            ((360.0 * 1e4 / f64::from(step_1e4deg)) * scan_frequency_hz / 100.0).round() * 100.0
        } else {
            0.0
        };
        // µs since start-up, wrapping like the scanner's own 32-bit clock.
        let t_us = (scan.t.as_micros() % (1u128 << 32)) as u32;
        self.version = 1;
        self.device_number = 1;
        self.serial_number = 0;
        self.device_status = [0, 0];
        self.telegram_counter = telegram_counter;
        self.scan_counter = scan.scan_counter;
        self.time_since_startup_us = t_us;
        self.time_of_transmission_us = t_us;
        self.digital_inputs = [0, 0];
        self.digital_outputs = [0, 0];
        self.scan_frequency_hz = scan_frequency_hz;
        self.measurement_frequency_hz = measurement_frequency_hz;
        self.encoders.clear();
        self.start_angle_sick_1e4deg = start_angle_sick_1e4deg;
        self.step_1e4deg = step_1e4deg;
        self.scale_factor = 1.0;
        self.scale_offset = 0.0;
    }
}

impl ScanTelegram {
    /// `dist_raw` for `ranges_m`, last beam first if `clockwise`. A block
    /// of beams without an echo is left at 0 at once (most of a scan in
    /// open space).
    fn set_ranges(&mut self, ranges_m: &[f32], clockwise: bool) {
        let n = ranges_m.len();
        self.dist_raw.clear();
        self.dist_raw.resize(n, 0);
        for (block, block_ranges_m) in ranges_m.chunks(NO_ECHO_BLOCK).enumerate() {
            if block_ranges_m.iter().all(|r| r.is_nan()) {
                continue;
            }
            for (i, &range_m) in block_ranges_m.iter().enumerate() {
                let beam = block * NO_ECHO_BLOCK + i;
                let slot = if clockwise { n - 1 - beam } else { beam };
                self.dist_raw[slot] = range_to_mm(range_m);
            }
        }
    }
}

/// Beams looked at together for an echo when a scan is converted.
const NO_ECHO_BLOCK: usize = 8;

/// A complete `STX sSN LMDscandata … ETX` telegram for `scan`: one DIST1
/// 16-bit channel, no 8-bit channels, every optional block absent. Fields
/// wider than the format are clamped; more than 65535 beams are cut.
pub fn encode_lmd_scandata(scan: &ScanTelegram) -> Vec<u8> {
    let mut out = Vec::new();
    encode_lmd_scandata_into(scan, &mut out);
    out
}

/// [`encode_lmd_scandata`] into `out` (cleared first), so a caller that
/// keeps the buffer encodes every scan without allocating.
pub fn encode_lmd_scandata_into(scan: &ScanTelegram, out: &mut Vec<u8>) {
    let clamp_u32 = |x: f64| x.round().clamp(0.0, f64::from(u32::MAX)) as u32;
    let n = scan.dist_raw.len().min(usize::from(u16::MAX));
    out.clear();
    out.reserve(160 + 5 * n);
    out.extend_from_slice(b"\x02sSN LMDscandata");
    let header = [
        u32::from(scan.version),
        u32::from(scan.device_number),
        scan.serial_number,
        u32::from(scan.device_status[0]),
        u32::from(scan.device_status[1]),
        scan.telegram_counter,
        scan.scan_counter,
        scan.time_since_startup_us,
        scan.time_of_transmission_us,
        u32::from(scan.digital_inputs[0]),
        u32::from(scan.digital_inputs[1]),
        u32::from(scan.digital_outputs[0]),
        u32::from(scan.digital_outputs[1]),
        // Reserved.
        0,
        clamp_u32(scan.scan_frequency_hz * 100.0),
        clamp_u32(scan.measurement_frequency_hz / 100.0),
    ];
    for value in header {
        push_hex(out, value);
    }
    let encoders = &scan.encoders[..scan.encoders.len().min(usize::from(u16::MAX))];
    push_hex(out, encoders.len() as u32);
    for encoder in encoders {
        push_hex(out, encoder.position_ticks);
        push_hex(out, u32::from(encoder.speed_raw));
    }
    out.extend_from_slice(b" 1 DIST1");
    push_hex_8_digits(out, scan.scale_factor.to_bits());
    push_hex_8_digits(out, scan.scale_offset.to_bits());
    // Two's complement: the bit pattern is the signed value.
    push_hex(out, scan.start_angle_sick_1e4deg as u32);
    push_hex(out, scan.step_1e4deg.min(u32::from(u16::MAX)));
    push_hex(out, n as u32);
    push_hex_u16s(out, &scan.dist_raw[..n]);
    // 8-bit channels, position, name, comment, time, event info: all absent.
    out.extend_from_slice(b" 0 0 0 0 0 0\x03");
}

const HEX_DIGITS: &[u8; 16] = b"0123456789ABCDEF";

/// Appends a space and `value` in upper-case hex without leading zeros
/// (what `{:X}` writes), one table look-up per digit.
fn push_hex(out: &mut Vec<u8>, value: u32) {
    let digits = (8 - value.leading_zeros() as usize / 4).max(1);
    let mut text = [b' '; 9];
    for (i, slot) in text[1..=digits].iter_mut().enumerate() {
        let shift = 4 * (digits - 1 - i);
        *slot = HEX_DIGITS[((value >> shift) & 0xF) as usize];
    }
    out.extend_from_slice(&text[..=digits]);
}

/// Appends ` {:X}` of each value: the buffer is grown once for the longest
/// text, and each value's space and digits are written as one 8-byte word
/// (a scan is hundreds of values), four no-echo beams as one.
fn push_hex_u16s(out: &mut Vec<u8>, values: &[u16]) {
    let start = out.len();
    // 5 bytes at most per value, and room for the last word's 3 spare bytes.
    out.resize(start + 5 * values.len() + 3, 0);
    let mut end = start;
    let mut fours = values.chunks_exact(NO_ECHO_RUN_BEAMS);
    for four in &mut fours {
        if four.iter().any(|&v| v != 0) {
            for &value in four {
                end = write_hex_u16(out, end, value);
            }
        } else {
            out[end..end + NO_ECHO_RUN.len()].copy_from_slice(NO_ECHO_RUN);
            end += NO_ECHO_RUN.len();
        }
    }
    for &value in fours.remainder() {
        end = write_hex_u16(out, end, value);
    }
    out.truncate(end);
}

/// Writes ` {:X}` of `value` at `at` as one 8-byte word (the bytes after
/// its text are scratch); returns where its text ends.
#[inline(always)]
fn write_hex_u16(out: &mut [u8], at: usize, value: u16) -> usize {
    let digits = (19 - (value | 1).leading_zeros() as usize) / 4;
    let [high, low] = value.to_be_bytes();
    let [a, b] = HEX_PAIRS[usize::from(high)];
    let [c, d] = HEX_PAIRS[usize::from(low)];
    // The four digits, the leading zeros shifted out, a space in front.
    let four = u64::from_le_bytes([a, b, c, d, 0, 0, 0, 0]) >> (8 * (4 - digits));
    let word = (four << 8) | u64::from(b' ');
    out[at..at + 8].copy_from_slice(&word.to_le_bytes());
    at + 1 + digits
}

/// Each byte as two upper-case hex digits.
const HEX_PAIRS: [[u8; 2]; 256] = {
    let mut table = [[0; 2]; 256];
    let mut i = 0;
    while i < 256 {
        table[i] = [HEX_DIGITS[i >> 4], HEX_DIGITS[i & 0xF]];
        i += 1;
    }
    table
};

/// Appends a space and all eight hex digits of `value` (`{:08X}`).
fn push_hex_8_digits(out: &mut Vec<u8>, value: u32) {
    let mut text = [b' '; 9];
    for (i, slot) in text[1..].iter_mut().enumerate() {
        *slot = HEX_DIGITS[((value >> (28 - 4 * i)) & 0xF) as usize];
    }
    out.extend_from_slice(&text);
}

// ---------------------------------------------------------------------------
// Commands and answers

/// Poll one scan: the scanner answers `sRA LMDscandata …`.
pub fn request_scan() -> &'static [u8] {
    b"\x02sRN LMDscandata\x03"
}

/// Start (`on`) or stop the continuous `sSN LMDscandata` stream; the scanner
/// acknowledges with `sEA LMDscandata 1` / `0`.
pub fn subscribe(on: bool) -> &'static [u8] {
    if on {
        b"\x02sEN LMDscandata 1\x03"
    } else {
        b"\x02sEN LMDscandata 0\x03"
    }
}

/// Any telegram the scanner may send a client, sorted for the client.
#[derive(Clone, Debug, PartialEq)]
pub enum ColaTelegram {
    /// `sRA`/`sSN LMDscandata`.
    ScanData(Box<ScanTelegram>),
    /// `sEA <event> <0|1>`: the subscription is now on or off.
    EventAck { event: String, subscribed: bool },
    /// `sFA <code>`: the scanner refused the last request.
    Error { code: u16 },
    /// Anything else (`sAN`, `sWA`, …), by its first two tokens.
    Other { command_type: String, name: String },
}

/// Sorts one telegram (with or without STX/ETX) by its command type.
pub fn parse_telegram(telegram: &[u8]) -> Result<ColaTelegram, ColaError> {
    let mut tokens = Tokens::new(telegram);
    let command_type = tokens.raw("command type").map_err(|_| ColaError::Empty)?;
    match command_type {
        b"sFA" => Ok(ColaTelegram::Error {
            code: tokens.hex_u16("error code")?,
        }),
        b"sEA" => {
            let event = quote(tokens.raw("event name")?);
            let subscribed = match tokens.raw("subscription state")? {
                b"1" => true,
                b"0" => false,
                other => {
                    return Err(ColaError::BadFlag {
                        field: "subscription state",
                        token: quote(other),
                    });
                }
            };
            Ok(ColaTelegram::EventAck { event, subscribed })
        }
        b"sRA" | b"sSN" if tokens.peek() == Some(SCAN_DATA) => {
            tokens.skip("command name")?;
            let mut scan = Box::<ScanTelegram>::default();
            parse_scan_fields(&mut tokens, &mut scan).map(|()| ColaTelegram::ScanData(scan))
        }
        _ => Ok(ColaTelegram::Other {
            command_type: quote(command_type),
            name: tokens.raw("command name").map(quote).unwrap_or_default(),
        }),
    }
}

/// SOPAS error names for `sFA` codes, as SICK's drivers list them.
pub fn sopas_error_name(code: u16) -> Option<&'static str> {
    const NAMES: [&str; 21] = [
        "Ok",
        "METHODIN_ACCESSDENIED",
        "METHODIN_UNKNOWNINDEX",
        "VARIABLE_UNKNOWNINDEX",
        "LOCALCONDITIONFAILED",
        "INVALID_DATA",
        "UNKNOWN_ERROR",
        "BUFFER_OVERFLOW",
        "BUFFER_UNDERFLOW",
        "ERROR_UNKNOWN_TYPE",
        "VARIABLE_WRITE_ACCESSDENIED",
        "UNKNOWN_CMD_FOR_NAMESERVER",
        "UNKNOWN_COLA_COMMAND",
        "METHODIN_SERVER_BUSY",
        "FLEX_OUT_OF_BOUNDS",
        "EVENTREG_UNKNOWNINDEX",
        "COLA_A_VALUE_OVERFLOW",
        "COLA_A_INVALID_CHARACTER",
        "OSAI_NO_MESSAGE",
        "OSAI_NO_ANSWER_MESSAGE",
        "INTERNAL",
    ];
    NAMES.get(usize::from(code)).copied()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Written out field by field from the published layout (see the module
    /// doc), not produced by `encode_lmd_scandata`.
    const LMS1XX_SRA: &str = "sRA LMDscandata 1 1 10A2F3C 0 0 2B3 2B7 5F5E100 5F5E4E8 0 0 7 0 0 1388 168 0 \
                              1 DIST1 3F800000 00000000 FFF92230 1388 5 1F4 0 3E8 FFFF 64 \
                              0 0 0 0 0 0";

    /// Streamed, with an encoder, RSSI1 before DIST1, a non-unit scale and
    /// offset, an 8-bit channel, and a device name and time stamp block.
    const STREAMED_SSN: &str = "sSN LMDscandata 1 1 A1B2C3 0 0 10 11 1000 1010 0 0 0 0 0 9C4 1C2 1 5DC 64 \
                                2 RSSI1 3F800000 00000000 0 2710 3 FF 80 0 \
                                DIST1 40000000 3F800000 0 2710 3 A 14 0 \
                                1 RSSI2 3F800000 00000000 0 2710 3 1 2 3 \
                                0 1 7 LMS-111 0 1 7E8 1 F 8 1E 2D 0 0";

    fn framed(body: &str) -> Vec<u8> {
        let mut v = vec![STX];
        v.extend_from_slice(body.as_bytes());
        v.push(ETX);
        v
    }

    fn deg(d: f64) -> f64 {
        d.to_radians()
    }

    #[test]
    fn parses_hand_written_lms1xx_answer() {
        let t = parse_lmd_scandata(&framed(LMS1XX_SRA)).unwrap();
        assert_eq!(t.version, 1);
        assert_eq!(t.device_number, 1);
        assert_eq!(t.serial_number, 0x10A2F3C);
        assert_eq!(t.device_status, [0, 0]);
        assert_eq!(t.telegram_counter, 691);
        assert_eq!(t.scan_counter, 695);
        assert_eq!(t.time_since_startup_us, 100_000_000);
        assert_eq!(t.time_of_transmission_us, 100_001_000);
        assert_eq!(t.digital_outputs, [7, 0]);
        assert_eq!(t.scan_frequency_hz, 50.0);
        assert_eq!(t.measurement_frequency_hz, 36_000.0);
        assert!(t.encoders.is_empty());
        assert_eq!(t.start_angle_sick_1e4deg, -450_000);
        assert_eq!(t.step_1e4deg, 5000);
        assert_eq!(t.scale_factor, 1.0);
        assert_eq!(t.scale_offset, 0.0);
        assert_eq!(t.dist_raw, vec![500, 0, 1000, 65535, 100]);

        let scan = t.to_scan(Duration::from_millis(1234));
        assert_eq!(scan.t, Duration::from_millis(1234));
        assert_eq!(scan.scan_counter, 695);
        // SICK −45° (right-rear) is 135° clockwise from forward.
        assert!((scan.start_angle_rad - deg(135.0)).abs() < 1e-12);
        assert!((scan.step_rad - deg(-0.5)).abs() < 1e-12);
        assert!((scan.angle_rad(4) - deg(133.0)).abs() < 1e-12);
        assert_eq!(scan.ranges_m[0], 0.5);
        assert!(scan.ranges_m[1].is_nan());
        assert_eq!(scan.ranges_m[2], 1.0);
        assert_eq!(scan.ranges_m[3], 65.535);
        assert_eq!(scan.ranges_m[4], 0.1);
    }

    #[test]
    fn straight_ahead_and_left_map_to_zero_and_minus_ninety() {
        // SICK 90° is ahead, 180° is the scanner's left.
        let mut t = parse_lmd_scandata(LMS1XX_SRA.as_bytes()).unwrap();
        t.start_angle_sick_1e4deg = 900_000;
        t.step_1e4deg = 900_000 / 4;
        let scan = t.to_scan(Duration::ZERO);
        assert!(scan.angle_rad(0).abs() < 1e-12);
        assert!((scan.angle_rad(4) - deg(-90.0)).abs() < 1e-12);
    }

    #[test]
    fn parses_streamed_telegram_with_extra_channels_and_trailer() {
        let t = parse_lmd_scandata(STREAMED_SSN.as_bytes()).unwrap();
        assert_eq!(t.serial_number, 0xA1B2C3);
        assert_eq!(t.telegram_counter, 16);
        assert_eq!(t.scan_counter, 17);
        assert_eq!(t.scan_frequency_hz, 25.0);
        assert_eq!(t.measurement_frequency_hz, 45_000.0);
        assert_eq!(
            t.encoders,
            vec![EncoderReading {
                position_ticks: 1500,
                speed_raw: 100
            }]
        );
        assert_eq!(t.scale_factor, 2.0);
        assert_eq!(t.scale_offset, 1.0);
        assert_eq!(t.start_angle_sick_1e4deg, 0);
        assert_eq!(t.step_1e4deg, 10_000);
        assert_eq!(t.dist_raw, vec![10, 20, 0]);
        let scan = t.to_scan(Duration::ZERO);
        assert!((scan.start_angle_rad - deg(90.0)).abs() < 1e-12);
        assert!((scan.step_rad - deg(-1.0)).abs() < 1e-12);
        // (raw · 2 + 1) mm
        assert!((scan.ranges_m[0] - 0.021).abs() < 1e-7);
        assert!((scan.ranges_m[1] - 0.041).abs() < 1e-7);
        assert!(scan.ranges_m[2].is_nan());
    }

    #[test]
    fn dist1_in_an_8_bit_channel_is_found() {
        let body = "sSN LMDscandata 1 1 0 0 0 1 2 0 0 0 0 0 0 0 1388 168 0 0 \
                    1 DIST1 3F800000 00000000 FFF92230 1388 2 FF 1 0 0 0 0 0";
        let t = parse_lmd_scandata(body.as_bytes()).unwrap();
        assert_eq!(t.dist_raw, vec![255, 1]);
    }

    fn replaced(from: &str, to: &str) -> String {
        assert!(LMS1XX_SRA.contains(from), "{from}");
        LMS1XX_SRA.replacen(from, to, 1)
    }

    /// A telegram body and the test its error must pass.
    type MalformedCase = (String, fn(&ColaError) -> bool);

    #[test]
    fn every_malformed_variant_is_an_error() {
        let cases: Vec<MalformedCase> = vec![
            (String::new(), |e| *e == ColaError::Empty),
            ("   ".into(), |e| *e == ColaError::Empty),
            (replaced("LMDscandata", "LMDscandatacfg"), |e| {
                matches!(e, ColaError::UnexpectedCommand { .. })
            }),
            (replaced("sRA", "sRN"), |e| {
                matches!(e, ColaError::UnexpectedCommand { .. })
            }),
            ("sEA LMDscandata 1".into(), |e| {
                matches!(e, ColaError::UnexpectedCommand { .. })
            }),
            ("sRA LMDscandata 1 1".into(), |e| {
                *e == ColaError::MissingField { field: "serial number" }
            }),
            (replaced("10A2F3C", "10G2F3C"), |e| {
                matches!(
                    e,
                    ColaError::BadHex {
                        field: "serial number",
                        ..
                    }
                )
            }),
            (replaced("10A2F3C", "110A2F3C0"), |e| {
                matches!(
                    e,
                    ColaError::BadHex {
                        field: "serial number",
                        ..
                    }
                )
            }),
            (replaced("1388 168", "-1388 168"), |e| {
                matches!(
                    e,
                    ColaError::BadHex {
                        field: "scan frequency",
                        ..
                    }
                )
            }),
            (replaced(" 1 1 10A2F3C", " 10000 1 10A2F3C"), |e| {
                matches!(
                    e,
                    ColaError::OutOfRange {
                        field: "version number",
                        value: 0x10000,
                        ..
                    }
                )
            }),
            (replaced("1388 5 1F4", "1388 FFFF 1F4"), |e| {
                matches!(
                    e,
                    ColaError::CountExceedsTokens {
                        field: "number of data",
                        count: 0xFFFF,
                        ..
                    }
                )
            }),
            (replaced("1388 5 1F4", "1388 C 1F4"), |e| {
                matches!(
                    e,
                    ColaError::CountExceedsTokens {
                        field: "number of data",
                        count: 12,
                        remaining: 11
                    }
                )
            }),
            (replaced("168 0 1 DIST1", "168 A 1 DIST1"), |e| {
                matches!(
                    e,
                    ColaError::CountExceedsTokens {
                        field: "number of encoders",
                        ..
                    }
                )
            }),
            (replaced("168 0 1 DIST1", "168 0 4 DIST1"), |e| {
                matches!(
                    e,
                    ColaError::CountExceedsTokens {
                        field: "number of 16-bit channels",
                        ..
                    }
                )
            }),
            (replaced("3F800000", "7F800000"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced("3F800000", "7FC00000"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced("3F800000", "BF800000"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced("3F800000", "0"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced("00000000", "FF800000"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            // Found by fuzzing: a factor of f32::MAX gave infinite ranges,
            // an offset of -1000 mm negative ones.
            (replaced("3F800000", "7F7FFFFF"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced("00000000", "C47A0000"), |e| {
                matches!(e, ColaError::InvalidScale { .. })
            }),
            (replaced(" FFFF 64", " 10000 64"), |e| {
                matches!(
                    e,
                    ColaError::OutOfRange {
                        field: "channel data",
                        value: 0x10000,
                        max: 0xFFFF
                    }
                )
            }),
            (replaced("DIST1", "DIST2"), |e| *e == ColaError::NoDistanceChannel),
            (replaced("FFF92230 1388", "FFF92230 0"), |e| {
                *e == ColaError::ZeroAngularStep
            }),
            (LMS1XX_SRA.trim_end_matches(" 0 0 0 0 0 0").to_string(), |e| {
                *e == ColaError::MissingField {
                    field: "number of 8-bit channels",
                }
            }),
            (replaced("0 0 0 0 0 0", "1 0 0 0 0 0"), |e| {
                matches!(e, ColaError::CountExceedsTokens { .. })
            }),
        ];
        for (body, expected) in &cases {
            let err = parse_lmd_scandata(body.as_bytes()).expect_err(body);
            assert!(expected(&err), "{body:?} gave {err:?}");
            let message = err.to_string();
            assert!(message.len() > 10, "{message}");
        }
    }

    #[test]
    fn error_messages_name_the_field_and_cut_long_tokens() {
        let long = "Z".repeat(10_000);
        let err = parse_lmd_scandata(replaced("10A2F3C", &long).as_bytes()).unwrap_err();
        let message = err.to_string();
        assert!(message.contains("serial number"), "{message}");
        assert!(message.len() < 100, "{message}");
    }

    #[test]
    fn sorts_answers_and_errors() {
        assert_eq!(
            parse_telegram(b"\x02sEA LMDscandata 1\x03"),
            Ok(ColaTelegram::EventAck {
                event: "LMDscandata".into(),
                subscribed: true
            })
        );
        assert_eq!(
            parse_telegram(b"sEA LMDscandata 0"),
            Ok(ColaTelegram::EventAck {
                event: "LMDscandata".into(),
                subscribed: false
            })
        );
        assert!(matches!(
            parse_telegram(b"sEA LMDscandata 2"),
            Err(ColaError::BadFlag { .. })
        ));
        assert!(matches!(
            parse_telegram(b"sEA LMDscandata"),
            Err(ColaError::MissingField { .. })
        ));
        assert_eq!(parse_telegram(b"\x02sFA 5\x03"), Ok(ColaTelegram::Error { code: 5 }));
        assert_eq!(parse_telegram(b"sFA C"), Ok(ColaTelegram::Error { code: 12 }));
        assert!(matches!(parse_telegram(b"sFA"), Err(ColaError::MissingField { .. })));
        assert!(matches!(parse_telegram(b"sFA ZZ"), Err(ColaError::BadHex { .. })));
        assert_eq!(
            parse_telegram(b"sAN Run 1"),
            Ok(ColaTelegram::Other {
                command_type: "sAN".into(),
                name: "Run".into()
            })
        );
        assert_eq!(parse_telegram(b""), Err(ColaError::Empty));
        match parse_telegram(STREAMED_SSN.as_bytes()) {
            Ok(ColaTelegram::ScanData(t)) => assert_eq!(t.scan_counter, 17),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            parse_telegram(replaced("DIST1", "DIST2").as_bytes()),
            Err(ColaError::NoDistanceChannel)
        ));
        assert_eq!(sopas_error_name(5), Some("INVALID_DATA"));
        assert_eq!(sopas_error_name(999), None);
    }

    #[test]
    fn commands_are_framed_ascii() {
        assert_eq!(request_scan(), b"\x02sRN LMDscandata\x03");
        assert_eq!(subscribe(true), b"\x02sEN LMDscandata 1\x03");
        assert_eq!(subscribe(false), b"\x02sEN LMDscandata 0\x03");
    }

    #[test]
    fn encoder_output_reparses_to_the_same_fields() {
        for body in [LMS1XX_SRA, STREAMED_SSN] {
            let t = parse_lmd_scandata(body.as_bytes()).unwrap();
            let bytes = encode_lmd_scandata(&t);
            assert_eq!(bytes.first(), Some(&STX));
            assert_eq!(bytes.last(), Some(&ETX));
            assert!(bytes.starts_with(b"\x02sSN LMDscandata 1 1 "));
            assert_eq!(parse_lmd_scandata(&bytes), Ok(t));
        }
    }

    #[test]
    fn clockwise_scans_are_sent_reversed() {
        let scan = Scan {
            t: Duration::from_millis(20),
            scan_counter: 9,
            start_angle_rad: deg(-90.0),
            step_rad: deg(5.0),
            ranges_m: vec![1.0, f32::NAN, 3.0, 4.0, 5.0],
        };
        let back = parse_lmd_scandata(&encode_lmd_scandata(&telegram_from_scan(&scan, 50.0, 3)))
            .unwrap()
            .to_scan(scan.t);
        assert!((back.start_angle_rad - deg(-70.0)).abs() < 1e-9);
        assert!((back.step_rad - deg(-5.0)).abs() < 1e-9);
        assert_eq!(back.ranges_m[0], 5.0);
        assert_eq!(back.ranges_m[2], 3.0);
        assert!(back.ranges_m[3].is_nan());
        assert_eq!(back.ranges_m[4], 1.0);
    }

    #[test]
    fn unrepresentable_ranges_become_no_echo_and_tiny_ones_stay_echoes() {
        assert_eq!(range_to_mm(f32::NAN), 0);
        assert_eq!(range_to_mm(f32::INFINITY), 0);
        assert_eq!(range_to_mm(-1.0), 0);
        assert_eq!(range_to_mm(70.0), 0);
        assert_eq!(range_to_mm(0.0), 1);
        assert_eq!(range_to_mm(0.0004), 1);
        assert_eq!(range_to_mm(65.535), 65535);
        assert_eq!(range_to_mm(12.3456), 12346);
    }

    #[test]
    fn millimetres_round_as_f64_round_does() {
        let reference = |r: f32| {
            let mm = (f64::from(r) * 1000.0).round();
            if mm > f64::from(u16::MAX) {
                0
            } else {
                (mm as u16).max(1)
            }
        };
        let halves = (0..=65_536u32).map(|mm| (f64::from(mm) + 0.5) as f32 / 1000.0);
        let edges = [0.0004999f32, 0.0005, 0.0015, 65.5345, 65.5355, 65.536, 1e-30, f32::MAX];
        for r in halves.chain(edges).chain((0..200_000u32).map(|i| i as f32 * 3.3e-4)) {
            for r in [
                r,
                f32::from_bits(r.to_bits() + 1),
                f32::from_bits(r.to_bits().saturating_sub(1)),
            ] {
                assert_eq!(range_to_mm(r), reference(r), "{r}");
            }
        }
    }

    /// Millimetres as an LMS1xx sends them (scale 1, offset 0) become the
    /// ranges the general scaling gives, bit for bit, for every raw value.
    #[test]
    fn unscaled_millimetres_convert_as_the_general_scaling_does() {
        let telegram = ScanTelegram {
            dist_raw: (0..=u16::MAX).collect(),
            step_1e4deg: 1,
            scale_factor: 1.0,
            scale_offset: 0.0,
            ..ScanTelegram::default()
        };
        let scan = telegram.to_scan(Duration::ZERO);
        assert!(scan.ranges_m[0].is_nan());
        for (raw, range_m) in (1..=u16::MAX).zip(&scan.ranges_m[1..]) {
            let general = ((f64::from(raw) * 1.0 + 0.0) / 1000.0) as f32;
            assert_eq!(range_m.to_bits(), general.to_bits(), "raw {raw}");
        }
    }

    #[test]
    fn simulated_telegram_carries_counters_and_frequencies() {
        let scan = Scan {
            t: Duration::from_secs(2),
            scan_counter: 77,
            start_angle_rad: deg(135.0),
            step_rad: deg(-0.5),
            ranges_m: vec![2.0; 541],
        };
        let t = telegram_from_scan(&scan, 50.0, 12);
        assert_eq!((t.telegram_counter, t.scan_counter), (12, 77));
        assert_eq!(t.start_angle_sick_1e4deg, -450_000);
        assert_eq!(t.step_1e4deg, 5000);
        assert_eq!(t.scan_frequency_hz, 50.0);
        assert_eq!(t.measurement_frequency_hz, 36_000.0);
        assert_eq!(t.time_since_startup_us, 2_000_000);
        assert_eq!(t.dist_raw.len(), 541);
    }

    // --- framer ---

    fn drain(framer: &mut ColaFramer) -> Vec<Vec<u8>> {
        std::iter::from_fn(|| framer.pop()).collect()
    }

    #[test]
    fn framer_skips_and_counts_garbage() {
        let mut f = ColaFramer::new();
        f.push(b"xx\x02abc\x03yy\x02def\x03");
        assert_eq!(drain(&mut f), vec![b"abc".to_vec(), b"def".to_vec()]);
        assert_eq!(
            f.stats(),
            FramerStats {
                telegrams: 2,
                skipped_bytes: 4,
                oversized: 0,
                overrun: 0
            }
        );
    }

    #[test]
    fn framer_reassembles_byte_by_byte() {
        let mut f = ColaFramer::new();
        let mut out = Vec::new();
        for b in framed(LMS1XX_SRA).iter().chain(framed("sFA 5").iter()) {
            f.push(std::slice::from_ref(b));
            out.extend(drain(&mut f));
        }
        assert_eq!(out, vec![LMS1XX_SRA.as_bytes().to_vec(), b"sFA 5".to_vec()]);
    }

    #[test]
    fn framer_drops_oversized_and_resynchronises() {
        let mut f = ColaFramer::with_max_len(8);
        f.push(b"\x0212345678\x03\x02123456789\x03\x02ok\x03\x02123456789\x02ok2\x03");
        assert_eq!(
            drain(&mut f),
            vec![b"12345678".to_vec(), b"ok".to_vec(), b"ok2".to_vec()]
        );
        assert_eq!(f.stats().oversized, 2);
        assert_eq!(f.stats().skipped_bytes, 0);
    }

    #[test]
    fn framer_restarts_on_stx_inside_a_telegram() {
        let mut f = ColaFramer::new();
        f.push(b"\x02abc\x02def\x03");
        assert_eq!(drain(&mut f), vec![b"def".to_vec()]);
        assert_eq!(f.stats().skipped_bytes, 4);
    }

    #[test]
    fn framer_bounds_unpopped_telegrams() {
        let mut f = ColaFramer::new();
        for i in 0..40 {
            f.push(format!("\x02t{i}\x03").as_bytes());
        }
        let out = drain(&mut f);
        assert_eq!(out.len(), MAX_PENDING_TELEGRAMS);
        assert_eq!(out[0], b"t8".to_vec());
        assert_eq!(f.stats().overrun, 8);
        assert_eq!(f.stats().telegrams, 40);
    }

    // --- properties ---

    fn stream_byte() -> impl Strategy<Value = u8> {
        prop_oneof![Just(STX), Just(ETX), Just(b' '), Just(b'A'), any::<u8>()]
    }

    fn frame_all(bytes: &[u8], chunks: &[usize], max_len: usize) -> (Vec<Vec<u8>>, FramerStats) {
        let mut f = ColaFramer::with_max_len(max_len);
        let mut out = Vec::new();
        let mut rest = bytes;
        let mut sizes = chunks.iter().cycle();
        while !rest.is_empty() {
            let n = sizes.next().copied().unwrap_or(rest.len()).clamp(1, rest.len());
            f.push(&rest[..n]);
            rest = &rest[n..];
            assert!(f.buffered_len() <= max_len * (MAX_PENDING_TELEGRAMS + 1));
            out.extend(drain(&mut f));
        }
        (out, f.stats())
    }

    /// Reads `count` tokens of `tokens` (each after its gap of spaces) with
    /// [`Tokens::hex_run`] and with a plain token-by-token reader: the same
    /// values or error, and the same tokens left after.
    fn check_hex_run(tokens: &[String], gaps: &[usize], count: usize, max: u32) -> Result<(), TestCaseError> {
        let body: String = tokens.iter().zip(gaps).map(|(t, &gap)| " ".repeat(gap) + t).collect();
        let mut run = Tokens::new(body.as_bytes());
        let mut got = Vec::new();
        let got = run.hex_run("data", count, max, Some(&mut got)).map(|()| got);
        let field = "data";
        let mut plain = body.split(' ').filter(|t| !t.is_empty());
        let expected = (0..count)
            .map(|_| {
                let token = plain.next().ok_or(ColaError::MissingField { field })?;
                let hex = token.len() <= 8 && token.bytes().all(|b| b.is_ascii_hexdigit());
                let bad = || ColaError::BadHex {
                    field,
                    token: quote(token.as_bytes()),
                };
                let value = if hex {
                    u32::from_str_radix(token, 16).map_err(|_| bad())?
                } else {
                    Err(bad())?
                };
                if value > max {
                    return Err(ColaError::OutOfRange { field, value, max });
                }
                Ok(value as u16)
            })
            .collect::<Result<Vec<u16>, ColaError>>();
        prop_assert_eq!(&got, &expected);
        if got.is_ok() {
            let rest: Vec<&str> = plain.collect();
            prop_assert_eq!(run.remaining(), rest.len());
            prop_assert_eq!(
                run.next_token().map(|t| t.to_vec()),
                rest.first().map(|t| t.as_bytes().to_vec())
            );
        }
        Ok(())
    }

    proptest! {
        #[test]
        // Chunks of ≤ 64 bytes hold ≤ 32 telegrams, so nothing overruns.
        fn framer_never_panics_and_is_chunking_independent(
            bytes in proptest::collection::vec(stream_byte(), 0..2000),
            chunks in proptest::collection::vec(1usize..64, 1..8),
            max_len in 0usize..64,
        ) {
            let (whole, whole_stats) = frame_all(&bytes, &[1], max_len);
            let (split, split_stats) = frame_all(&bytes, &chunks, max_len);
            prop_assert_eq!(&whole, &split);
            prop_assert_eq!(whole_stats, split_stats);
            for body in &whole {
                prop_assert!(body.len() <= max_len);
                prop_assert!(!body.contains(&STX) && !body.contains(&ETX));
            }
        }

        #[test]
        fn parsers_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            let _ = parse_lmd_scandata(&bytes);
            let _ = parse_telegram(&bytes);
        }

        #[test]
        fn parsers_never_panic_on_mutated_telegrams(
            base in prop_oneof![Just(LMS1XX_SRA), Just(STREAMED_SSN)],
            edits in proptest::collection::vec(
                (any::<prop::sample::Index>(), 0u8..3, "[0-9A-Fa-fGZ+ -]{0,10}"), 1..4),
        ) {
            let mut tokens: Vec<String> = base.split_whitespace().map(str::to_string).collect();
            for (at, kind, text) in edits {
                let i = at.index(tokens.len() + 1);
                match kind {
                    0 if i < tokens.len() => tokens[i] = text,
                    1 if i < tokens.len() => { tokens.remove(i); }
                    _ => tokens.insert(i, text),
                }
            }
            let body = tokens.join(" ");
            if let Ok(t) = parse_lmd_scandata(body.as_bytes()) {
                let scan = t.to_scan(Duration::ZERO);
                prop_assert_eq!(scan.ranges_m.len(), t.dist_raw.len());
            }
            let _ = parse_telegram(body.as_bytes());
        }

        /// Each beam's millimetres are what `range_to_mm` makes of it, in
        /// the order sent (a clockwise scan last beam first), whatever runs
        /// of no echo lie between.
        #[test]
        fn ranges_convert_beam_by_beam(
            ranges in proptest::collection::vec(prop_oneof![6 => Just(f32::NAN), 1 => -1.0f32..70.0], 0..100),
            clockwise in any::<bool>(),
        ) {
            let mut telegram = ScanTelegram::default();
            telegram.set_ranges(&ranges, clockwise);
            let mut plain: Vec<u16> = ranges.iter().map(|&r| range_to_mm(r)).collect();
            if clockwise {
                plain.reverse();
            }
            prop_assert_eq!(telegram.dist_raw, plain);
        }

        #[test]
        fn scan_round_trips_through_the_wire(
            start_deg in -180.0f64..180.0,
            step_1e4deg in 1u32..=65535,
            counter in any::<u32>(),
            t_us in 0u64..10_000_000_000,
            ranges in proptest::collection::vec(
                prop_oneof![1 => Just(f32::NAN), 4 => 0.001f32..65.0], 0..600),
        ) {
            let scan = Scan {
                t: Duration::from_micros(t_us),
                scan_counter: counter,
                start_angle_rad: start_deg.to_radians(),
                step_rad: -(f64::from(step_1e4deg) / 1e4).to_radians(),
                ranges_m: ranges,
            };
            let telegram = telegram_from_scan(&scan, 50.0, 1);
            let bytes = encode_lmd_scandata(&telegram);
            let mut framer = ColaFramer::new();
            framer.push(&bytes);
            let body = framer.pop().expect("one telegram");
            let parsed = parse_lmd_scandata(&body).unwrap();
            prop_assert_eq!(&parsed, &telegram);
            let back = parsed.to_scan(scan.t);
            prop_assert_eq!(back.scan_counter, counter);
            prop_assert_eq!(back.ranges_m.len(), scan.ranges_m.len());
            let tol_rad = 1e-4f64.to_radians();
            for i in 0..scan.ranges_m.len() {
                prop_assert!((back.angle_rad(i) - scan.angle_rad(i)).abs() <= tol_rad,
                    "beam {} angle {} vs {}", i, back.angle_rad(i), scan.angle_rad(i));
                let (a, b) = (scan.ranges_m[i], back.ranges_m[i]);
                if a.is_nan() {
                    prop_assert!(b.is_nan());
                } else {
                    prop_assert!((a - b).abs() <= 0.5e-3 + 1e-5, "beam {} range {} vs {}", i, a, b);
                }
            }
        }

        /// Every field the encoder writes comes back from the parser,
        /// whatever its value, and parsing into a telegram left over from
        /// another scan (as the simulator does) gives the same as a fresh one.
        #[test]
        fn any_telegram_round_trips_through_encoder_and_parser(
            header in proptest::collection::vec(any::<u32>(), 9),
            status in proptest::collection::vec(any::<u16>(), 6),
            start_1e4deg in any::<i32>(),
            step_1e4deg in 1u32..=65535,
            scale_factor in 1e-3f32..1e3,
            scale_offset in -1.0f32..1e3,
            encoders in proptest::collection::vec((any::<u32>(), any::<u16>()), 0..4),
            dist_raw in proptest::collection::vec(any::<u16>(), 0..700),
            previous in proptest::collection::vec(any::<u16>(), 0..700),
        ) {
            let telegram = ScanTelegram {
                version: status[0],
                device_number: status[1],
                serial_number: header[0],
                device_status: [status[2], status[3]],
                telegram_counter: header[1],
                scan_counter: header[2],
                time_since_startup_us: header[3],
                time_of_transmission_us: header[4],
                digital_inputs: [status[4], status[5]],
                digital_outputs: [(header[5] & 0xFFFF) as u16, (header[6] & 0xFFFF) as u16],
                // Whole units of the wire's 1/100 Hz and 100 Hz.
                scan_frequency_hz: f64::from(header[7]) / 100.0,
                measurement_frequency_hz: f64::from(header[8] >> 8) * 100.0,
                encoders: encoders
                    .iter()
                    .map(|&(position_ticks, speed_raw)| EncoderReading { position_ticks, speed_raw })
                    .collect(),
                start_angle_sick_1e4deg: start_1e4deg,
                step_1e4deg,
                scale_factor,
                scale_offset: scale_offset.max(0.0),
                dist_raw,
            };
            let mut bytes = vec![b'x'; 3];
            encode_lmd_scandata_into(&telegram, &mut bytes);
            prop_assert_eq!(&bytes, &encode_lmd_scandata(&telegram));
            let fresh = parse_lmd_scandata(&bytes).unwrap();
            prop_assert_eq!(&fresh, &telegram);
            let mut reused = telegram_from_scan(
                &Scan {
                    t: Duration::ZERO,
                    scan_counter: 7,
                    start_angle_rad: 0.1,
                    step_rad: 0.01,
                    ranges_m: previous.iter().map(|&r| f32::from(r) / 1000.0).collect(),
                },
                25.0,
                9,
            );
            parse_lmd_scandata_into(&bytes, &mut reused).unwrap();
            prop_assert_eq!(&reused, &telegram);
        }

        /// The one-pass check agrees with the minimum and maximum echo
        /// taken the plain way.
        #[test]
        fn echo_range_check_matches_the_plain_min_and_max(
            data in proptest::collection::vec(prop_oneof![Just(0u16), Just(1u16), Just(u16::MAX), any::<u16>()], 0..50),
            scale_factor in prop_oneof![Just(f32::MAX), 1e-3f32..1e36],
            scale_offset in prop_oneof![Just(0.0f32), -1e3f32..1e3],
        ) {
            let channel = ChannelHeader {
                name: DIST1,
                scale_factor,
                scale_offset,
                start_angle_1e4deg: 0,
                step_1e4deg: 1,
            };
            let echoes = data.iter().filter(|&&raw| raw != 0);
            let range_m = |raw: u16| (f64::from(raw) * f64::from(scale_factor) + f64::from(scale_offset)) / 1000.0;
            let plain = match (echoes.clone().min(), echoes.max()) {
                (Some(&min), Some(&max)) => range_m(min) >= 0.0 && (range_m(max) as f32).is_finite(),
                _ => true,
            };
            prop_assert_eq!(echoes_in_range(&channel, &data), plain);
        }

        /// The run reader gives what reading the tokens one by one does: the
        /// same values, or the same error at the same token, whatever the
        /// spacing and the digits.
        #[test]
        fn hex_run_matches_reading_token_by_token(
            tokens in proptest::collection::vec(
                prop_oneof![8 => "[0-9A-F]{1,4}", 1 => "[0-9a-fA-F]{5,9}", 1 => "[0-9A-Fa-fGz+ -]{0,6}"], 0..40),
            gaps in proptest::collection::vec(1usize..3, 40),
            count in 0usize..44,
            max in prop_oneof![Just(0xFFu32), Just(0xFFFFu32)],
        ) {
            check_hex_run(&tokens, &gaps, count, max)?;
        }

        /// Runs of no-echo beams (`0`, read four at a time) among tokens that
        /// start or continue like one (`00`, `0A`, `0G`) and spacing that
        /// breaks a run: read as token by token.
        #[test]
        fn no_echo_runs_read_as_token_by_token(
            tokens in proptest::collection::vec(
                prop_oneof![12 => Just("0"), 1 => Just("00"), 1 => Just("0A"), 1 => Just("0G"), 1 => Just("1"), 1 => Just("")],
                0..40),
            gaps in proptest::collection::vec(prop_oneof![8 => Just(1usize), 1 => Just(2)], 40),
            count in 0usize..44,
            max in prop_oneof![Just(0xFFu32), Just(0xFFFFu32)],
        ) {
            let tokens: Vec<String> = tokens.into_iter().map(str::to_owned).collect();
            check_hex_run(&tokens, &gaps, count, max)?;
        }

        /// The word-at-a-time count of token starts is the plain pairwise one.
        #[test]
        fn token_start_count_matches_the_pairwise_count(
            body in proptest::collection::vec(
                prop_oneof![4 => Just(b' '), 1 => Just(0xA0u8), 1 => Just(0x21u8), 1 => Just(0x1Fu8), 3 => any::<u8>()], 0..80),
            needed in 0usize..40,
        ) {
            let plain = body.windows(2).filter(|pair| pair[0] == b' ' && pair[1] != b' ').count();
            prop_assert_eq!(token_starts_after_spaces(&body, usize::MAX), plain);
            // Counted only as far as needed: at least that many when there
            // are, never more than there are.
            let limited = token_starts_after_spaces(&body, needed);
            prop_assert!(limited >= needed.min(plain) && limited <= plain, "{} of {} needed {}", limited, plain, needed);
        }

        /// The table-driven hex writer writes what `{:X}` and `{:08X}` do.
        #[test]
        fn hex_writer_matches_the_formatter(
            value in any::<u32>(),
            small in 0u32..0x100,
            // Half no echo: runs of four are written as one word.
            beams in proptest::collection::vec(prop_oneof![any::<u16>(), Just(0u16)], 0..40),
        ) {
            for v in [value, small] {
                let mut out = Vec::new();
                push_hex(&mut out, v);
                push_hex_8_digits(&mut out, v);
                prop_assert_eq!(String::from_utf8(out).unwrap(), format!(" {v:X} {v:08X}"));
            }
            let mut out = b"head".to_vec();
            push_hex_u16s(&mut out, &beams);
            let expected: String = beams.iter().map(|b| format!(" {b:X}")).collect();
            prop_assert_eq!(String::from_utf8(out).unwrap(), format!("head{expected}"));
        }
    }
}
