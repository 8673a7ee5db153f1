//! A data directory belongs to one vehicle profile and is used by one
//! process at a time: the running autopilot holds an exclusive lock on
//! `furrow.lock`; the offline tools refuse to touch a locked directory.

use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::sitl::simulation::ModelKind;

const LOCK_FILE: &str = "furrow.lock";
const PROFILE_FILE: &str = "profile";

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
    _lock: File,
}

impl DataDir {
    /// Creates (if needed) and locks `path` for a running autopilot.
    /// Stored parameters are relative to the profile's defaults, so a
    /// directory made for one vehicle profile is refused for another.
    pub fn open(path: &Path, profile: Profile) -> Result<DataDir, String> {
        fs::create_dir_all(path).map_err(|e| format!("data directory {}: {e}", path.display()))?;
        let lock = lock(path)?;
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
            None => params::store::write_atomic(&path.join(PROFILE_FILE), format!("{}\n", profile.as_str()).as_bytes())
                .map_err(|e| format!("data directory {}: {e}", path.display()))?,
        }
        Ok(DataDir {
            path: path.to_path_buf(),
            _lock: lock,
        })
    }

    /// Locks an existing directory for an offline tool; fails while an
    /// autopilot runs on it.
    pub fn open_offline(path: &Path) -> Result<(DataDir, Profile), String> {
        if !path.is_dir() {
            return Err(format!("data directory {} does not exist", path.display()));
        }
        let lock = lock(path)?;
        let profile = read_profile(path)?.unwrap_or(Profile::Sitl(ModelKind::Ackermann));
        Ok((
            DataDir {
                path: path.to_path_buf(),
                _lock: lock,
            },
            profile,
        ))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

fn lock(path: &Path) -> Result<File, String> {
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .read(true)
        .write(true)
        .open(path.join(LOCK_FILE))
        .map_err(|e| format!("data directory {}: {e}", path.display()))?;
    match file.try_lock() {
        Ok(()) => {
            let mut f = &file;
            let _ = f.set_len(0);
            let _ = writeln!(f, "{}", std::process::id());
            Ok(file)
        }
        Err(_) => {
            let pid = fs::read_to_string(path.join(LOCK_FILE)).unwrap_or_default();
            Err(format!(
                "data directory {} is in use by a running furrow (pid {})",
                path.display(),
                pid.trim()
            ))
        }
    }
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

    fn temp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("furrow-datadir-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn one_process_at_a_time_and_one_profile() {
        let d = temp("lock");
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
        fs::remove_dir_all(d).unwrap();
    }
}
