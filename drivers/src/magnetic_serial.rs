//! The magnetic guide sensor pair over a serial line: a binary frame format,
//! its sans-IO parser ([`MagneticFramer`]) and the device thread
//! ([`MagneticSerial`]) that reads a port and keeps the newest
//! [`MagneticSample`].
//!
//! # Frame format (for sensor adapters)
//!
//! Two 16-probe bars (front and rear) are reported together in one 8-byte
//! frame, little-endian, no padding:
//!
//! | offset | size | content                                                   |
//! |--------|------|-----------------------------------------------------------|
//! | 0      | 1    | sync `0xA5`                                               |
//! | 1      | 1    | sync `0x5A`                                               |
//! | 2      | 2    | front mask, u16 LE                                        |
//! | 4      | 2    | rear mask, u16 LE                                         |
//! | 6      | 1    | sequence counter, +1 per frame, wraps 255 → 0             |
//! | 7      | 1    | CRC-8/SMBUS of bytes 2..=6 (the 5 bytes after the sync)   |
//!
//! - Masks: bit i−1 is probe i, probe 1 is the rightmost looking forward; a
//!   set bit means the probe is over the tape (see [`crate::magnetic`]).
//! - CRC-8/SMBUS: polynomial 0x07 (x⁸ + x² + x + 1), initial value 0x00, no
//!   reflection, no final XOR; check value 0xF4 for the ASCII bytes
//!   `123456789`. [`crc8_smbus`] and [`encode_frame`] are a reference.
//! - Line: 8 data bits, no parity, 1 stop bit, any baud from 9600 to 115200
//!   (set the same on both ends); 50–100 frames per second (8 bytes at
//!   100 Hz is 8 % of 9600 baud). Frames are sent back to back or with any
//!   gap; there is no request, the sensor just streams.
//!
//! The parser looks for the sync pair, checks the CRC and otherwise skips one
//! byte and looks again, so it resynchronises after noise, a cut frame or
//! a sensor started mid-stream; a sync pair inside the masks is harmless.
//! Frames with a bad CRC are dropped and counted; a sequence number that is
//! not the previous one plus one (lost, repeated or restarted) counts a gap.
//!
//! # Device
//!
//! [`MagneticSerial::spawn`] runs a std thread (the `serialport` crate is
//! blocking) with a short read timeout so it notices its handle being
//! dropped. A port that fails to open, reaches EOF or errors (adapter
//! unplugged) is reopened with a backoff from 100 ms to 2 s; the thread only
//! ends when the handle is dropped. Samples are stamped with
//! `origin.elapsed()` when their bytes are read (or, from
//! [`MagneticSerial::spawn_with_clock`], with the given clock, which also
//! times the backoff).

use std::io::{self, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use crate::backoff::Backoff;
use crate::clock::{DeviceClock, WallClock};
use crate::device::{self, DeviceStatus, SharedStatus};
use crate::magnetic::MagneticSample;

/// The two sync bytes that start every frame.
pub const SYNC: [u8; 2] = [0xA5, 0x5A];

/// Bytes in one frame, sync and CRC included.
pub const FRAME_LEN: usize = 8;

/// Read timeout of the port: how long the thread may take to notice that its
/// handle was dropped.
const READ_TIMEOUT: Duration = Duration::from_millis(20);
const MIN_BACKOFF: Duration = Duration::from_millis(100);
const MAX_BACKOFF: Duration = Duration::from_secs(2);

/// CRC-8/SMBUS (poly 0x07, init 0x00, not reflected, no final XOR).
pub fn crc8_smbus(bytes: &[u8]) -> u8 {
    let mut crc = 0u8;
    for &byte in bytes {
        crc ^= byte;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 { (crc << 1) ^ 0x07 } else { crc << 1 };
        }
    }
    crc
}

/// The frame a sensor sends for these masks and sequence number.
pub fn encode_frame(front_mask: u16, rear_mask: u16, seq: u8) -> [u8; FRAME_LEN] {
    let [f0, f1] = front_mask.to_le_bytes();
    let [r0, r1] = rear_mask.to_le_bytes();
    let mut frame = [SYNC[0], SYNC[1], f0, f1, r0, r1, seq, 0];
    frame[7] = crc8_smbus(&frame[2..7]);
    frame
}

/// One good frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MagneticFrame {
    pub front_mask: u16,
    pub rear_mask: u16,
    pub seq: u8,
}

impl MagneticFrame {
    /// The sample this frame is, at time `t`.
    pub fn at(self, t: Duration) -> MagneticSample {
        MagneticSample {
            t,
            front_mask: self.front_mask,
            rear_mask: self.rear_mask,
        }
    }
}

/// What the parser has seen so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FramerStats {
    /// Good frames returned.
    pub frames: u64,
    /// Candidate frames (sync found) whose CRC did not match.
    pub bad_checksums: u64,
    /// Bytes skipped while looking for a good frame (noise, the first byte
    /// of every bad candidate).
    pub discarded_bytes: u64,
    /// Good frames whose sequence number was not the previous one plus one.
    pub sequence_gaps: u64,
}

/// Sans-IO frame parser: feed it bytes as they arrive, in any chunks.
#[derive(Clone, Debug, Default)]
pub struct MagneticFramer {
    /// Unconsumed bytes: always shorter than a frame between calls.
    pending: Vec<u8>,
    last_seq: Option<u8>,
    stats: FramerStats,
}

impl MagneticFramer {
    pub fn new() -> MagneticFramer {
        MagneticFramer::default()
    }

    pub fn stats(&self) -> FramerStats {
        self.stats
    }

    /// Forgets a partial frame and the last sequence number (after a
    /// reconnect: the gap across it is not the sensor's).
    pub fn resync(&mut self) {
        self.pending.clear();
        self.last_seq = None;
    }

    /// Adds `bytes` and returns the good frames completed by them, in order.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<MagneticFrame> {
        self.pending.extend_from_slice(bytes);
        let mut frames = Vec::new();
        let mut start = 0;
        while start < self.pending.len() {
            let rest = &self.pending[start..];
            let Some(sync_at) = find_sync(rest) else {
                // Keep a trailing first sync byte: its partner may be next.
                let keep = usize::from(rest.last() == Some(&SYNC[0]));
                let skipped = rest.len() - keep;
                self.stats.discarded_bytes += skipped as u64;
                start += skipped;
                break;
            };
            self.stats.discarded_bytes += sync_at as u64;
            start += sync_at;
            let Some(candidate) = self.pending.get(start..start + FRAME_LEN) else {
                break;
            };
            match decode(candidate) {
                Some(frame) => {
                    self.note_sequence(frame.seq);
                    self.stats.frames += 1;
                    frames.push(frame);
                    start += FRAME_LEN;
                }
                None => {
                    // The real frame may start inside this candidate.
                    self.stats.bad_checksums += 1;
                    self.stats.discarded_bytes += 1;
                    start += 1;
                }
            }
        }
        self.pending.drain(..start);
        frames
    }

    fn note_sequence(&mut self, seq: u8) {
        if let Some(last) = self.last_seq
            && seq != last.wrapping_add(1)
        {
            self.stats.sequence_gaps += 1;
        }
        self.last_seq = Some(seq);
    }
}

/// Index of the first full sync pair.
fn find_sync(bytes: &[u8]) -> Option<usize> {
    bytes.windows(2).position(|pair| pair == SYNC)
}

/// A full candidate (sync already matched) if its CRC is right.
fn decode(candidate: &[u8]) -> Option<MagneticFrame> {
    let &[_, _, f0, f1, r0, r1, seq, crc] = candidate else {
        return None;
    };
    (crc8_smbus(&candidate[2..7]) == crc).then_some(MagneticFrame {
        front_mask: u16::from_le_bytes([f0, f1]),
        rear_mask: u16::from_le_bytes([r0, r1]),
        seq,
    })
}

/// What the thread shares with the handle besides the device status.
#[derive(Debug, Default)]
struct Readings {
    /// Newest sample not yet taken by [`MagneticSerial::latest`].
    untaken: Option<MagneticSample>,
    /// Time of the newest sample ever, for staleness.
    last_sample_t: Option<Duration>,
    framer: FramerStats,
}

/// The guide sensor on a serial port, read by its own thread.
#[derive(Debug)]
pub struct MagneticSerial {
    path: String,
    stale_after: Duration,
    status: SharedStatus,
    readings: Arc<Mutex<Readings>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl MagneticSerial {
    /// Starts reading `path` at `baud`. Never fails: a missing port is
    /// retried (and shows in [`MagneticSerial::status`]).
    pub fn spawn(path: String, baud: u32, stale_after: Duration, origin: Instant) -> MagneticSerial {
        Self::spawn_with_clock(path, baud, stale_after, Arc::new(WallClock::new(origin)))
    }

    /// [`MagneticSerial::spawn`] on a given clock: sample stamps and
    /// backoff waits read `clock`.
    pub fn spawn_with_clock(
        path: String,
        baud: u32,
        stale_after: Duration,
        clock: Arc<dyn DeviceClock>,
    ) -> MagneticSerial {
        let status = device::shared_status();
        let readings = Arc::new(Mutex::new(Readings::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let reader = Reader {
            path: path.clone(),
            baud,
            clock,
            status: status.clone(),
            readings: readings.clone(),
            stop: stop.clone(),
            framer: MagneticFramer::new(),
        };
        let thread = thread::Builder::new()
            .name("magnetic-serial".into())
            .spawn(move || reader.run());
        let thread = match thread {
            Ok(handle) => Some(handle),
            Err(e) => {
                device::update(&status, |s| {
                    s.errors += 1;
                    s.last_error = Some(format!("cannot start the reader thread: {e}"));
                });
                None
            }
        };
        MagneticSerial {
            path,
            stale_after,
            status,
            readings,
            stop,
            thread,
        }
    }

    /// The port path as given.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The newest sample read since the previous call, if any.
    pub fn latest(&self) -> Option<MagneticSample> {
        lock(&self.readings).untaken.take()
    }

    /// Whether no sample has arrived within `stale_after` of `now` (time
    /// since `origin`), or none ever.
    pub fn is_stale(&self, now: Duration) -> bool {
        lock(&self.readings)
            .last_sample_t
            .is_none_or(|t| now.saturating_sub(t) > self.stale_after)
    }

    /// `messages` are good frames; `errors` count bad CRCs, failed opens and
    /// lost ports.
    pub fn status(&self) -> DeviceStatus {
        device::snapshot(&self.status)
    }

    pub fn shared_status(&self) -> SharedStatus {
        self.status.clone()
    }

    /// The parser's counters (sequence gaps, discarded bytes), summed over
    /// reconnects.
    pub fn framer_stats(&self) -> FramerStats {
        lock(&self.readings).framer
    }
}

impl Drop for MagneticSerial {
    /// Stops the thread within about one read timeout.
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A panicked holder leaves consistent data (plain values), so take it over.
fn lock(readings: &Mutex<Readings>) -> std::sync::MutexGuard<'_, Readings> {
    readings.lock().unwrap_or_else(|p| p.into_inner())
}

/// The thread's side.
struct Reader {
    path: String,
    baud: u32,
    clock: Arc<dyn DeviceClock>,
    status: SharedStatus,
    readings: Arc<Mutex<Readings>>,
    stop: Arc<AtomicBool>,
    framer: MagneticFramer,
}

impl Reader {
    fn run(mut self) {
        let mut backoff = Backoff::new(MIN_BACKOFF, MAX_BACKOFF);
        while !self.stopped() {
            let port = serialport::new(&self.path, self.baud).timeout(READ_TIMEOUT).open();
            let failure = match port {
                Ok(mut port) => {
                    tracing::info!(path = %self.path, baud = self.baud, "magnetic sensor port open");
                    device::update(&self.status, |s| {
                        s.connected = true;
                        s.connects += 1;
                    });
                    backoff.reset();
                    self.framer.resync();
                    let result = self.read_until_lost(&mut *port);
                    device::update(&self.status, |s| s.connected = false);
                    // Lost after it was open: worth a warning.
                    result.err().map(|e| (e.to_string(), true))
                }
                Err(e) => Some((e.to_string(), false)),
            };
            let retry_in = backoff.next_delay();
            if let Some((error, lost)) = failure {
                if lost {
                    tracing::warn!(path = %self.path, %error, ?retry_in, "magnetic sensor port lost");
                } else {
                    tracing::debug!(path = %self.path, %error, ?retry_in, "magnetic sensor port not open");
                }
                self.note_error(format!("{}: {error}", self.path));
            }
            self.sleep_unless_stopped(retry_in);
        }
    }

    /// Reads and parses until the port fails (`Err`) or the handle is
    /// dropped (`Ok`).
    fn read_until_lost(&mut self, port: &mut dyn Read) -> io::Result<()> {
        let mut buf = [0u8; 256];
        while !self.stopped() {
            match port.read(&mut buf) {
                Ok(0) => return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "end of file")),
                Ok(n) => self.take_bytes(&buf[..n]),
                Err(e) if matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    fn take_bytes(&mut self, bytes: &[u8]) {
        let t = self.clock.now();
        let bad_before = self.framer.stats().bad_checksums;
        let frames = self.framer.push(bytes);
        let stats = self.framer.stats();
        let new_bad = stats.bad_checksums - bad_before;
        {
            let mut readings = lock(&self.readings);
            if let Some(newest) = frames.last() {
                readings.untaken = Some(newest.at(t));
                readings.last_sample_t = Some(t);
            }
            readings.framer = stats;
        }
        device::update(&self.status, |s| {
            s.bytes_in += bytes.len() as u64;
            s.messages += frames.len() as u64;
            if !frames.is_empty() {
                s.last_message = Some(t);
            }
            if new_bad > 0 {
                s.errors += new_bad;
                s.last_error = Some(format!("{}: {new_bad} frame(s) with a bad CRC", self.path));
            }
        });
    }

    fn note_error(&self, message: String) {
        device::update(&self.status, |s| {
            s.errors += 1;
            s.last_error = Some(message);
        });
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn sleep_unless_stopped(&self, total: Duration) {
        let until = self.clock.now().saturating_add(total);
        while !self.stopped() {
            let left = until.saturating_sub(self.clock.now());
            if left.is_zero() {
                return;
            }
            thread::sleep(self.clock.wall_wait(left).min(READ_TIMEOUT));
        }
    }
}
