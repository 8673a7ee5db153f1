//! Writes files in the data directory on a thread of its own, atomically
//! (`params::store::write_atomic`). The core's tick only hands over bytes; a
//! burst of changes to one file coalesces into one write of the newest.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::mpsc;
use std::thread::JoinHandle;

use params::store::write_atomic;

pub struct FileWriter {
    tx: Option<mpsc::Sender<(PathBuf, Vec<u8>)>>,
    thread: Option<JoinHandle<()>>,
}

impl Default for FileWriter {
    fn default() -> Self {
        Self::start()
    }
}

impl FileWriter {
    pub fn start() -> FileWriter {
        let (tx, rx) = mpsc::channel::<(PathBuf, Vec<u8>)>();
        let thread = std::thread::Builder::new()
            .name("file writer".into())
            .spawn(move || {
                while let Ok(first) = rx.recv() {
                    // Only the newest content of each file matters.
                    let mut pending = BTreeMap::from([first]);
                    while let Ok((path, bytes)) = rx.try_recv() {
                        pending.insert(path, bytes);
                    }
                    for (path, bytes) in pending {
                        if let Err(e) = write_atomic(&path, &bytes) {
                            tracing::error!("writing {}: {e}", path.display());
                        }
                    }
                }
            })
            .expect("spawn file writer");
        FileWriter {
            tx: Some(tx),
            thread: Some(thread),
        }
    }

    pub fn write(&self, path: PathBuf, bytes: Vec<u8>) {
        if let Some(tx) = &self.tx {
            let _ = tx.send((path, bytes));
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
