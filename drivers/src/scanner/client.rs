//! The edge between a real LMS1xx and Furrow: a tokio task that keeps a TCP
//! connection to the scanner, subscribes to its scans, and hands each one on
//! as a [`Scan`] stamped with the caller's clock at receipt.
//!
//! Whatever happens on the wire (refused connection, scanner power cycle,
//! silence, garbage) the task reconnects with backoff and counts it in
//! [`ScannerStats`]; consumers judge freshness from `Scan::t`, never from
//! whether the task is alive.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;
use tokio::time::{Instant, sleep, sleep_until, timeout};

use super::Scan;
use super::cola::{ColaFramer, ColaTelegram, FramerStats, parse_telegram, request_scan, sopas_error_name, subscribe};
use crate::backoff::Backoff;

/// Where the scanner is and how patient to be with it.
#[derive(Clone, Debug, PartialEq)]
pub struct ScannerClientConfig {
    /// `host:port`; an LMS1xx listens for CoLa-A on port 2111.
    pub address: String,
    pub connect_timeout: Duration,
    /// No well-formed telegram for this long: the link is dead, reconnect.
    /// A few scan periods (20 ms at 50 Hz) so one late scan is not a reconnect.
    pub stale_after: Duration,
    /// First wait after a failure; doubles up to `backoff_max`, and returns
    /// to this once a connection has delivered a telegram.
    pub backoff_initial: Duration,
    pub backoff_max: Duration,
    /// Longest telegram accepted (bytes between STX and ETX).
    pub max_telegram_len: usize,
}

impl Default for ScannerClientConfig {
    fn default() -> Self {
        Self {
            address: "192.168.0.1:2111".to_string(),
            connect_timeout: Duration::from_secs(1),
            stale_after: Duration::from_millis(500),
            backoff_initial: Duration::from_millis(200),
            backoff_max: Duration::from_secs(2),
            max_telegram_len: super::cola::MAX_TELEGRAM_LEN,
        }
    }
}

/// Live counters, shared with whoever reports health (arming checks,
/// STATUSTEXT). All monotonic except `last_error`.
#[derive(Debug, Default)]
pub struct ScannerStats {
    /// TCP connections established.
    pub connects: AtomicU64,
    /// Established connections that ended (closed, failed, stale, stopped).
    pub disconnects: AtomicU64,
    /// Scans handed to the channel.
    pub scans: AtomicU64,
    /// Telegrams that could not be parsed (dropped).
    pub malformed: AtomicU64,
    /// Scans dropped because the channel was full.
    pub dropped_full: AtomicU64,
    /// `sFA` answers: the scanner refused a request.
    pub scanner_errors: AtomicU64,
    /// Bytes outside any telegram.
    pub skipped_bytes: AtomicU64,
    /// Telegrams longer than the bound, or not popped in time.
    pub oversized: AtomicU64,
    pub last_error: Mutex<Option<String>>,
}

/// A plain copy of [`ScannerStats`] at one moment.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ScannerStatsSnapshot {
    pub connects: u64,
    pub disconnects: u64,
    pub scans: u64,
    pub malformed: u64,
    pub dropped_full: u64,
    pub scanner_errors: u64,
    pub skipped_bytes: u64,
    pub oversized: u64,
    pub last_error: Option<String>,
}

impl ScannerStats {
    pub fn snapshot(&self) -> ScannerStatsSnapshot {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        ScannerStatsSnapshot {
            connects: get(&self.connects),
            disconnects: get(&self.disconnects),
            scans: get(&self.scans),
            malformed: get(&self.malformed),
            dropped_full: get(&self.dropped_full),
            scanner_errors: get(&self.scanner_errors),
            skipped_bytes: get(&self.skipped_bytes),
            oversized: get(&self.oversized),
            last_error: self.last_error(),
        }
    }

    pub fn last_error(&self) -> Option<String> {
        // A poisoned lock only means a writer panicked mid-assignment of an
        // Option<String>; the value is still a valid Option.
        match self.last_error.lock() {
            Ok(guard) => guard.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    fn set_last_error(&self, error: String) {
        match self.last_error.lock() {
            Ok(mut guard) => *guard = Some(error),
            Err(poisoned) => *poisoned.into_inner() = Some(error),
        }
    }

    fn bump(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }

    fn add_framing(&self, before: FramerStats, after: FramerStats) {
        self.skipped_bytes
            .fetch_add(after.skipped_bytes - before.skipped_bytes, Ordering::Relaxed);
        let lost = |s: FramerStats| s.oversized + s.overrun;
        self.oversized.fetch_add(lost(after) - lost(before), Ordering::Relaxed);
    }
}

/// Why [`run_scanner`] returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScannerExit {
    /// The scan receiver was dropped: nobody is listening.
    ReceiverDropped,
    /// Shutdown was requested (or its sender dropped).
    Shutdown,
    /// The task panicked or was aborted (only from [`ScannerClient::stop`]).
    TaskFailed,
}

/// How one connection ended.
enum SessionEnd {
    Exit(ScannerExit),
    /// Reconnect; whether any telegram arrived (resets the backoff).
    Lost {
        error: String,
        heard_from_scanner: bool,
    },
}

/// Keeps a connection to the scanner until the receiver is dropped or
/// `shutdown` turns true: connect, poll one scan (`sRN`) and subscribe
/// (`sEN LMDscandata 1`), then forward every scan telegram as a [`Scan`]
/// stamped `clock()` at receipt. A full channel drops the scan (counted)
/// rather than stall the socket: the consumer wants the newest scan, and a
/// blocked reader would make every later one stale too.
pub async fn run_scanner(
    config: ScannerClientConfig,
    clock: impl Fn() -> Duration + Send + 'static,
    tx: mpsc::Sender<Scan>,
    stats: Arc<ScannerStats>,
    mut shutdown: watch::Receiver<bool>,
) -> ScannerExit {
    // Held as `&mut` across awaits: that needs only `Send`, where `&` would
    // need the clock to be `Sync` too.
    let mut clock = clock;
    let mut backoff = Backoff::new(config.backoff_initial, config.backoff_max);
    loop {
        if *shutdown.borrow() {
            return ScannerExit::Shutdown;
        }
        let connected = tokio::select! {
            exit = stop_requested(&mut shutdown, &tx) => return exit,
            c = timeout(config.connect_timeout, TcpStream::connect(&config.address)) => c,
        };
        let error = match connected {
            Ok(Ok(stream)) => {
                ScannerStats::bump(&stats.connects);
                tracing::info!(address = %config.address, "scanner connected");
                let end = session(stream, &config, &mut clock, &tx, &stats, &mut shutdown).await;
                ScannerStats::bump(&stats.disconnects);
                match end {
                    SessionEnd::Exit(exit) => return exit,
                    SessionEnd::Lost {
                        error,
                        heard_from_scanner,
                    } => {
                        if heard_from_scanner {
                            backoff.reset();
                        }
                        error
                    }
                }
            }
            Ok(Err(e)) => format!("connect to {}: {e}", config.address),
            Err(_) => format!(
                "connect to {}: no answer within {:?}",
                config.address, config.connect_timeout
            ),
        };
        let wait = backoff.next_delay();
        tracing::warn!(%error, retry_in = ?wait, "scanner link lost");
        stats.set_last_error(error);
        tokio::select! {
            exit = stop_requested(&mut shutdown, &tx) => return exit,
            () = sleep(wait) => {}
        }
    }
}

/// Resolves when the task should end.
async fn stop_requested(shutdown: &mut watch::Receiver<bool>, tx: &mpsc::Sender<Scan>) -> ScannerExit {
    tokio::select! {
        () = tx.closed() => ScannerExit::ReceiverDropped,
        // Err: the sender is gone, so nobody could ever ask us to stop.
        _ = shutdown.wait_for(|stop| *stop) => ScannerExit::Shutdown,
    }
}

async fn session(
    mut stream: TcpStream,
    config: &ScannerClientConfig,
    clock: &mut (impl Fn() -> Duration + Send),
    tx: &mpsc::Sender<Scan>,
    stats: &ScannerStats,
    shutdown: &mut watch::Receiver<bool>,
) -> SessionEnd {
    let lost = |error: String, heard_from_scanner: bool| SessionEnd::Lost {
        error,
        heard_from_scanner,
    };
    // Latency matters more than packet count for the few command bytes.
    let _ = stream.set_nodelay(true);
    let mut hello = request_scan().to_vec();
    hello.extend_from_slice(subscribe(true));
    match timeout(config.stale_after, stream.write_all(&hello)).await {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return lost(format!("send subscription: {e}"), false),
        Err(_) => return lost("send subscription: timed out".to_string(), false),
    }

    let mut framer = ColaFramer::with_max_len(config.max_telegram_len);
    let mut buf = vec![0u8; 16 * 1024];
    let mut deadline = deadline_after(config.stale_after);
    let mut heard = false;
    loop {
        let read = tokio::select! {
            exit = stop_requested(shutdown, tx) => {
                // Polite, best effort: the socket is closing anyway.
                let _ = timeout(Duration::from_millis(50), stream.write_all(subscribe(false))).await;
                return SessionEnd::Exit(exit);
            }
            () = sleep_until(deadline) => {
                return lost(format!("no telegram from scanner for {:?}", config.stale_after), heard);
            }
            read = stream.read(&mut buf) => read,
        };
        let n = match read {
            Ok(0) => return lost("scanner closed the connection".to_string(), heard),
            Ok(n) => n,
            Err(e) => return lost(format!("read: {e}"), heard),
        };
        let before = framer.stats();
        framer.push(&buf[..n]);
        stats.add_framing(before, framer.stats());
        while let Some(telegram) = framer.pop() {
            match handle_telegram(&telegram, &*clock, tx, stats) {
                Handled::WellFormed => {
                    heard = true;
                    deadline = deadline_after(config.stale_after);
                }
                Handled::Malformed => {}
                Handled::ReceiverDropped => return SessionEnd::Exit(ScannerExit::ReceiverDropped),
            }
        }
    }
}

/// `now + after`, saturating: a configured "never" must not overflow.
fn deadline_after(after: Duration) -> Instant {
    let now = Instant::now();
    now.checked_add(after)
        .unwrap_or_else(|| now + Duration::from_secs(365 * 24 * 3600))
}

enum Handled {
    WellFormed,
    Malformed,
    ReceiverDropped,
}

fn handle_telegram(
    telegram: &[u8],
    clock: &impl Fn() -> Duration,
    tx: &mpsc::Sender<Scan>,
    stats: &ScannerStats,
) -> Handled {
    match parse_telegram(telegram) {
        Ok(ColaTelegram::ScanData(scan)) => {
            // Counted before it is handed on, so whoever has received n
            // scans sees at least n counted.
            match tx.try_reserve() {
                Ok(permit) => {
                    ScannerStats::bump(&stats.scans);
                    permit.send(scan.to_scan(clock()));
                }
                Err(mpsc::error::TrySendError::Full(())) => ScannerStats::bump(&stats.dropped_full),
                Err(mpsc::error::TrySendError::Closed(())) => return Handled::ReceiverDropped,
            }
            Handled::WellFormed
        }
        Ok(ColaTelegram::EventAck { event, subscribed }) => {
            tracing::debug!(%event, subscribed, "scanner acknowledged subscription");
            Handled::WellFormed
        }
        Ok(ColaTelegram::Error { code }) => {
            ScannerStats::bump(&stats.scanner_errors);
            let name = sopas_error_name(code).unwrap_or("unknown");
            let error = format!("scanner answered sFA {code:X} ({name})");
            tracing::warn!(%error);
            stats.set_last_error(error);
            Handled::WellFormed
        }
        Ok(ColaTelegram::Other { command_type, name }) => {
            tracing::debug!(%command_type, %name, "ignored scanner telegram");
            Handled::WellFormed
        }
        Err(e) => {
            ScannerStats::bump(&stats.malformed);
            tracing::debug!(error = %e, len = telegram.len(), "malformed scanner telegram dropped");
            stats.set_last_error(format!("malformed telegram: {e}"));
            Handled::Malformed
        }
    }
}

/// A running [`run_scanner`] task with its stats and stop switch.
#[derive(Debug)]
pub struct ScannerClient {
    stats: Arc<ScannerStats>,
    shutdown: watch::Sender<bool>,
    task: JoinHandle<ScannerExit>,
}

impl ScannerClient {
    /// Spawns the client on the current tokio runtime (panics outside one,
    /// like `tokio::spawn`). Scans arrive on the returned receiver, which
    /// holds at most `channel_capacity` (at least 1) unread scans.
    pub fn spawn(
        config: ScannerClientConfig,
        clock: impl Fn() -> Duration + Send + 'static,
        channel_capacity: usize,
    ) -> (Self, mpsc::Receiver<Scan>) {
        let (tx, rx) = mpsc::channel(channel_capacity.max(1));
        let (shutdown, shutdown_rx) = watch::channel(false);
        let stats = Arc::new(ScannerStats::default());
        let task = tokio::spawn(run_scanner(config, clock, tx, Arc::clone(&stats), shutdown_rx));
        (Self { stats, shutdown, task }, rx)
    }

    pub fn stats(&self) -> &Arc<ScannerStats> {
        &self.stats
    }

    /// Asks the task to end and waits for it.
    pub async fn stop(self) -> ScannerExit {
        // Err only if the task already ended and dropped its receiver.
        let _ = self.shutdown.send(true);
        self.task.await.unwrap_or(ScannerExit::TaskFailed)
    }
}
