//! The log's edge: a thread that writes the core's records to `logs/` and
//! serves downloads (a fleet's vehicles share one, [`LogThread`], each with
//! its own files and queue). The core's side only ever `try_send`s into a bounded
//! queue: when the disk falls behind, commands are dropped and counted, and
//! the core never waits. A download reads ahead only while the links'
//! backlog of bulk replies is short: it goes at the link's pace.
//!
//! Records are handed over in batches of [`BATCH_AGE`] (or [`BATCH_BYTES`]),
//! not every tick: waking the thread 50 times a second per vehicle cost a
//! fleet of 50 about a quarter of its CPU in context switches. The thread
//! flushes to the file once a second anyway, so a crash loses at most
//! `FLUSH_EVERY + BATCH_AGE` of records.

use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use tokio::sync::mpsc::Sender;

use super::format::write_header;
use super::messages;
use super::protocol::{Action, LogTransfer};
use super::store::LogStore;
use super::{FileLimits, LogCommand};
use crate::link::hub::BulkBacklog;
use crate::shared_thread::{Client, Session, SharedThread};
use crate::vehicle::{Destination, Outbound};

/// Commands queued for the thread per vehicle: about a minute of record
/// batches.
const QUEUE: usize = 256;
/// Records are held at most this long before they go to the thread …
const BATCH_AGE: Duration = Duration::from_millis(250);
/// … or until this many bytes are held.
const BATCH_BYTES: usize = 32 * 1024;
/// LOG_DATA sent per pass at most, and only while the core's outbound
/// queue is at most half full and the links hold fewer than
/// [`BACKLOG_AHEAD`] bulk replies not yet queued.
const CHUNKS_PER_PASS: usize = 64;
const BACKLOG_AHEAD: usize = 64;
/// How long the thread sleeps between passes during a download.
const DOWNLOAD_PASS: Duration = Duration::from_millis(2);
/// Written data reaches the file at least this often (a download of the
/// file being written, a crash).
const FLUSH_EVERY: Duration = Duration::from_secs(1);

/// The thread that writes onboard logs (one per process: a fleet's
/// vehicles share it).
pub type LogThread = SharedThread<VehicleLog>;

/// Starts the onboard log's thread.
pub fn start_thread() -> std::io::Result<LogThread> {
    SharedThread::start("log")
}

/// The handle the runner keeps: hands commands over and counts drops.
pub struct Logger {
    client: Option<Client<VehicleLog>>,
    /// Commands handed over and not yet taken by the thread (at most
    /// [`QUEUE`]).
    queued: Arc<AtomicUsize>,
    /// Records not yet handed over, and how many commands they came in.
    batch: Vec<u8>,
    batch_commands: u64,
    batch_started: Instant,
    dropped: u64,
    written_bytes: Arc<AtomicU64>,
}

impl Logger {
    /// Starts a thread of its own for the data directory at `data_dir`;
    /// replies to downloads go to `outbound`, paced by the links' `backlog`.
    pub fn start(data_dir: &Path, outbound: Sender<Outbound>, backlog: BulkBacklog) -> Logger {
        match start_thread() {
            Ok(thread) => Logger::on(&thread, data_dir, outbound, backlog),
            Err(e) => {
                tracing::error!("onboard log thread: {e}; not logging");
                Logger::with_client(None, Arc::default(), Arc::default())
            }
        }
    }

    /// As [`Logger::start`], on `thread`.
    pub fn on(thread: &LogThread, data_dir: &Path, outbound: Sender<Outbound>, backlog: BulkBacklog) -> Logger {
        let store = LogStore::new(data_dir);
        let written_bytes = Arc::new(AtomicU64::new(0));
        let queued = Arc::new(AtomicUsize::new(0));
        let session = VehicleLog {
            writer: Writer {
                store,
                open: None,
                last_flush: Instant::now(),
                written: written_bytes.clone(),
            },
            transfer: LogTransfer::default(),
            replies: Replies { outbound, backlog },
            queued: queued.clone(),
        };
        Logger::with_client(Some(thread.client(session)), queued, written_bytes)
    }

    fn with_client(client: Option<Client<VehicleLog>>, queued: Arc<AtomicUsize>, written: Arc<AtomicU64>) -> Logger {
        Logger {
            client,
            queued,
            batch: Vec::new(),
            batch_commands: 0,
            batch_started: Instant::now(),
            dropped: 0,
            written_bytes: written,
        }
    }

    /// Moves `commands` to the thread without waiting; what does not fit
    /// is dropped and counted. Records join the batch; any other command
    /// first sends the batch, so the thread sees everything in order.
    pub fn send(&mut self, commands: &mut Vec<LogCommand>) {
        if self.client.is_none() {
            commands.clear();
            return;
        }
        for command in commands.drain(..) {
            match command {
                LogCommand::Records(bytes) => {
                    // A file rotates by size between writes: a batch keeps
                    // it within BATCH_BYTES of its limit (LOG_FILE_MB).
                    if self.batch.len() + bytes.len() > BATCH_BYTES {
                        self.send_batch();
                    }
                    if self.batch.is_empty() {
                        self.batch = bytes;
                        self.batch_started = Instant::now();
                    } else {
                        self.batch.extend_from_slice(&bytes);
                    }
                    self.batch_commands += 1;
                }
                other => {
                    self.send_batch();
                    self.hand_over(other, 1);
                }
            }
        }
        if self.batch.len() >= BATCH_BYTES || self.batch_started.elapsed() >= BATCH_AGE {
            self.send_batch();
        }
    }

    /// The records held so far, as one command.
    fn send_batch(&mut self) {
        if self.batch_commands > 0 {
            let records = LogCommand::Records(std::mem::take(&mut self.batch));
            let commands = std::mem::take(&mut self.batch_commands);
            self.hand_over(records, commands);
        }
    }

    /// `command`, standing for `merged` of the core's commands.
    fn hand_over(&mut self, command: LogCommand, merged: u64) {
        let Some(client) = &self.client else {
            return;
        };
        // The thread takes one off as it takes each command.
        let room = self
            .queued
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < QUEUE).then_some(n + 1))
            .is_ok();
        if !room {
            self.dropped += merged;
        } else if !client.send(command) {
            self.queued.fetch_sub(1, Ordering::AcqRel);
            self.dropped += merged;
        }
    }

    /// The core's commands dropped because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Bytes written to log files so far.
    pub fn written_bytes(&self) -> u64 {
        self.written_bytes.load(Ordering::Relaxed)
    }
}

impl Drop for Logger {
    /// Ends its session and waits for the thread to write what it holds.
    fn drop(&mut self) {
        self.send_batch();
        self.client.take();
    }
}

/// The file being written.
struct OpenLog {
    number: u16,
    file: BufWriter<std::fs::File>,
    bytes: u64,
    limits: FileLimits,
}

struct Writer {
    store: LogStore,
    open: Option<OpenLog>,
    last_flush: Instant,
    written: Arc<AtomicU64>,
}

impl Writer {
    fn open(&mut self, limits: FileLimits) {
        self.close();
        match self.store.create_next(limits.max_files) {
            Ok((number, file)) => {
                let mut header = Vec::new();
                write_header(&mut header, 0, messages::ALL);
                self.open = Some(OpenLog {
                    number,
                    file: BufWriter::with_capacity(64 * 1024, file),
                    bytes: 0,
                    limits,
                });
                self.write(&header);
                tracing::info!("onboard log {} started", number);
            }
            Err(e) => tracing::warn!("onboard log in {}: {e}; not logging", self.store.dir().display()),
        }
    }

    fn write(&mut self, bytes: &[u8]) {
        let Some(log) = &mut self.open else {
            return;
        };
        if let Err(e) = log.file.write_all(bytes) {
            tracing::warn!("onboard log {}: {e}; closed", log.number);
            self.open = None;
            return;
        }
        log.bytes += bytes.len() as u64;
        self.written.fetch_add(bytes.len() as u64, Ordering::Relaxed);
        if log.limits.max_bytes > 0 && log.bytes >= log.limits.max_bytes {
            let limits = log.limits;
            self.open(limits);
        }
    }

    fn flush(&mut self) {
        self.last_flush = Instant::now();
        if let Some(log) = &mut self.open
            && let Err(e) = log.file.flush()
        {
            tracing::warn!("onboard log {}: {e}", log.number);
        }
    }

    fn close(&mut self) {
        self.flush();
        self.open = None;
    }
}

/// Where a download's replies go, and how far ahead it may run.
struct Replies {
    outbound: Sender<Outbound>,
    backlog: BulkBacklog,
}

/// One vehicle's onboard log on the log thread.
pub struct VehicleLog {
    writer: Writer,
    transfer: LogTransfer,
    replies: Replies,
    queued: Arc<AtomicUsize>,
}

impl Session for VehicleLog {
    type Job = LogCommand;

    fn handle(&mut self, command: LogCommand) {
        self.queued.fetch_sub(1, Ordering::AcqRel);
        let writer = &mut self.writer;
        match command {
            LogCommand::Open(limits) => writer.open(limits),
            LogCommand::Records(bytes) => writer.write(&bytes),
            LogCommand::Close => writer.close(),
            LogCommand::LinkClosed(link) => self.transfer.link_closed(link),
            LogCommand::Request { link, message } => {
                // A download sees everything written so far.
                writer.flush();
                let store = &writer.store;
                let logs: Vec<_> = store.list().iter().map(|l| l.info()).collect();
                for action in self.transfer.handle(link, &message, &logs) {
                    match action {
                        Action::Send(link, message) => send(&self.replies.outbound, link, *message),
                        Action::EraseAll => erase(store, writer.open.as_ref().map(|l| l.number)),
                    }
                }
            }
        }
    }

    fn pass(&mut self) -> Option<Duration> {
        if self.writer.last_flush.elapsed() >= FLUSH_EVERY {
            self.writer.flush();
        }
        pump(&mut self.transfer, &self.writer.store, &self.replies);
        Some(if self.transfer.busy() {
            DOWNLOAD_PASS
        } else {
            FLUSH_EVERY.saturating_sub(self.writer.last_flush.elapsed())
        })
    }

    fn close(&mut self) {
        self.writer.close();
    }
}

fn send(
    outbound: &Sender<Outbound>,
    link: crate::vehicle::LinkId,
    message: mavlink::dialects::ardupilotmega::MavMessage,
) {
    let _ = outbound.try_send(Outbound {
        dest: Destination::Link(link),
        message,
    });
}

fn erase(store: &LogStore, keep: Option<u16>) {
    match store.erase_all(keep) {
        Ok(n) => tracing::info!("onboard logs erased: {n}"),
        Err(e) => tracing::warn!("erasing onboard logs in {}: {e}", store.dir().display()),
    }
}

/// Sends the next LOG_DATA chunks while the link queue has room.
fn pump(transfer: &mut LogTransfer, store: &LogStore, replies: &Replies) {
    let mut buf = [0u8; super::protocol::CHUNK];
    let outbound = &replies.outbound;
    for _ in 0..CHUNKS_PER_PASS {
        if outbound.capacity() < outbound.max_capacity() / 2 || replies.backlog.waiting() >= BACKLOG_AHEAD {
            return;
        }
        let Some(request) = transfer.next_chunk() else {
            return;
        };
        let read = match store.read(request.id, u64::from(request.ofs), &mut buf[..request.len]) {
            Ok(n) => n,
            Err(e) => {
                tracing::warn!("onboard log {} read: {e}", request.id);
                0
            }
        };
        if let Some(message) = transfer.chunk_read(request, &buf[..read]) {
            send(outbound, request.link, message);
        }
    }
}

/// Stops the thread once it has written everything, and says how it went.
pub fn report(mut logger: Logger) {
    logger.send_batch();
    let dropped = logger.dropped();
    let written = logger.written_bytes.clone();
    drop(logger);
    tracing::info!(
        "onboard log: {} bytes written, {} commands dropped (queue full)",
        written.load(Ordering::Relaxed),
        dropped
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logging::reader::DataFlashLog;

    fn records(n: usize) -> Vec<u8> {
        let mut out = Vec::new();
        for i in 0..n {
            let values = [
                super::super::format::Value::U(i as u64),
                super::super::format::Value::U(10),
            ];
            super::super::format::write_record(&mut out, &messages::EV, &values);
        }
        out
    }

    #[test]
    fn files_rotate_by_size_and_count_and_each_reads_on_its_own() {
        // A data directory that does not exist yet, as on a first start.
        let scratch = tempfile::tempdir().unwrap();
        let data = scratch.path().join("data");
        let (outbound, _rx) = tokio::sync::mpsc::channel(16);
        let mut logger = Logger::start(&data, outbound, BulkBacklog::default());
        let limits = FileLimits {
            max_files: 3,
            max_bytes: 50_000,
        };
        let mut commands = vec![LogCommand::Open(limits)];
        // 36 kB a command, more than a batch holds, so each is a write: a
        // file (with its header) passes 50 kB on its second, so 7 make 4
        // files, and the first is removed.
        for _ in 0..7 {
            commands.push(LogCommand::Records(records(3000)));
        }
        commands.push(LogCommand::Close);
        logger.send(&mut commands);
        assert_eq!(logger.dropped(), 0);
        drop(logger);
        let logs = LogStore::new(&data).list();
        let numbers: Vec<u16> = logs.iter().map(|l| l.number).collect();
        assert_eq!(numbers, vec![2, 3, 4], "rotated by size, the oldest removed past 3");
        for log in &logs {
            let parsed = DataFlashLog::read(&log.path).unwrap();
            assert_eq!(parsed.skipped_bytes, 0, "each file has its own header");
            assert!(parsed.messages("EV").count() >= 3000);
        }
    }

    #[test]
    fn records_go_over_in_batches_and_in_order() {
        let scratch = tempfile::tempdir().unwrap();
        let (outbound, _rx) = tokio::sync::mpsc::channel(16);
        let mut logger = Logger::start(scratch.path(), outbound, BulkBacklog::default());
        let limits = FileLimits {
            max_files: 3,
            max_bytes: 0,
        };
        logger.send(&mut vec![LogCommand::Open(limits)]);
        // A tick's worth at a time: held, not handed over, until the batch
        // is old or large enough.
        for _ in 0..10 {
            logger.send(&mut vec![LogCommand::Records(records(10))]);
        }
        assert_eq!(logger.batch_commands, 10);
        assert_eq!(logger.batch.len(), 10 * records(10).len());
        std::thread::sleep(BATCH_AGE);
        logger.send(&mut vec![LogCommand::Records(records(10))]);
        assert_eq!(logger.batch_commands, 0, "an old batch goes over");
        // A command other than records sends the batch before itself.
        logger.send(&mut vec![LogCommand::Records(records(5)), LogCommand::Close]);
        assert_eq!(logger.batch_commands, 0);
        logger.send(&mut vec![LogCommand::Records(records(7))]);
        // Dropping the logger writes what it still holds.
        drop(logger);
        let logs = LogStore::new(scratch.path()).list();
        assert_eq!(logs.len(), 1, "records after Close have no file");
        let parsed = DataFlashLog::read(&logs[0].path).unwrap();
        let counters: Vec<u64> = parsed.messages("EV").map(|m| m.get("TimeUS").unwrap() as u64).collect();
        let expected: Vec<u64> = (0..11).flat_map(|_| 0..10).chain(0..5).collect();
        assert_eq!(counters, expected);
    }

    /// Starts a logger with one finished log and a download of all of it
    /// on `link`; returns the logger, the reply channel and the data dir.
    fn download_started(
        link: crate::vehicle::LinkId,
    ) -> (Logger, tokio::sync::mpsc::Receiver<Outbound>, tempfile::TempDir) {
        use mavlink::dialects::ardupilotmega::{LOG_REQUEST_DATA_DATA, LOG_REQUEST_LIST_DATA, MavMessage};
        let scratch = tempfile::tempdir().unwrap();
        // Small: the download stalls (half full) until the test drains it.
        let (outbound, mut rx) = tokio::sync::mpsc::channel(16);
        let mut logger = Logger::start(scratch.path(), outbound, BulkBacklog::default());
        let list = MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
            start: 0,
            end: u16::MAX,
            target_system: 1,
            target_component: 1,
        });
        let limits = FileLimits {
            max_files: 3,
            max_bytes: 0,
        };
        let mut commands = vec![
            LogCommand::Open(limits),
            LogCommand::Records(records(1000)),
            LogCommand::Close,
            LogCommand::Request {
                link,
                message: Box::new(list),
            },
        ];
        logger.send(&mut commands);
        let entry = match rx.blocking_recv().map(|o| o.message) {
            Some(MavMessage::LOG_ENTRY(e)) => e,
            other => panic!("expected LOG_ENTRY, got {other:?}"),
        };
        assert!(entry.size > 90 * 100, "a log of many chunks: {} bytes", entry.size);
        let data = MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs: 0,
            count: u32::MAX,
            id: entry.id,
            target_system: 1,
            target_component: 1,
        });
        logger.send(&mut vec![LogCommand::Request {
            link,
            message: Box::new(data),
        }]);
        (logger, rx, scratch)
    }

    /// Receives LOG_DATA until none comes for a while; returns how many.
    fn drain_log_data(rx: &mut tokio::sync::mpsc::Receiver<Outbound>) -> usize {
        let mut n = 0;
        let mut quiet_since = Instant::now();
        while quiet_since.elapsed() < Duration::from_millis(100) {
            match rx.try_recv() {
                Ok(o) => {
                    assert!(matches!(
                        o.message,
                        mavlink::dialects::ardupilotmega::MavMessage::LOG_DATA(_)
                    ));
                    n += 1;
                    quiet_since = Instant::now();
                }
                Err(_) => std::thread::sleep(Duration::from_millis(1)),
            }
        }
        n
    }

    /// Waits until the (undrained) download has filled the queue to the
    /// point where it pauses.
    fn wait_stalled(rx: &tokio::sync::mpsc::Receiver<Outbound>) {
        let started = Instant::now();
        while rx.len() < 8 {
            assert!(started.elapsed() < Duration::from_secs(5), "download never started");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_download_runs_to_the_end_while_its_link_is_open() {
        let link = crate::vehicle::LinkId(3);
        let (logger, mut rx, _dir) = download_started(link);
        wait_stalled(&rx);
        let chunks = drain_log_data(&mut rx);
        assert!(chunks > 100, "the whole file comes: {chunks} chunks");
        drop(logger);
    }

    #[test]
    fn a_download_stops_when_its_link_closes_or_the_client_ends_it() {
        use mavlink::dialects::ardupilotmega::{LOG_REQUEST_END_DATA, MavMessage};
        let link = crate::vehicle::LinkId(3);
        let end = MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
            target_system: 1,
            target_component: 1,
        });
        let stops = [
            LogCommand::LinkClosed(link),
            LogCommand::Request {
                link,
                message: Box::new(end),
            },
        ];
        for stop in stops {
            let (mut logger, mut rx, _dir) = download_started(link);
            wait_stalled(&rx);
            logger.send(&mut vec![stop.clone()]);
            // What was queued before the stop still drains; nothing after.
            let chunks = drain_log_data(&mut rx);
            assert!(chunks <= 16, "{stop:?}: {chunks} chunks after it");
            drop(logger);
        }
    }

    #[test]
    fn a_full_queue_drops_and_counts_without_waiting() {
        // A data directory that does not exist yet, as on a first start.
        let scratch = tempfile::tempdir().unwrap();
        let data = scratch.path().join("data");
        let (outbound, _rx) = tokio::sync::mpsc::channel(16);
        let mut logger = Logger::start(&data, outbound, BulkBacklog::default());
        // The writer may keep up with one burst on an idle machine: send
        // bursts until the queue overflows; no send may wait for it.
        for _ in 0..100 {
            let mut commands: Vec<_> = (0..QUEUE * 4).map(|_| LogCommand::Records(records(1000))).collect();
            let started = Instant::now();
            logger.send(&mut commands);
            assert!(started.elapsed() < Duration::from_millis(500));
            assert!(commands.is_empty());
            if logger.dropped() > 0 {
                break;
            }
        }
        // Records without an open file are discarded; some did not fit.
        assert!(logger.dropped() > 0, "{} dropped", logger.dropped());
        drop(logger);
    }
}
