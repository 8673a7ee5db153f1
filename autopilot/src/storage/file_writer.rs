//! Writes files in the data directory on a thread of its own, atomically
//! (`params::store::write_atomic`: written, fsynced, renamed, directory
//! fsynced), and reports each save's token once its file is durable (or
//! why it is not). The core's tick only hands over bytes; a burst of saves
//! of one file coalesces into one write of the newest, which answers every
//! token of the burst (each newer content holds the older changes).
//!
//! A fleet's vehicles share one thread ([`FileWriterThread::writer`]): each
//! gets its own reports, and a save is still reported only once its file is
//! durable.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, mpsc};
use std::thread::JoinHandle;

use params::store::write_atomic;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};

use crate::vehicle::SaveDone;

struct Job {
    token: u64,
    path: PathBuf,
    bytes: Vec<u8>,
    /// Where this save's report goes (its vehicle's).
    report: UnboundedSender<SaveDone>,
}

/// The writing thread. It ends once every handle on it (this and each
/// [`FileWriter`]) is gone and what they queued is written; the last one
/// dropped waits for that.
pub struct FileWriterThread {
    tx: Option<mpsc::Sender<Job>>,
    thread: Option<Arc<JoinHandle<()>>>,
}

impl FileWriterThread {
    pub fn start() -> FileWriterThread {
        let (tx, rx) = mpsc::channel::<Job>();
        let thread = std::thread::Builder::new()
            .name("file writer".into())
            .spawn(move || write_loop(&rx))
            .expect("spawn file writer");
        FileWriterThread {
            tx: Some(tx),
            thread: Some(Arc::new(thread)),
        }
    }

    /// A writer on this thread; its receiver gets a [`SaveDone`] per save.
    pub fn writer(&self) -> (FileWriter, UnboundedReceiver<SaveDone>) {
        let (done, done_rx) = unbounded_channel();
        let writer = FileWriter {
            thread: FileWriterThread {
                tx: self.tx.clone(),
                thread: self.thread.clone(),
            },
            done,
        };
        (writer, done_rx)
    }
}

impl Drop for FileWriterThread {
    /// The last handle writes what is pending before the process goes.
    fn drop(&mut self) {
        self.tx.take();
        if let Some(thread) = self.thread.take().and_then(Arc::into_inner) {
            let _ = thread.join();
        }
    }
}

pub struct FileWriter {
    thread: FileWriterThread,
    done: UnboundedSender<SaveDone>,
}

impl FileWriter {
    /// Starts a thread for this writer alone; the receiver gets a
    /// [`SaveDone`] per save.
    pub fn start() -> (FileWriter, UnboundedReceiver<SaveDone>) {
        FileWriterThread::start().writer()
    }

    /// Writes `bytes` to `path` and reports `token` when it is durable.
    pub fn save(&self, token: u64, path: PathBuf, bytes: Vec<u8>) {
        let job = Job {
            token,
            path,
            bytes,
            report: self.done.clone(),
        };
        let sent = self.thread.tx.as_ref().is_some_and(|tx| tx.send(job).is_ok());
        if !sent {
            let _ = self.done.send(SaveDone {
                token,
                result: Err("file writer stopped".into()),
            });
        }
    }
}

/// The newest content of one file, and every save waiting on it.
type Pending = (Vec<u8>, Vec<(u64, UnboundedSender<SaveDone>)>);

fn write_loop(rx: &mpsc::Receiver<Job>) {
    while let Ok(first) = rx.recv() {
        // Only the newest content of each file is written; every token
        // waiting on that file is answered by that write.
        let mut pending: BTreeMap<PathBuf, Pending> = BTreeMap::new();
        let mut take = |job: Job| {
            let entry = pending.entry(job.path).or_default();
            entry.0 = job.bytes;
            entry.1.push((job.token, job.report));
        };
        take(first);
        while let Ok(job) = rx.try_recv() {
            take(job);
        }
        for (path, (bytes, waiting)) in pending {
            let result = write_atomic(&path, &bytes).map_err(|e| {
                let name = path
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                tracing::error!("writing {}: {e}", path.display());
                format!("{name}: {e}")
            });
            for (token, report) in waiting {
                let _ = report.send(SaveDone {
                    token,
                    result: result.clone(),
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wait(rx: &mut UnboundedReceiver<SaveDone>) -> SaveDone {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        loop {
            if let Ok(done) = rx.try_recv() {
                return done;
            }
            assert!(std::time::Instant::now() < deadline, "no completion");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }

    #[test]
    fn every_save_is_reported_after_its_file_is_on_disk() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let (w, mut rx) = FileWriter::start();
        for token in 1..=5 {
            w.save(token, dir.join("a.txt"), format!("{token}").into_bytes());
        }
        let mut tokens = Vec::new();
        for _ in 0..5 {
            let done = wait(&mut rx);
            assert_eq!(done.result, Ok(()));
            tokens.push(done.token);
        }
        tokens.sort();
        assert_eq!(tokens, vec![1, 2, 3, 4, 5]);
        assert_eq!(std::fs::read_to_string(dir.join("a.txt")).unwrap(), "5");
    }

    #[test]
    fn a_failed_write_is_reported_with_its_error_and_leaves_the_old_file() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        std::fs::write(dir.join("a.txt"), "old").unwrap();
        // The temporary file's path is taken by a directory.
        std::fs::create_dir(dir.join("a.txt.tmp")).unwrap();
        let (w, mut rx) = FileWriter::start();
        w.save(7, dir.join("a.txt"), b"new".to_vec());
        let done = wait(&mut rx);
        assert_eq!(done.token, 7);
        let err = done.result.expect_err("the write fails");
        assert!(err.starts_with("a.txt: "), "{err}");
        assert_eq!(std::fs::read_to_string(dir.join("a.txt")).unwrap(), "old");
    }

    #[test]
    fn writers_sharing_a_thread_each_get_their_own_reports_and_the_last_drop_writes_all() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let thread = FileWriterThread::start();
        let (a, mut a_rx) = thread.writer();
        let (b, mut b_rx) = thread.writer();
        drop(thread);
        a.save(1, dir.join("a.txt"), b"a1".to_vec());
        b.save(2, dir.join("b.txt"), b"b2".to_vec());
        assert_eq!(wait(&mut a_rx).token, 1);
        assert_eq!(wait(&mut b_rx).token, 2);
        assert!(a_rx.try_recv().is_err() && b_rx.try_recv().is_err());
        for token in 3..=40 {
            b.save(token, dir.join("b.txt"), format!("b{token}").into_bytes());
        }
        drop(a);
        drop(b);
        assert_eq!(std::fs::read_to_string(dir.join("b.txt")).unwrap(), "b40");
        assert_eq!(std::fs::read_to_string(dir.join("a.txt")).unwrap(), "a1");
    }
}
