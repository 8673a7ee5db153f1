//! Writes files in the data directory on a thread of its own, atomically
//! (`params::store::write_atomic`: written, fsynced, renamed, directory
//! fsynced), and reports each save's token once its file is durable (or
//! why it is not). The core's tick only hands over bytes; a burst of saves
//! of one file coalesces into one write of the newest, which answers every
//! token of the burst (each newer content holds the older changes).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::mpsc;
use std::thread::JoinHandle;

use params::store::write_atomic;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};

use crate::vehicle::SaveDone;

struct Job {
    token: u64,
    path: PathBuf,
    bytes: Vec<u8>,
}

pub struct FileWriter {
    tx: Option<mpsc::Sender<Job>>,
    done: UnboundedSender<SaveDone>,
    thread: Option<JoinHandle<()>>,
}

impl FileWriter {
    /// Starts the thread; the receiver gets a [`SaveDone`] per save.
    pub fn start() -> (FileWriter, UnboundedReceiver<SaveDone>) {
        let (tx, rx) = mpsc::channel::<Job>();
        let (done, done_rx) = unbounded_channel();
        let report = done.clone();
        let thread = std::thread::Builder::new()
            .name("file writer".into())
            .spawn(move || write_loop(&rx, &report))
            .expect("spawn file writer");
        let writer = FileWriter {
            tx: Some(tx),
            done,
            thread: Some(thread),
        };
        (writer, done_rx)
    }

    /// Writes `bytes` to `path` and reports `token` when it is durable.
    pub fn save(&self, token: u64, path: PathBuf, bytes: Vec<u8>) {
        let sent = self
            .tx
            .as_ref()
            .is_some_and(|tx| tx.send(Job { token, path, bytes }).is_ok());
        if !sent {
            let _ = self.done.send(SaveDone {
                token,
                result: Err("file writer stopped".into()),
            });
        }
    }
}

fn write_loop(rx: &mpsc::Receiver<Job>, report: &UnboundedSender<SaveDone>) {
    while let Ok(first) = rx.recv() {
        // Only the newest content of each file is written; every token
        // waiting on that file is answered by that write.
        let mut pending: BTreeMap<PathBuf, (Vec<u8>, Vec<u64>)> = BTreeMap::new();
        let mut take = |job: Job| {
            let entry = pending.entry(job.path).or_default();
            entry.0 = job.bytes;
            entry.1.push(job.token);
        };
        take(first);
        while let Ok(job) = rx.try_recv() {
            take(job);
        }
        for (path, (bytes, tokens)) in pending {
            let result = write_atomic(&path, &bytes).map_err(|e| {
                let name = path
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                tracing::error!("writing {}: {e}", path.display());
                format!("{name}: {e}")
            });
            for token in tokens {
                let _ = report.send(SaveDone {
                    token,
                    result: result.clone(),
                });
            }
        }
    }
}

impl Drop for FileWriter {
    /// Writes what is pending before the process goes.
    fn drop(&mut self) {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
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
}
