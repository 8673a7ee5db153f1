//! A data directory belongs to one vehicle profile and is used by one
//! process at a time: the running autopilot holds an exclusive lock on
//! `furrow.lock`; the offline tools refuse to touch a locked directory.
//!
//! A directory that cannot be written (a read-only file system, a full or
//! immutable one) still opens for the autopilot, marked read-only: the
//! vehicle drives with what it loads and refuses changes it cannot save.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::sitl::simulation::ModelKind;

const LOCK_FILE: &str = "furrow.lock";
const PROFILE_FILE: &str = "profile";
/// Written and removed at start to learn whether changes can be saved.
const WRITE_CHECK_FILE: &str = "write-check";

/// Which defaults the stored parameters are relative to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Profile {
    Sitl(ModelKind),
    /// A real vehicle (`furrow run`).
    Vehicle(ModelKind),
}

impl Profile {
    fn as_str(self) -> &'static str {
        match self {
            Profile::Sitl(ModelKind::Ackermann) => "sitl-ackermann",
            Profile::Sitl(ModelKind::Differential) => "sitl-differential",
            Profile::Vehicle(ModelKind::Ackermann) => "vehicle-ackermann",
            Profile::Vehicle(ModelKind::Differential) => "vehicle-differential",
        }
    }

    fn parse(text: &str) -> Option<Profile> {
        match text.trim() {
            "sitl-ackermann" => Some(Profile::Sitl(ModelKind::Ackermann)),
            "sitl-differential" => Some(Profile::Sitl(ModelKind::Differential)),
            "vehicle-ackermann" => Some(Profile::Vehicle(ModelKind::Ackermann)),
            "vehicle-differential" => Some(Profile::Vehicle(ModelKind::Differential)),
            _ => None,
        }
    }

    pub fn model(self) -> ModelKind {
        match self {
            Profile::Sitl(m) | Profile::Vehicle(m) => m,
        }
    }
}

/// An open, locked data directory.
pub struct DataDir {
    path: PathBuf,
    /// `None` when no lock file exists and none can be made (read-only).
    _lock: Option<File>,
    /// Why changes cannot be saved here (`None`: they can).
    read_only: Option<String>,
}

impl DataDir {
    /// Creates (if needed) and locks `path` for a running autopilot.
    /// Stored parameters are relative to the profile's defaults, so a
    /// directory made for one vehicle profile is refused for another.
    pub fn open(path: &Path, profile: Profile) -> Result<DataDir, String> {
        fs::create_dir_all(path).map_err(|e| format!("data directory {}: {e}", path.display()))?;
        let lock = match lock(path) {
            Ok(lock) => Some(lock),
            Err(LockError::InUse(text)) => return Err(text),
            Err(LockError::Unwritable(_)) => lock_read_only(path)?,
        };
        let mut read_only = None;
        match read_profile(path)? {
            Some(existing) if existing != profile => {
                return Err(format!(
                    "data directory {} belongs to a {} vehicle, not {}: use another --data-dir",
                    path.display(),
                    existing.as_str(),
                    profile.as_str()
                ));
            }
            Some(_) => {}
            None => {
                let text = format!("{}\n", profile.as_str());
                if let Err(e) = params::store::write_atomic(&path.join(PROFILE_FILE), text.as_bytes()) {
                    read_only = Some(e.to_string());
                }
            }
        }
        let read_only = read_only.or_else(|| write_check(path).err().map(|e| e.to_string()));
        Ok(DataDir {
            path: path.to_path_buf(),
            _lock: lock,
            read_only,
        })
    }

    /// Why changes cannot be saved in this directory (`None`: they can).
    pub fn read_only(&self) -> Option<&str> {
        self.read_only.as_deref()
    }

    /// Locks an existing directory for an offline tool; fails while an
    /// autopilot runs on it.
    pub fn open_offline(path: &Path) -> Result<(DataDir, Profile), String> {
        if !path.is_dir() {
            return Err(format!("data directory {} does not exist", path.display()));
        }
        let lock = lock(path).map_err(|e| match e {
            LockError::InUse(text) | LockError::Unwritable(text) => text,
        })?;
        let profile = read_profile(path)?.unwrap_or(Profile::Sitl(ModelKind::Ackermann));
        Ok((
            DataDir {
                path: path.to_path_buf(),
                _lock: Some(lock),
                read_only: None,
            },
            profile,
        ))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

enum LockError {
    InUse(String),
    /// The lock file cannot be opened for writing.
    Unwritable(String),
}

fn lock(path: &Path) -> Result<File, LockError> {
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .read(true)
        .write(true)
        .open(path.join(LOCK_FILE))
        .map_err(|e| LockError::Unwritable(format!("data directory {}: {e}", path.display())))?;
    match file.try_lock() {
        Ok(()) => {
            let mut f = &file;
            let _ = f.set_len(0);
            let _ = writeln!(f, "{}", std::process::id());
            Ok(file)
        }
        Err(_) => Err(LockError::InUse(in_use(path))),
    }
}

fn in_use(path: &Path) -> String {
    let pid = fs::read_to_string(path.join(LOCK_FILE)).unwrap_or_default();
    format!(
        "data directory {} is in use by a running furrow (pid {})",
        path.display(),
        pid.trim()
    )
}

/// A directory whose lock file cannot be written: the lock is taken on the
/// file opened for reading (a lock needs no write access); without a file
/// there is nothing to lock, and nothing can be written by anyone either.
fn lock_read_only(path: &Path) -> Result<Option<File>, String> {
    let Ok(file) = File::open(path.join(LOCK_FILE)) else {
        return Ok(None);
    };
    match file.try_lock() {
        Ok(()) => Ok(Some(file)),
        Err(_) => Err(in_use(path)),
    }
}

/// Writes and removes a small file the way saves are written.
fn write_check(path: &Path) -> std::io::Result<()> {
    let file = path.join(WRITE_CHECK_FILE);
    params::store::write_atomic(&file, b"furrow write check\n")?;
    fs::remove_file(&file)
}

fn read_profile(path: &Path) -> Result<Option<Profile>, String> {
    match fs::read_to_string(path.join(PROFILE_FILE)) {
        Ok(text) => Profile::parse(&text).map(Some).ok_or_else(|| {
            format!(
                "{}: unknown vehicle profile {:?}",
                path.join(PROFILE_FILE).display(),
                text.trim()
            )
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{}: {e}", path.join(PROFILE_FILE).display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_process_at_a_time_and_one_profile() {
        let scratch = tempfile::tempdir().unwrap();
        let d = scratch.path().join("data");
        let held = DataDir::open(&d, Profile::Sitl(ModelKind::Ackermann)).unwrap();
        let err = DataDir::open_offline(&d).err().expect("locked");
        assert!(err.contains("in use"), "{err}");
        drop(held);
        let (_offline, profile) = DataDir::open_offline(&d).unwrap();
        assert_eq!(profile, Profile::Sitl(ModelKind::Ackermann));
        drop(_offline);
        let err = DataDir::open(&d, Profile::Sitl(ModelKind::Differential))
            .err()
            .expect("profile mismatch");
        assert!(err.contains("belongs to"), "{err}");
    }

    #[test]
    fn a_directory_that_cannot_be_written_opens_read_only() {
        let scratch = tempfile::tempdir().unwrap();
        let d = scratch.path().join("data");
        let profile = Profile::Sitl(ModelKind::Ackermann);
        assert_eq!(DataDir::open(&d, profile).unwrap().read_only(), None);
        // Saves go through a temporary file; its path taken, none can be made.
        fs::create_dir(d.join(format!("{WRITE_CHECK_FILE}.tmp"))).unwrap();
        let dir = DataDir::open(&d, profile).expect("opens, read-only");
        assert!(dir.read_only().is_some_and(|why| !why.is_empty()));
        drop(dir);
    }
}
