//! The data directory at run time: what the core loads at start, and the
//! saves it asks for while running.

use std::path::PathBuf;

use mission::MissionType;
use tokio::sync::mpsc::UnboundedReceiver;

use crate::storage::data_dir::DataDir;
use crate::storage::file_writer::{FileWriter, FileWriterThread};
use crate::storage::session::SessionParams;
use crate::storage::{missions, termination};
use crate::vehicle::{Core, Inputs, SaveDone, SaveRequest, SaveWhat, Storage};

/// Gives the core the stored plans, a flight termination in force, and the
/// notices loading them (and the parameters) left for the ground stations.
pub fn restore(data_dir: &DataDir, session: &mut SessionParams, core: &mut Core) {
    for (severity, text) in session.notices.drain(..) {
        core.add_startup_notice(severity, text);
    }
    let (plans, plan_notices) = missions::load(data_dir.path());
    for mission_type in MissionType::ALL {
        core.load_plan(mission_type, plans.get(mission_type).clone());
    }
    for (severity, text) in plan_notices {
        core.add_startup_notice(severity, text);
    }
    match termination::load(data_dir.path()) {
        Ok(false) => {}
        Ok(true) => core.restore_termination(None),
        Err(why) => core.restore_termination(Some(why)),
    }
}

/// Does the core's saves (see `vehicle::Storage`): turns each request into
/// a file for the writer thread and hands the writer's reports back to the
/// core, which acknowledges a change only then.
pub struct Persistence {
    dir: PathBuf,
    session: SessionParams,
    writer: Option<FileWriter>,
    done: UnboundedReceiver<SaveDone>,
}

impl Persistence {
    /// Opens the data directory's storage for `core`: durable when it can
    /// be written, else read-only (the vehicle runs on what it loaded).
    /// Its files are written on `writers` (a fleet's vehicles share one).
    pub fn start(
        data_dir: &DataDir,
        session: SessionParams,
        core: &mut Core,
        writers: &FileWriterThread,
    ) -> Persistence {
        match data_dir.read_only() {
            Some(why) => {
                tracing::error!("data directory {}: {why}; changes refused", data_dir.path().display());
                core.set_storage(Storage::ReadOnly(why.to_owned()));
            }
            None => core.set_storage(Storage::Durable),
        }
        let (writer, done) = writers.writer();
        Persistence {
            dir: data_dir.path().to_path_buf(),
            session,
            writer: Some(writer),
            done,
        }
    }

    /// The data directory (the signing key is kept there too).
    pub fn dir(&self) -> &std::path::Path {
        &self.dir
    }

    /// Hands the saves the core asked for to the writer thread.
    pub fn save(&mut self, requests: Vec<SaveRequest>, core: &Core) {
        let Some(writer) = &self.writer else {
            return;
        };
        for SaveRequest { token, what } in requests {
            let (path, bytes) = match what {
                SaveWhat::Params { changes } => (
                    self.dir.join(params::store::STORE_FILE),
                    self.session
                        .snapshot_with(core.params(), &changes)
                        .render()
                        .into_bytes(),
                ),
                SaveWhat::Plan { mission_type, plan } => {
                    (missions::path(&self.dir, mission_type), missions::contents(&plan))
                }
                SaveWhat::Termination { terminated } => {
                    (termination::path(&self.dir), termination::contents(terminated))
                }
            };
            writer.save(token, path, bytes);
        }
    }

    /// Moves the saves finished so far into the core's inputs.
    pub fn collect(&mut self, inputs: &mut Inputs) {
        while let Ok(done) = self.done.try_recv() {
            inputs.saved.push(done);
        }
    }

    /// The next finished save (pending forever once the writer is gone).
    pub async fn next_done(&mut self) -> SaveDone {
        match self.done.recv().await {
            Some(done) => done,
            None => std::future::pending().await,
        }
    }

    /// Finishes the pending writes (their changes were never acknowledged:
    /// the process is going).
    pub fn finish(&mut self) {
        self.writer.take();
    }
}
