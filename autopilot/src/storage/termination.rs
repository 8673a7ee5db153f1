//! `terminated`: whether a ground station's flight termination is in
//! force, kept in the data directory so a restart does not clear it. It
//! holds `terminated` or `cleared` (written atomically by the file writer,
//! as every saved change). A vehicle that finds it unreadable starts
//! terminated: a termination is cleared only by the command, never by a
//! damaged file.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

pub const FILE: &str = "terminated";
const TERMINATED: &str = "terminated";
const CLEARED: &str = "cleared";

pub fn path(dir: &Path) -> PathBuf {
    dir.join(FILE)
}

pub fn contents(terminated: bool) -> Vec<u8> {
    format!("{}\n", if terminated { TERMINATED } else { CLEARED }).into_bytes()
}

/// Whether the vehicle was terminated when it stopped: `Ok(false)` with no
/// file, `Err(why)` when the file says neither (the caller starts
/// terminated).
pub fn load(dir: &Path) -> Result<bool, String> {
    let path = path(dir);
    match fs::read(&path) {
        Ok(bytes) => match String::from_utf8_lossy(&bytes).trim() {
            TERMINATED => Ok(true),
            CLEARED => Ok(false),
            other => Err(format!("{} holds {other:?}", path.display())),
        },
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(format!("{}: {e}", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_written_is_read_back_and_anything_else_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(load(dir.path()), Ok(false), "no file: never terminated");
        fs::write(path(dir.path()), contents(true)).unwrap();
        assert_eq!(load(dir.path()), Ok(true));
        fs::write(path(dir.path()), contents(false)).unwrap();
        assert_eq!(load(dir.path()), Ok(false));
        fs::write(path(dir.path()), b"termin").unwrap();
        let why = load(dir.path()).expect_err("damaged");
        assert!(why.contains("holds \"termin\""), "{why}");
    }
}
