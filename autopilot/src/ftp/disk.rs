//! [`Files`] on the data directory, plus the virtual `@PARAM/` directory
//! and read-only mounts such as `@LOGS/`.
//!
//! Paths are relative to the data directory; a leading `/` names the data
//! directory itself (as `/` is the SD card on ArduPilot), never the host's
//! root. `..`, and any symlink on the way, are refused (FileProtected): the
//! served tree cannot be left. The vehicle's own files in the data directory
//! (parameter store, plans, signing key, lock and profile) are read-only, and
//! the signing key is neither listed nor readable.

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::server::{Entry, Files, FsError};
use crate::storage::missions;
use mission::MissionType;

/// The virtual parameter directory and its file.
pub const PARAM_DIR: &str = "@PARAM";
const PARAM_FILE: &str = "param.pck";

/// Vehicle-owned names in the data directory root.
const OWNED: &[&str] = &[params::store::STORE_FILE, "furrow.lock", "profile", "write-check"];
const SECRET: &str = crate::storage::signing_key::KEY_FILE;

pub enum Handle {
    Memory(Arc<Vec<u8>>),
    Disk(File),
}

/// A read-only directory served under `@NAME/`.
struct Mount {
    name: String,
    dir: PathBuf,
}

pub struct DataFiles {
    root: PathBuf,
    mounts: Vec<Mount>,
    /// `param.pck` as last packed, without and with defaults.
    param_pack: [Arc<Vec<u8>>; 2],
}

/// Where a path leads.
enum Target {
    /// A real file or directory, and whether it may be changed.
    Disk(PathBuf, bool),
    ParamDir,
    ParamFile {
        with_defaults: bool,
    },
    Root,
}

fn io_error(e: &std::io::Error) -> FsError {
    match e.kind() {
        std::io::ErrorKind::NotFound => FsError::NotFound,
        std::io::ErrorKind::AlreadyExists => FsError::Exists,
        std::io::ErrorKind::PermissionDenied => FsError::Protected,
        _ => FsError::Errno(e.raw_os_error().map_or(0, |n| u8::try_from(n).unwrap_or(u8::MAX))),
    }
}

impl DataFiles {
    pub fn new(root: &Path) -> DataFiles {
        DataFiles {
            root: root.to_path_buf(),
            mounts: Vec::new(),
            param_pack: [Arc::new(Vec::new()), Arc::new(Vec::new())],
        }
    }

    /// Serves `dir` read-only as `@name/` (e.g. the onboard logs as
    /// `@LOGS/`). It need not exist yet.
    pub fn mount(&mut self, name: &str, dir: PathBuf) {
        self.mounts.push(Mount {
            name: format!("@{name}"),
            dir,
        });
    }

    /// The parameter file to serve from now on.
    pub fn set_param_pack(&mut self, with_defaults: bool, bytes: Vec<u8>) {
        self.param_pack[usize::from(with_defaults)] = Arc::new(bytes);
    }

    fn owned(&self, path: &Path) -> bool {
        let Ok(rel) = path.strip_prefix(&self.root) else {
            return false;
        };
        let name = rel.to_string_lossy();
        OWNED.contains(&name.as_ref())
            || name == SECRET
            || MissionType::ALL.iter().any(|t| missions::path(&self.root, *t) == path)
    }

    fn resolve(&self, path: &str) -> Result<Target, FsError> {
        let (path, query) = path.split_once('?').unwrap_or((path, ""));
        let parts: Vec<&str> = path.split('/').filter(|p| !p.is_empty() && *p != ".").collect();
        if parts.contains(&"..") {
            return Err(FsError::Protected);
        }
        let Some((first, rest)) = parts.split_first() else {
            return Ok(Target::Root);
        };
        if *first == PARAM_DIR {
            return match rest {
                [] => Ok(Target::ParamDir),
                [PARAM_FILE] => Ok(Target::ParamFile {
                    with_defaults: query.split('&').any(|q| q == "withdefaults=1"),
                }),
                _ => Err(FsError::NotFound),
            };
        }
        let (base, rest, writable) = match self.mounts.iter().find(|m| m.name == *first) {
            Some(m) => (m.dir.clone(), rest, false),
            None => (self.root.clone(), &parts[..], true),
        };
        let mut full = base;
        for part in rest {
            full.push(part);
            if fs::symlink_metadata(&full).is_ok_and(|m| m.file_type().is_symlink()) {
                return Err(FsError::Protected);
            }
        }
        let writable = writable && !self.owned(&full);
        Ok(Target::Disk(full, writable))
    }

    fn writable(&self, path: &str) -> Result<PathBuf, FsError> {
        match self.resolve(path)? {
            Target::Disk(p, true) => Ok(p),
            _ => Err(FsError::Protected),
        }
    }

    fn list_disk(&self, dir: &Path, root: bool) -> Result<Vec<Entry>, FsError> {
        let mut entries = Vec::new();
        for item in fs::read_dir(dir).map_err(|e| io_error(&e))?.flatten() {
            let name = item.file_name().to_string_lossy().into_owned();
            let Ok(kind) = item.file_type() else { continue };
            if root && name == SECRET {
                continue;
            }
            if kind.is_dir() {
                entries.push(Entry::Dir { name });
            } else if kind.is_file() {
                let size = item.metadata().map_or(0, |m| m.len());
                entries.push(Entry::File { name, size });
            }
        }
        entries.sort_by(|a, b| entry_name(a).cmp(entry_name(b)));
        if root {
            entries.push(Entry::Dir { name: PARAM_DIR.into() });
            entries.extend(self.mounts.iter().map(|m| Entry::Dir { name: m.name.clone() }));
        }
        Ok(entries)
    }
}

fn entry_name(e: &Entry) -> &str {
    match e {
        Entry::File { name, .. } | Entry::Dir { name } => name,
    }
}

fn size_u32(len: u64) -> Result<u32, FsError> {
    u32::try_from(len).map_err(|_| FsError::Errno(27)) // EFBIG
}

impl Files for DataFiles {
    type Handle = Handle;

    fn list(&mut self, dir: &str) -> Result<Vec<Entry>, FsError> {
        match self.resolve(dir)? {
            Target::Root => self.list_disk(&self.root, true),
            Target::ParamDir => Ok(vec![Entry::File {
                name: PARAM_FILE.into(),
                size: self.param_pack[0].len() as u64,
            }]),
            Target::ParamFile { .. } => Err(FsError::NotFound),
            Target::Disk(path, _) => self.list_disk(&path, false),
        }
    }

    fn open_read(&mut self, path: &str) -> Result<(Handle, u32), FsError> {
        match self.resolve(path)? {
            Target::ParamFile { with_defaults } => {
                let bytes = self.param_pack[usize::from(with_defaults)].clone();
                let size = size_u32(bytes.len() as u64)?;
                Ok((Handle::Memory(bytes), size))
            }
            Target::Disk(p, _) if self.owned(&p) && p.ends_with(SECRET) => Err(FsError::Protected),
            Target::Disk(p, _) => {
                let file = File::open(&p).map_err(|e| io_error(&e))?;
                let meta = file.metadata().map_err(|e| io_error(&e))?;
                if !meta.is_file() {
                    return Err(FsError::NotFound);
                }
                Ok((Handle::Disk(file), size_u32(meta.len())?))
            }
            Target::Root | Target::ParamDir => Err(FsError::NotFound),
        }
    }

    fn open_write(&mut self, path: &str, create: bool) -> Result<(Handle, u32), FsError> {
        let p = self.writable(path)?;
        let file = if create {
            OpenOptions::new().write(true).create(true).truncate(true).open(&p)
        } else {
            OpenOptions::new().write(true).open(&p)
        }
        .map_err(|e| io_error(&e))?;
        let size = size_u32(file.metadata().map_err(|e| io_error(&e))?.len())?;
        Ok((Handle::Disk(file), size))
    }

    fn read(&mut self, handle: &mut Handle, offset: u32, buf: &mut [u8]) -> Result<usize, FsError> {
        match handle {
            Handle::Memory(bytes) => {
                let from = (offset as usize).min(bytes.len());
                let n = buf.len().min(bytes.len() - from);
                buf[..n].copy_from_slice(&bytes[from..from + n]);
                Ok(n)
            }
            Handle::Disk(file) => {
                file.seek(SeekFrom::Start(u64::from(offset)))
                    .map_err(|e| io_error(&e))?;
                let mut n = 0;
                while n < buf.len() {
                    match file.read(&mut buf[n..]).map_err(|e| io_error(&e))? {
                        0 => break,
                        k => n += k,
                    }
                }
                Ok(n)
            }
        }
    }

    fn write(&mut self, handle: &mut Handle, offset: u32, data: &[u8]) -> Result<(), FsError> {
        let Handle::Disk(file) = handle else {
            return Err(FsError::Protected);
        };
        file.seek(SeekFrom::Start(u64::from(offset)))
            .map_err(|e| io_error(&e))?;
        file.write_all(data).map_err(|e| io_error(&e))
    }

    fn remove_file(&mut self, path: &str) -> Result<(), FsError> {
        fs::remove_file(self.writable(path)?).map_err(|e| io_error(&e))
    }

    fn create_dir(&mut self, path: &str) -> Result<(), FsError> {
        fs::create_dir(self.writable(path)?).map_err(|e| io_error(&e))
    }

    fn remove_dir(&mut self, path: &str) -> Result<(), FsError> {
        let p = self.writable(path)?;
        if p == self.root {
            return Err(FsError::Protected);
        }
        fs::remove_dir(p).map_err(|e| io_error(&e))
    }

    fn truncate(&mut self, path: &str, len: u32) -> Result<(), FsError> {
        let file = OpenOptions::new()
            .write(true)
            .open(self.writable(path)?)
            .map_err(|e| io_error(&e))?;
        file.set_len(u64::from(len)).map_err(|e| io_error(&e))
    }

    fn rename(&mut self, from: &str, to: &str) -> Result<(), FsError> {
        let (from, to) = (self.writable(from)?, self.writable(to)?);
        if from == self.root || to == self.root {
            return Err(FsError::Protected);
        }
        fs::rename(from, to).map_err(|e| io_error(&e))
    }

    fn crc32(&mut self, path: &str) -> Result<u32, FsError> {
        let (mut handle, _) = self.open_read(path)?;
        let mut hasher = crc32fast::Hasher::new_with_initial(u32::MAX);
        let mut buf = vec![0u8; 64 * 1024];
        let mut offset = 0u32;
        loop {
            let n = self.read(&mut handle, offset, &mut buf)?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            offset = offset.saturating_add(n as u32);
        }
        // crc32fast inverts on the way in and out (zlib's CRC-32); seeded
        // with all ones and inverted again, that is ArduPilot's plain one.
        Ok(hasher.finalize() ^ u32::MAX)
    }
}
