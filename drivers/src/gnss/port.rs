//! The device edge of a GNSS receiver (or an NMEA compass): a serial port or
//! TCP connection kept open by one std thread, whose bytes go through an
//! [`NmeaReader`] and whose other direction carries RTCM corrections to the
//! receiver.
//!
//! The core thread polls a [`GnssPort`] once per tick and never waits on it:
//! samples are handed over through a short mutex-guarded queue, corrections
//! through a bounded channel that drops whole frames when full (a partial RTCM
//! frame would corrupt the receiver's parser, and a late one is worth less
//! than the next).
//!
//! One thread owns the connection for both directions, so a reconnect never
//! races a writer holding the old descriptor (which, with the exclusive lock
//! `serialport` takes, would make the reopen fail). Reads wait at most
//! [`IO_POLL`]; writes go in chunks small enough for the free output buffer
//! and give up after [`WRITE_WAIT`], so neither direction holds up the other
//! and sample timestamps stay close to arrival.

use std::fmt;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError, sync_channel};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::{GnssSample, NmeaReader, NmeaStats};
use crate::backoff::{Backoff, MIN_BACKOFF};
use crate::clock::{DeviceClock, WallClock};
use crate::device::{DeviceStatus, SharedStatus, shared_status, snapshot, update};

/// Longest a read waits for bytes: also how late a queued correction or a
/// shutdown request is noticed.
pub const IO_POLL: Duration = Duration::from_millis(10);

/// Longest a write waits for room in the output buffer before the thread
/// goes back to reading.
pub const WRITE_WAIT: Duration = Duration::from_millis(1);

/// Bytes per write call. A tty reports itself writable while fewer than 256
/// bytes are queued and its buffer holds kilobytes, so a chunk this size
/// never blocks the thread (a whole 1 KiB frame could, at low baud).
const WRITE_CHUNK: usize = 256;

/// Samples held for a core that stopped draining; the oldest go first.
pub const MAX_QUEUED_SAMPLES: usize = 1024;

/// How long `Drop` waits for the thread. It notices the request within
/// [`IO_POLL`] unless it is inside a TCP connect or name lookup; then it is
/// left to finish on its own.
const SHUTDOWN_WAIT: Duration = Duration::from_millis(100);

/// Where the NMEA comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GnssSource {
    /// A serial device (`/dev/ttyUSB0`, or a stable `/dev/serial/by-id/…` link).
    Serial { path: String, baud: u32 },
    /// A receiver's or NMEA server's TCP port, `host:port`.
    Tcp { address: String },
}

impl fmt::Display for GnssSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GnssSource::Serial { path, baud } => write!(f, "serial {path} at {baud} baud"),
            GnssSource::Tcp { address } => write!(f, "tcp {address}"),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct GnssPortConfig {
    pub source: GnssSource,
    /// No good sentence for longer than this: [`GnssPort::is_stale`].
    pub stale_after: Duration,
    /// First wait after a failed open or a lost connection; doubles up to
    /// `backoff_max`, and returns to this once a connection has delivered a
    /// good sentence (so a port that opens and dies at once is not hammered).
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
    /// Correction frames waiting to be written; more are dropped whole.
    pub write_queue: usize,
    pub connect_timeout: Duration,
    /// An open connection that delivers no bytes for this long is reopened:
    /// a TCP peer that vanished without a reset looks exactly like this.
    pub reconnect_after_silence: Duration,
}

impl GnssPortConfig {
    /// Defaults for a receiver sending at 5–10 Hz.
    pub fn new(source: GnssSource) -> Self {
        Self {
            source,
            // Five epochs at ArduPilot's default GPS1_RATE_MS (200 ms).
            stale_after: Duration::from_secs(1),
            backoff_initial: Duration::from_millis(100),
            backoff_max: Duration::from_secs(2),
            // An RTCM epoch is 5–10 messages; several epochs of slack.
            write_queue: 64,
            connect_timeout: Duration::from_secs(1),
            reconnect_after_silence: Duration::from_secs(5),
        }
    }
}

/// A running GNSS device: a thread that keeps the connection and the handle
/// the core polls. Dropping it stops the thread.
pub struct GnssPort {
    shared: Arc<Shared>,
    stale_after: Duration,
    /// `None` only while dropping: closing the channel wakes a thread that
    /// is waiting out a backoff.
    frames: Option<SyncSender<Vec<u8>>>,
    thread: Option<JoinHandle<()>>,
}

impl GnssPort {
    /// Starts the device thread. Never fails: a device that cannot be opened
    /// is retried with backoff and reported through [`GnssPort::status`].
    /// Samples are stamped with the wall time since `origin`.
    pub fn spawn(config: GnssPortConfig, origin: Instant) -> GnssPort {
        Self::spawn_with_clock(config, Arc::new(WallClock::new(origin)))
    }

    /// [`GnssPort::spawn`] on a given clock: sample stamps, silence detection
    /// and backoff waits all read `clock`.
    pub fn spawn_with_clock(config: GnssPortConfig, clock: Arc<dyn DeviceClock>) -> GnssPort {
        let shared = Arc::new(Shared::new());
        let (frames, frames_rx) = sync_channel(config.write_queue.max(1));
        let stale_after = config.stale_after;
        let name = match &config.source {
            GnssSource::Serial { .. } => "gnss-serial",
            GnssSource::Tcp { .. } => "gnss-tcp",
        };
        let worker = Worker {
            config,
            clock,
            shared: Arc::clone(&shared),
            frames: frames_rx,
        };
        let thread = match std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || worker.run())
        {
            Ok(handle) => Some(handle),
            Err(e) => {
                // Without a thread the port stays disconnected; say why.
                update(&shared.status, |s| {
                    s.errors += 1;
                    s.last_error = Some(format!("cannot start the GNSS thread: {e}"));
                });
                None
            }
        };
        GnssPort {
            shared,
            stale_after,
            frames: Some(frames),
            thread,
        }
    }

    /// Moves every sample received since the last call to the end of `out`.
    pub fn drain_samples(&self, out: &mut Vec<GnssSample>) {
        out.append(&mut lock(&self.shared.samples));
    }

    /// Queues bytes (a whole RTCM frame, or several) to be written to the
    /// receiver unchanged and in order. `false`: the queue was full (or the
    /// thread is gone) and the frame was dropped and counted.
    pub fn send_to_receiver(&self, bytes: Vec<u8>) -> bool {
        if bytes.is_empty() {
            return true;
        }
        let Some(frames) = &self.frames else {
            return false;
        };
        match frames.try_send(bytes) {
            Ok(()) => true,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.shared.frames_dropped.fetch_add(1, Ordering::Relaxed);
                false
            }
        }
    }

    pub fn status(&self) -> DeviceStatus {
        snapshot(&self.shared.status)
    }

    /// The status handle, for a status view that outlives polling.
    pub fn shared_status(&self) -> SharedStatus {
        Arc::clone(&self.shared.status)
    }

    /// No good sentence within `stale_after` before `now` (or none ever).
    /// `now` is on the port's clock (the wall since the `origin` given to
    /// [`GnssPort::spawn`]).
    pub fn is_stale(&self, now: Duration) -> bool {
        is_stale(self.status().last_message, now, self.stale_after)
    }

    pub fn nmea_stats(&self) -> NmeaStats {
        *lock(&self.shared.nmea_stats)
    }

    /// Correction frames dropped: queue full at [`GnssPort::send_to_receiver`],
    /// or discarded unsent because the connection was down or broke mid-frame.
    pub fn frames_dropped(&self) -> u64 {
        self.shared.frames_dropped.load(Ordering::Relaxed)
    }

    /// Samples dropped because more than [`MAX_QUEUED_SAMPLES`] waited.
    pub fn samples_dropped(&self) -> u64 {
        self.shared.samples_dropped.load(Ordering::Relaxed)
    }
}

impl Drop for GnssPort {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        self.frames = None;
        let Some(thread) = self.thread.take() else {
            return;
        };
        let deadline = Instant::now() + SHUTDOWN_WAIT;
        while !thread.is_finished() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        if thread.is_finished() {
            // The thread catches its own errors; a panic would already be
            // in the log, and there is nobody to hand it to.
            let _ = thread.join();
        }
        // Otherwise it is blocked in a connect or lookup and exits when that
        // returns; it owns nothing but its Arc of the shared state.
    }
}

/// Whether the last good sentence (if any) is older than `stale_after`.
pub fn is_stale(last_message: Option<Duration>, now: Duration, stale_after: Duration) -> bool {
    match last_message {
        None => true,
        Some(t) => now.saturating_sub(t) > stale_after,
    }
}

/// What the thread and the handle share.
struct Shared {
    status: SharedStatus,
    samples: Mutex<Vec<GnssSample>>,
    nmea_stats: Mutex<NmeaStats>,
    frames_dropped: AtomicU64,
    samples_dropped: AtomicU64,
    stop: AtomicBool,
}

impl Shared {
    fn new() -> Self {
        Self {
            status: shared_status(),
            samples: Mutex::new(Vec::new()),
            nmea_stats: Mutex::new(NmeaStats::default()),
            frames_dropped: AtomicU64::new(0),
            samples_dropped: AtomicU64::new(0),
            stop: AtomicBool::new(false),
        }
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The data behind these locks is valid after any panic mid-update.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Bytes → samples, and how many lines were good or bad, across connections.
struct Intake {
    reader: NmeaReader,
    /// Counters of the readers of earlier connections.
    earlier: NmeaStats,
}

/// Lines completed by one push.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct LineCount {
    good: u64,
    bad: u64,
}

impl Intake {
    fn new() -> Self {
        Self {
            reader: NmeaReader::new(),
            earlier: NmeaStats::default(),
        }
    }

    fn push(&mut self, t: Duration, bytes: &[u8], out: &mut Vec<GnssSample>) -> LineCount {
        let before = self.reader.stats();
        self.reader.push(t, bytes, out);
        let after = self.reader.stats();
        LineCount {
            good: after.sentences - before.sentences,
            bad: bad_lines(&after) - bad_lines(&before),
        }
    }

    /// A new connection: a line the old one cut off is forgotten rather than
    /// glued to the first bytes of the new one.
    fn restart(&mut self) {
        self.earlier = self.stats();
        self.reader = NmeaReader::new();
    }

    fn stats(&self) -> NmeaStats {
        let (a, b) = (self.earlier, self.reader.stats());
        NmeaStats {
            sentences: a.sentences + b.sentences,
            checksum_errors: a.checksum_errors + b.checksum_errors,
            malformed: a.malformed + b.malformed,
            unsupported: a.unsupported + b.unsupported,
            overlong: a.overlong + b.overlong,
        }
    }
}

/// Lines that are the device's fault. Unsupported sentences are not: a
/// receiver may send types we do not read.
fn bad_lines(stats: &NmeaStats) -> u64 {
    stats.checksum_errors + stats.malformed + stats.overlong
}

/// Counts one read into the device status.
fn record_read(status: &mut DeviceStatus, t: Duration, bytes: usize, lines: LineCount) {
    status.bytes_in += bytes as u64;
    status.messages += lines.good;
    status.errors += lines.bad;
    if lines.good > 0 {
        status.last_message = Some(t);
    }
}

/// Counts a failed open or a lost connection into the device status.
fn record_failure(status: &mut DeviceStatus, error: String) {
    status.connected = false;
    status.errors += 1;
    status.last_error = Some(error);
}

/// An open connection to the device.
enum Link {
    /// The same port twice: the write side has its own (short) timeout.
    Serial {
        reader: TTYPort,
        writer: TTYPort,
    },
    Tcp(TcpStream),
}

impl Link {
    fn open(config: &GnssPortConfig) -> io::Result<Link> {
        match &config.source {
            GnssSource::Serial { path, baud } => {
                let reader = serialport::new(path, *baud).timeout(IO_POLL).open_native()?;
                let mut writer = reader.try_clone_native()?;
                writer.set_timeout(WRITE_WAIT)?;
                Ok(Link::Serial { reader, writer })
            }
            GnssSource::Tcp { address } => {
                let stream = connect(address, config.connect_timeout.max(MIN_BACKOFF))?;
                stream.set_read_timeout(Some(IO_POLL))?;
                stream.set_write_timeout(Some(WRITE_WAIT))?;
                // Corrections are small and late ones are worth less.
                stream.set_nodelay(true)?;
                Ok(Link::Tcp(stream))
            }
        }
    }

    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Link::Serial { reader, .. } => reader.read(buf),
            Link::Tcp(stream) => stream.read(buf),
        }
    }

    /// Writes what fits now; `Ok(0)` when the device cannot take more yet.
    fn write_some(&mut self, bytes: &[u8]) -> io::Result<usize> {
        let written = match self {
            Link::Serial { writer, .. } => writer.write(bytes),
            Link::Tcp(stream) => stream.write(bytes),
        };
        match written {
            Err(e) if is_no_data_yet(&e) => Ok(0),
            other => other,
        }
    }
}

fn connect(address: &str, timeout: Duration) -> io::Result<TcpStream> {
    let mut last_error = io::Error::new(io::ErrorKind::InvalidInput, "the address resolves to nothing");
    for addr in address.to_socket_addrs()? {
        match TcpStream::connect_timeout(&addr, timeout) {
            // A connect to a free local port in the ephemeral range can pick
            // that very port and connect to itself (TCP simultaneous open).
            Ok(stream) if stream.local_addr().ok() == Some(addr) => {
                last_error = io::Error::new(io::ErrorKind::ConnectionRefused, "connected to itself");
            }
            Ok(stream) => return Ok(stream),
            Err(e) => last_error = e,
        }
    }
    Err(last_error)
}

/// A read or write that timed out: nothing wrong, just nothing to do.
fn is_no_data_yet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

/// A correction frame being written.
struct OutFrame {
    bytes: Vec<u8>,
    written: usize,
}

/// How a connection ended.
enum SessionEnd {
    Stopped,
    Lost {
        error: String,
        /// A good sentence arrived on it: the device works, reset the backoff.
        heard_sentence: bool,
    },
}

/// The device thread.
struct Worker {
    config: GnssPortConfig,
    clock: Arc<dyn DeviceClock>,
    shared: Arc<Shared>,
    frames: Receiver<Vec<u8>>,
}

impl Worker {
    fn run(self) {
        let mut backoff = Backoff::new(self.config.backoff_initial, self.config.backoff_max);
        let mut intake = Intake::new();
        let mut reported_open_failure = false;
        while !self.stopping() {
            match Link::open(&self.config) {
                Ok(mut link) => {
                    update(&self.shared.status, |s| {
                        s.connected = true;
                        s.connects += 1;
                    });
                    tracing::info!(source = %self.config.source, "GNSS device connected");
                    reported_open_failure = false;
                    intake.restart();
                    match self.session(&mut link, &mut intake) {
                        SessionEnd::Stopped => break,
                        SessionEnd::Lost { error, heard_sentence } => {
                            if heard_sentence {
                                backoff.reset();
                            }
                            tracing::warn!(source = %self.config.source, %error, "GNSS device lost");
                            update(&self.shared.status, |s| record_failure(s, error));
                        }
                    }
                }
                Err(e) => {
                    let error = format!("cannot open {}: {e}", self.config.source);
                    // Once per outage in the log; every attempt in the counters.
                    if !reported_open_failure {
                        tracing::warn!(%error, "GNSS device unavailable, retrying");
                        reported_open_failure = true;
                    }
                    update(&self.shared.status, |s| record_failure(s, error));
                }
            }
            if !self.wait_out(backoff.next_delay()) {
                break;
            }
        }
        update(&self.shared.status, |s| s.connected = false);
    }

    fn stopping(&self) -> bool {
        self.shared.stop.load(Ordering::Relaxed)
    }

    /// Sleeps `delay`, discarding corrections that arrive meanwhile (they
    /// would be stale by the time a device is back). `false`: stop.
    fn wait_out(&self, delay: Duration) -> bool {
        let deadline = self.clock.now().saturating_add(delay);
        loop {
            let left = deadline.saturating_sub(self.clock.now());
            if left.is_zero() || self.stopping() {
                return !self.stopping();
            }
            match self.frames.recv_timeout(self.clock.wall_wait(left)) {
                Ok(_) => {
                    self.shared.frames_dropped.fetch_add(1, Ordering::Relaxed);
                }
                // The clock decides whether the deadline has passed.
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return false,
            }
        }
    }

    fn session(&self, link: &mut Link, intake: &mut Intake) -> SessionEnd {
        let mut buf = [0u8; 4096];
        let mut fresh = Vec::new();
        let mut pending: Option<OutFrame> = None;
        let mut heard_sentence = false;
        let mut last_bytes_at = self.clock.now();
        let end = loop {
            if self.stopping() {
                break SessionEnd::Stopped;
            }
            let failure = match link.read(&mut buf) {
                Ok(0) => Some("closed by the device (end of stream)".to_owned()),
                Ok(n) => {
                    let t = self.clock.now();
                    last_bytes_at = t;
                    let lines = intake.push(t, &buf[..n], &mut fresh);
                    heard_sentence |= lines.good > 0;
                    self.publish(t, n, lines, &mut fresh, intake.stats());
                    None
                }
                Err(e) if is_no_data_yet(&e) => None,
                Err(e) => Some(format!("read: {e}")),
            };
            if let Some(error) = failure {
                break SessionEnd::Lost { error, heard_sentence };
            }
            match self.pump_frames(link, &mut pending) {
                Ok(true) => {}
                Ok(false) => break SessionEnd::Stopped,
                Err(e) => {
                    break SessionEnd::Lost {
                        error: format!("write: {e}"),
                        heard_sentence,
                    };
                }
            }
            let silent_for = self.clock.now().saturating_sub(last_bytes_at);
            if silent_for > self.config.reconnect_after_silence {
                break SessionEnd::Lost {
                    error: format!("no bytes for {silent_for:?}"),
                    heard_sentence,
                };
            }
        };
        if pending.is_some() {
            // Cut mid-frame: the rest must not go to whatever connects next.
            self.shared.frames_dropped.fetch_add(1, Ordering::Relaxed);
        }
        end
    }

    /// Writes queued frames until the queue is empty or the device is busy.
    /// `Ok(false)`: the handle is gone, stop.
    fn pump_frames(&self, link: &mut Link, pending: &mut Option<OutFrame>) -> io::Result<bool> {
        loop {
            let frame = match pending {
                Some(frame) => frame,
                None => match self.frames.try_recv() {
                    Ok(bytes) => pending.insert(OutFrame { bytes, written: 0 }),
                    Err(TryRecvError::Empty) => return Ok(true),
                    Err(TryRecvError::Disconnected) => return Ok(false),
                },
            };
            let rest = &frame.bytes[frame.written..];
            let chunk = &rest[..rest.len().min(WRITE_CHUNK)];
            let n = link.write_some(chunk)?;
            if n == 0 && !chunk.is_empty() {
                return Ok(true);
            }
            frame.written += n;
            if frame.written >= frame.bytes.len() {
                *pending = None;
            }
            update(&self.shared.status, |s| s.bytes_out += n as u64);
        }
    }

    fn publish(&self, t: Duration, bytes: usize, lines: LineCount, fresh: &mut Vec<GnssSample>, stats: NmeaStats) {
        update(&self.shared.status, |s| record_read(s, t, bytes, lines));
        *lock(&self.shared.nmea_stats) = stats;
        if fresh.is_empty() {
            return;
        }
        let mut samples = lock(&self.shared.samples);
        samples.append(fresh);
        let excess = samples.len().saturating_sub(MAX_QUEUED_SAMPLES);
        if excess > 0 {
            samples.drain(..excess);
            self.shared.samples_dropped.fetch_add(excess as u64, Ordering::Relaxed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    fn sentence(body: &str) -> String {
        format!("${body}*{:02X}\r\n", super::super::nmea_checksum(body.as_bytes()))
    }

    #[test]
    fn staleness_is_measured_from_the_last_good_sentence() {
        assert!(is_stale(None, ms(0), ms(500)));
        assert!(!is_stale(Some(ms(1000)), ms(1500), ms(500)));
        assert!(is_stale(Some(ms(1000)), ms(1501), ms(500)));
        // A sample stamped after `now` (clock read in another order) is fresh.
        assert!(!is_stale(Some(ms(2000)), ms(1000), ms(500)));
    }

    #[test]
    fn intake_counts_good_and_bad_lines_across_restarts() {
        let gga = sentence("GNGGA,123519.00,4807.038,N,01131.000,E,4,12,0.8,545.4,M,46.9,M,1.0,0000");
        let mut intake = Intake::new();
        let mut out = Vec::new();

        let mut bytes = b"garbage\r\n".to_vec();
        bytes.extend_from_slice(gga.as_bytes());
        bytes.extend_from_slice(b"$GNGGA,bad*00\r\n$GPGSV,1*");
        let count = intake.push(ms(5), &bytes, &mut out);
        assert_eq!(count, LineCount { good: 1, bad: 2 });
        assert_eq!(out.len(), 1);

        // The unfinished GSV is dropped at the restart, not completed by the
        // new connection's first line.
        intake.restart();
        let count = intake.push(ms(6), gga.as_bytes(), &mut out);
        assert_eq!(count, LineCount { good: 1, bad: 0 });
        let stats = intake.stats();
        assert_eq!((stats.sentences, stats.malformed, stats.checksum_errors), (2, 1, 1));
        assert_eq!(stats.total(), 4);
    }

    #[test]
    fn record_read_stamps_only_good_sentences() {
        let mut status = DeviceStatus::default();
        record_read(&mut status, ms(10), 40, LineCount { good: 0, bad: 1 });
        assert_eq!(status.last_message, None);
        record_read(&mut status, ms(20), 60, LineCount { good: 2, bad: 0 });
        assert_eq!(
            (status.bytes_in, status.messages, status.errors, status.last_message),
            (100, 2, 1, Some(ms(20)))
        );
    }
}
