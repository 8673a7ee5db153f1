//! Persistence in the data directory: `params.parm` holds the parameters
//! whose value differs from the default, in Mission Planner's `.param`
//! layout (human-readable, and loadable by any GCS).
//!
//! Writes are atomic: a temporary file is written and fsynced, then renamed
//! over the old one and the directory fsynced, so a crash or kill at any
//! instant leaves either the old file or the new one. A file that does not
//! parse is moved aside (never silently replaced) and defaults are used.

use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::files::{FileFormat, format_value, parse};
use crate::table::ParamTable;

pub const STORE_FILE: &str = "params.parm";

/// What loading found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    pub applied: usize,
    /// Entries skipped (unknown names, values out of range), one line each.
    pub warnings: Vec<String>,
    /// Where an unreadable file was moved, and why it was unreadable.
    pub corrupt: Option<(PathBuf, String)>,
}

/// The non-default values of a table, ready to be written by another thread.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshot {
    lines: Vec<String>,
}

impl Snapshot {
    pub fn of(table: &ParamTable) -> Snapshot {
        Self::of_adjusted(table, |_, value| value)
    }

    /// Like [`Snapshot::of`], storing `adjust(index, value)` instead of each
    /// value (for session overrides that must not replace what was stored).
    pub fn of_adjusted(table: &ParamTable, adjust: impl Fn(u16, f64) -> f64) -> Snapshot {
        let mut lines: Vec<String> = (0..table.len() as u16)
            .map(|i| (table.def(i), adjust(i, table.value(i))))
            .filter(|(d, v)| *v != d.default)
            .map(|(d, v)| format!("{},{}", d.name, format_value(d.ty, v)))
            .collect();
        lines.sort();
        Snapshot { lines }
    }

    /// The file's text.
    pub fn render(&self) -> String {
        let mut text = String::from(
            "# Furrow parameters that differ from their defaults (Mission Planner .param layout).\n\
             # Written atomically by furrow; edit only while it is stopped.\n",
        );
        for line in &self.lines {
            text.push_str(line);
            text.push('\n');
        }
        text
    }
}

/// Writes `bytes` to `path` atomically (temp file, fsync, rename, fsync dir).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "no file name"))?;
    let mut tmp_name = name.to_os_string();
    tmp_name.push(".tmp");
    let tmp = dir.join(tmp_name);
    {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    fs::rename(&tmp, path)?;
    File::open(dir)?.sync_all()
}

/// Saves a snapshot into `dir`.
pub fn save(dir: &Path, snapshot: &Snapshot) -> io::Result<()> {
    write_atomic(&dir.join(STORE_FILE), snapshot.render().as_bytes())
}

/// Moves an unreadable file aside under a name that does not exist yet.
fn move_aside(path: &Path) -> io::Result<PathBuf> {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    for n in 0.. {
        let candidate = path.with_extension(format!("parm.corrupt-{secs}-{n}"));
        if !candidate.exists() {
            fs::rename(path, &candidate)?;
            return Ok(candidate);
        }
    }
    unreachable!("an unused name exists")
}

/// Loads `dir/params.parm` into `table`. A missing file is not an error.
pub fn load(dir: &Path, table: &mut ParamTable) -> io::Result<LoadReport> {
    let path = dir.join(STORE_FILE);
    let bytes = match fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(LoadReport::default()),
        Err(e) => return Err(e),
    };
    let parsed = String::from_utf8(bytes)
        .map_err(|_| "not UTF-8 text".to_string())
        .and_then(|text| parse(&text, FileFormat::MissionPlanner).map_err(|e| e.to_string()));
    let entries = match parsed {
        Ok(entries) => entries,
        Err(why) => {
            let moved = move_aside(&path)?;
            return Ok(LoadReport {
                corrupt: Some((moved, why)),
                ..LoadReport::default()
            });
        }
    };
    let mut report = LoadReport::default();
    for entry in entries {
        let Some(index) = table.index_of(&entry.name) else {
            report.warnings.push(format!(
                "{STORE_FILE} line {}: unknown parameter {} ignored",
                entry.line, entry.name
            ));
            continue;
        };
        // Our own file may hold read-only bookkeeping values (boot count).
        match table.set_internal(index, entry.value) {
            Ok(_) => report.applied += 1,
            Err(e) => report.warnings.push(format!(
                "{STORE_FILE} line {}: {} {e}, default kept",
                entry.line, entry.name
            )),
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::def::{ParamDef, ParamFlags, ParamName, ParamType};
    use crate::table::ParamTableBuilder;

    fn table() -> ParamTable {
        let mut b = ParamTableBuilder::new();
        for (name, ty, default, max) in [
            ("WP_SPEED", ParamType::Real32, 2.0, 10.0),
            ("FS_ACTION", ParamType::Int8, 2.0, 5.0),
        ] {
            b.add(ParamDef {
                name: ParamName::new(name).unwrap(),
                ty,
                default,
                min: 0.0,
                max,
                unit: "",
                description: "",
                flags: ParamFlags::default(),
            });
        }
        b.build()
    }

    #[test]
    fn only_non_defaults_are_stored_and_they_load_back() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let mut t = table();
        t.set_by_name("WP_SPEED", 3.3).unwrap();
        save(dir, &Snapshot::of(&t)).unwrap();
        let text = fs::read_to_string(dir.join(STORE_FILE)).unwrap();
        assert!(text.contains("WP_SPEED,3.3\n") && !text.contains("FS_ACTION"), "{text}");
        let mut fresh = table();
        let report = load(dir, &mut fresh).unwrap();
        assert_eq!(report.applied, 1);
        assert_eq!(fresh.value_of("WP_SPEED"), Some(f64::from(3.3f32)));
    }

    #[test]
    fn corrupt_file_is_moved_aside_and_defaults_used() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        fs::write(dir.join(STORE_FILE), "WP_SPEED,3\nWP_SPE").unwrap();
        let mut t = table();
        let report = load(dir, &mut t).unwrap();
        let (moved, why) = report.corrupt.expect("reported corrupt");
        assert!(why.contains("line 2"), "{why}");
        assert!(moved.exists() && !dir.join(STORE_FILE).exists());
        assert_eq!(t.value_of("WP_SPEED"), Some(2.0));
    }

    #[test]
    fn unknown_and_out_of_range_entries_are_skipped_with_a_warning() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        fs::write(dir.join(STORE_FILE), "OLD_PARAM,1\nWP_SPEED,99\nFS_ACTION,1\n").unwrap();
        let mut t = table();
        let report = load(dir, &mut t).unwrap();
        assert_eq!(report.applied, 1);
        assert_eq!(report.warnings.len(), 2);
        assert_eq!(t.value_of("FS_ACTION"), Some(1.0));
    }

    #[test]
    fn atomic_write_leaves_no_temp_file() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        write_atomic(&dir.join("x.txt"), b"one").unwrap();
        write_atomic(&dir.join("x.txt"), b"two").unwrap();
        assert_eq!(fs::read(dir.join("x.txt")).unwrap(), b"two");
        assert!(!dir.join("x.txt.tmp").exists());
    }
}
