//! Writes parameter snapshots to the data directory on a thread of its own.
//! The core's tick only hands over a snapshot; a burst of PARAM_SETs
//! coalesces into one write of the newest state.

use std::path::PathBuf;
use std::sync::mpsc;
use std::thread::JoinHandle;

use params::store::{self, Snapshot};

pub struct ParamWriter {
    tx: Option<mpsc::Sender<Snapshot>>,
    thread: Option<JoinHandle<()>>,
}

impl ParamWriter {
    pub fn start(dir: PathBuf) -> ParamWriter {
        let (tx, rx) = mpsc::channel::<Snapshot>();
        let thread = std::thread::Builder::new()
            .name("param writer".into())
            .spawn(move || {
                while let Ok(mut snapshot) = rx.recv() {
                    // Only the newest state matters.
                    while let Ok(newer) = rx.try_recv() {
                        snapshot = newer;
                    }
                    if let Err(e) = store::save(&dir, &snapshot) {
                        tracing::error!("saving parameters in {}: {e}", dir.display());
                    }
                }
            })
            .expect("spawn param writer");
        ParamWriter {
            tx: Some(tx),
            thread: Some(thread),
        }
    }

    pub fn save(&self, snapshot: Snapshot) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(snapshot);
        }
    }
}

impl Drop for ParamWriter {
    /// Writes what is pending before the process goes.
    fn drop(&mut self) {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
