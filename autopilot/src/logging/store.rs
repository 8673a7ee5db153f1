//! The `logs/` folder of the data directory: numbered DataFlash files
//! (`00000001.BIN`, as ArduPilot names them), listed, created, read and
//! erased here (edge code: file I/O).

use std::fs::{self, File};
use std::io::{self, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::protocol::LogInfo;

/// The folder under the data directory.
pub const LOGS_DIR: &str = "logs";

/// One log file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogFile {
    pub number: u16,
    pub path: PathBuf,
    pub size_bytes: u64,
    /// Seconds since 1970 of its last change.
    pub modified_unix_s: u64,
}

impl LogFile {
    pub fn info(&self) -> LogInfo {
        LogInfo {
            id: self.number,
            size_bytes: u32::try_from(self.size_bytes).unwrap_or(u32::MAX),
            time_utc_s: u32::try_from(self.modified_unix_s).unwrap_or(0),
        }
    }
}

#[derive(Clone, Debug)]
pub struct LogStore {
    dir: PathBuf,
}

/// `00000042.BIN` → 42.
fn number_of(name: &str) -> Option<u16> {
    let stem = name.strip_suffix(".BIN")?;
    if stem.len() != 8 || !stem.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    stem.parse::<u16>().ok().filter(|&n| n > 0)
}

pub fn file_name(number: u16) -> String {
    format!("{number:08}.BIN")
}

impl LogStore {
    /// The logs of the data directory at `data_dir`.
    pub fn new(data_dir: &Path) -> LogStore {
        LogStore {
            dir: data_dir.join(LOGS_DIR),
        }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The logs there are, by number (none when the folder is missing).
    pub fn list(&self) -> Vec<LogFile> {
        let Ok(entries) = fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let mut logs: Vec<LogFile> = entries
            .flatten()
            .filter_map(|entry| {
                let number = number_of(entry.file_name().to_str()?)?;
                let meta = entry.metadata().ok().filter(|m| m.is_file())?;
                let modified_unix_s = meta
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_secs());
                Some(LogFile {
                    number,
                    path: entry.path(),
                    size_bytes: meta.len(),
                    modified_unix_s,
                })
            })
            .collect();
        logs.sort_by_key(|l| l.number);
        logs
    }

    /// A new empty log numbered after the last (the lowest free number
    /// once 65535 is taken), after removing the oldest so that at most
    /// `max_files` remain with it.
    pub fn create_next(&self, max_files: u16) -> io::Result<(u16, File)> {
        fs::create_dir_all(&self.dir)?;
        let mut logs = self.list();
        while logs.len() >= usize::from(max_files.max(1)) {
            let oldest = logs.remove(0);
            fs::remove_file(&oldest.path)?;
        }
        let number = match logs.last().map(|l| l.number) {
            None => 1,
            Some(u16::MAX) => (1..u16::MAX)
                .find(|n| logs.binary_search_by_key(n, |l| l.number).is_err())
                .ok_or_else(|| io::Error::other("no free log number"))?,
            Some(last) => last + 1,
        };
        let file = File::options()
            .write(true)
            .create_new(true)
            .open(self.dir.join(file_name(number)))?;
        Ok((number, file))
    }

    /// Up to `buf.len()` bytes of log `number` from `offset`.
    pub fn read(&self, number: u16, offset: u64, buf: &mut [u8]) -> io::Result<usize> {
        let mut file = File::open(self.dir.join(file_name(number)))?;
        file.seek(SeekFrom::Start(offset))?;
        let mut filled = 0;
        while filled < buf.len() {
            match file.read(&mut buf[filled..])? {
                0 => break,
                n => filled += n,
            }
        }
        Ok(filled)
    }

    /// Removes every log but `keep` (the one being written).
    pub fn erase_all(&self, keep: Option<u16>) -> io::Result<usize> {
        let mut removed = 0;
        for log in self.list().into_iter().filter(|l| Some(l.number) != keep) {
            fs::remove_file(&log.path)?;
            removed += 1;
        }
        Ok(removed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_are_numbered_rotated_by_count_read_and_erased() {
        let scratch = tempfile::tempdir().unwrap();
        let data = scratch.path().join("data");
        let store = LogStore::new(&data);
        assert!(store.list().is_empty(), "no folder yet");
        for expected in 1..=4u16 {
            let (n, mut f) = store.create_next(3).unwrap();
            assert_eq!(n, expected);
            std::io::Write::write_all(&mut f, &vec![n as u8; usize::from(n) * 10]).unwrap();
        }
        fs::write(store.dir().join("notes.txt"), b"x").unwrap();
        fs::write(store.dir().join("00000000.BIN"), b"x").unwrap();
        let numbers: Vec<u16> = store.list().iter().map(|l| l.number).collect();
        assert_eq!(numbers, vec![2, 3, 4], "at most 3 kept, other names ignored");
        assert_eq!(store.list()[2].size_bytes, 40);
        let mut buf = [0u8; 16];
        assert_eq!(store.read(4, 30, &mut buf).unwrap(), 10);
        assert_eq!(&buf[..10], &[4; 10]);
        assert_eq!(store.erase_all(Some(4)).unwrap(), 2);
        assert_eq!(store.list().len(), 1);
        assert!(store.read(2, 0, &mut buf).is_err());
    }

    #[test]
    fn names_are_eight_digits() {
        assert_eq!(file_name(7), "00000007.BIN");
        assert_eq!(number_of("00000007.BIN"), Some(7));
        assert_eq!(number_of("7.BIN"), None);
        assert_eq!(number_of("00000007.bin"), None);
        assert_eq!(number_of("99999999.BIN"), None);
    }
}
