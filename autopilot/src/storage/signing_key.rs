//! The MAVLink 2 signing key and our last signing timestamp, in
//! `signing.key` in the data directory: readable by the owner only (0600),
//! replaced atomically (temporary file, fsync, rename, fsync of the
//! directory), so a crash leaves the old file or the new one. The key goes
//! nowhere else: not to parameters, logs or tlogs.
//!
//! Writes happen off the link hub's thread ([`KeyFileWriter`], on a
//! [`KeyFileThread`] a fleet's vehicles share) so the hub never waits for a
//! disk.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::link::signing::{KEY_LEN, SecretKey};
use crate::shared_thread::{Client, Session, SharedThread};

pub const KEY_FILE: &str = "signing.key";
const OWNER_ONLY: u32 = 0o600;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StoredSigning {
    pub key: SecretKey,
    /// 10 µs units since 2015-01-01 (the signing timestamp).
    pub timestamp: u64,
}

pub fn path(dir: &Path) -> PathBuf {
    dir.join(KEY_FILE)
}

pub fn render(stored: &StoredSigning) -> String {
    let hex: String = stored.key.bytes().iter().map(|b| format!("{b:02x}")).collect();
    format!(
        "# Furrow MAVLink 2 signing key. Keep it private; set or clear it with SETUP_SIGNING on a secure link.\nkey {hex}\ntimestamp {}\n",
        stored.timestamp
    )
}

/// Errors never quote the file: it holds the key.
pub fn parse(text: &str) -> Result<StoredSigning, String> {
    let mut key = None;
    let mut timestamp = None;
    for (index, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let number = index + 1;
        match line.split_once(' ') {
            Some(("key", hex)) if key.is_none() => {
                key =
                    Some(parse_key(hex.trim()).ok_or_else(|| format!("line {number}: the key is not 64 hex digits"))?);
            }
            Some(("timestamp", value)) if timestamp.is_none() => {
                timestamp = Some(
                    value
                        .trim()
                        .parse::<u64>()
                        .map_err(|_| format!("line {number}: the timestamp is not a number"))?,
                );
            }
            _ => return Err(format!("line {number}: expected `key HEX` or `timestamp N`, once each")),
        }
    }
    match (key, timestamp) {
        (Some(key), Some(timestamp)) => Ok(StoredSigning { key, timestamp }),
        (None, _) => Err("no key line".into()),
        (_, None) => Err("no timestamp line".into()),
    }
}

fn parse_key(hex: &str) -> Option<SecretKey> {
    if hex.len() != 2 * KEY_LEN || !hex.is_ascii() {
        return None;
    }
    let mut bytes = [0u8; KEY_LEN];
    for (byte, pair) in bytes.iter_mut().zip(hex.as_bytes().chunks(2)) {
        let text = std::str::from_utf8(pair).ok()?;
        *byte = u8::from_str_radix(text, 16).ok()?;
    }
    Some(SecretKey::new(bytes))
}

/// The stored key: `Ok(None)` when there is none, `Err` (a reason without
/// key material) when the file is unreadable or damaged.
pub fn load(dir: &Path) -> Result<Option<StoredSigning>, String> {
    let file = path(dir);
    let bytes = match fs::read(&file) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", file.display())),
    };
    let text = String::from_utf8(bytes).map_err(|_| format!("{}: not a text file", file.display()))?;
    let stored = parse(&text).map_err(|e| format!("{}: {e}", file.display()))?;
    if let Ok(meta) = fs::metadata(&file)
        && meta.permissions().mode() & 0o077 != 0
    {
        tracing::warn!(
            "{}: readable by others (mode {:o}); it is rewritten 0600 at the next save",
            file.display(),
            meta.permissions().mode() & 0o777
        );
    }
    Ok(Some(stored))
}

/// Replaces the file atomically, owner-only.
pub fn save(dir: &Path, stored: &StoredSigning) -> io::Result<()> {
    let file = path(dir);
    let tmp = dir.join(format!("{KEY_FILE}.tmp"));
    {
        let mut out = OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .mode(OWNER_ONLY)
            .open(&tmp)?;
        // A leftover temporary file keeps its old mode; the key must not.
        out.set_permissions(fs::Permissions::from_mode(OWNER_ONLY))?;
        out.write_all(render(stored).as_bytes())?;
        out.sync_all()?;
    }
    fs::rename(&tmp, &file)?;
    File::open(dir)?.sync_all()
}

/// Deletes the key (signing disabled). No file is not an error.
pub fn remove(dir: &Path) -> io::Result<()> {
    match fs::remove_file(path(dir)) {
        Ok(()) => File::open(dir)?.sync_all(),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

pub enum Request {
    Save(StoredSigning),
    Remove,
}

/// The thread that writes key files (one per process: a fleet's vehicles
/// share it).
pub type KeyFileThread = SharedThread<KeyFile>;

/// Starts the key files' thread.
pub fn start_thread() -> io::Result<KeyFileThread> {
    SharedThread::start("signing key writer")
}

/// One data directory's key file on the thread: the newest request of a
/// burst is the one written.
pub struct KeyFile {
    dir: PathBuf,
    pending: Option<Request>,
}

impl KeyFile {
    fn write_pending(&mut self) {
        let Some(request) = self.pending.take() else {
            return;
        };
        let result = match &request {
            Request::Save(stored) => save(&self.dir, stored),
            Request::Remove => remove(&self.dir),
        };
        if let Err(e) = result {
            tracing::error!("signing key file {}: {e}", path(&self.dir).display());
        }
    }
}

impl Session for KeyFile {
    type Job = Request;

    fn handle(&mut self, request: Request) {
        self.pending = Some(request);
    }

    fn pass(&mut self) -> Option<Duration> {
        self.write_pending();
        None
    }

    fn close(&mut self) {
        self.write_pending();
    }
}

/// Saves and removals off the caller's thread, newest first: a burst of
/// requests becomes one write of the last. Dropping it finishes what is
/// pending.
pub struct KeyFileWriter {
    client: Client<KeyFile>,
}

impl KeyFileWriter {
    /// A writer on a thread of its own.
    pub fn start(dir: PathBuf) -> io::Result<KeyFileWriter> {
        Ok(KeyFileWriter::on(&start_thread()?, dir))
    }

    /// A writer for the key file in `dir`, on `thread`.
    pub fn on(thread: &KeyFileThread, dir: PathBuf) -> KeyFileWriter {
        KeyFileWriter {
            client: thread.client(KeyFile { dir, pending: None }),
        }
    }

    pub fn save(&self, stored: StoredSigning) {
        self.client.send(Request::Save(stored));
    }

    pub fn remove(&self) {
        self.client.send(Request::Remove);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> StoredSigning {
        let mut bytes = [0u8; KEY_LEN];
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = (i as u8).wrapping_mul(37).wrapping_add(1);
        }
        StoredSigning {
            key: SecretKey::new(bytes),
            timestamp: 345_678_901_234,
        }
    }

    #[test]
    fn round_trip_owner_only() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        assert_eq!(load(dir), Ok(None));
        save(dir, &sample()).expect("save");
        assert_eq!(load(dir), Ok(Some(sample())));
        let mode = fs::metadata(path(dir)).expect("file").permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        assert!(!dir.join(format!("{KEY_FILE}.tmp")).exists());
        remove(dir).expect("remove");
        assert_eq!(load(dir), Ok(None));
        remove(dir).expect("removing nothing is fine");
    }

    #[test]
    fn a_leftover_world_readable_temp_file_does_not_leak_its_mode() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let tmp = dir.join(format!("{KEY_FILE}.tmp"));
        fs::write(&tmp, "junk").expect("write");
        fs::set_permissions(&tmp, fs::Permissions::from_mode(0o666)).expect("chmod");
        save(dir, &sample()).expect("save");
        let mode = fs::metadata(path(dir)).expect("file").permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
    }

    #[test]
    fn damaged_files_are_errors_that_do_not_quote_the_key() {
        let good = render(&sample());
        let hex_line = good.lines().find(|l| l.starts_with("key ")).expect("key line");
        let damaged = [
            good.replace("timestamp", "timestamq"),
            good.replacen(&hex_line[4..8], "zzzz", 1),
            good.replacen(hex_line, &hex_line[..hex_line.len() - 2], 1),
            good.replace("timestamp 345678901234", "timestamp -1"),
            format!("{good}key {}\n", &hex_line[4..]),
            String::new(),
        ];
        for text in damaged {
            let err = parse(&text).expect_err("damaged");
            assert!(!err.contains(&hex_line[4..12]), "{err}");
        }
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        fs::write(path(dir), [0xff, 0xfe, 0x00]).expect("write");
        assert!(load(dir).is_err());
    }

    #[test]
    fn the_writer_keeps_the_newest_and_finishes_on_drop() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        {
            let writer = KeyFileWriter::start(dir.to_path_buf()).expect("start");
            writer.save(sample());
            writer.remove();
            writer.save(StoredSigning {
                timestamp: 7,
                ..sample()
            });
        }
        assert_eq!(load(dir).expect("loads").map(|s| s.timestamp), Some(7));
    }
}
