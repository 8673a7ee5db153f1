//! The three plans in the data directory: `mission.waypoints`,
//! `fence.waypoints` and `rally.waypoints`, in QGC WPL 110 (lossless as
//! Furrow writes it, and loadable by Mission Planner, MAVProxy and
//! QGroundControl).
//!
//! Writes are atomic ([`params::store::write_atomic`]: temporary file,
//! fsync, rename, fsync of the directory), so a crash or a kill at any
//! instant leaves the old plan or the new one. A file that does not parse,
//! or whose plan fails [`mission::validate_plan`], is moved aside (never
//! overwritten) and that plan starts empty, with a notice for the operator.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use mavlink::dialects::ardupilotmega::MavSeverity;
use mission::files::wpl;
use mission::validate::result_name;
use mission::{MissionType, Plan, Plans, validate_plan};

/// The file holding a plan, in the data directory.
pub fn file_name(mission_type: MissionType) -> &'static str {
    match mission_type {
        MissionType::Mission => "mission.waypoints",
        MissionType::Fence => "fence.waypoints",
        MissionType::Rally => "rally.waypoints",
    }
}

/// Moves an unreadable file aside as `<name>.corrupt-<unix secs>-<n>`,
/// under a name that does not exist yet.
fn move_aside(path: &Path) -> io::Result<PathBuf> {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    for n in 0u32.. {
        let candidate = path.with_file_name(format!("{name}.corrupt-{secs}-{n}"));
        if !candidate.exists() {
            fs::rename(path, &candidate)?;
            return Ok(candidate);
        }
    }
    unreachable!("an unused name exists")
}

/// Reads one plan's file: `Ok(None)` when there is none, `Err(why)` when
/// it is unreadable as a plan.
fn read_plan(path: &Path, mission_type: MissionType) -> io::Result<Result<Option<Plan>, String>> {
    let bytes = match fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Ok(None)),
        Err(e) => return Err(e),
    };
    let Ok(text) = String::from_utf8(bytes) else {
        return Ok(Err("not UTF-8 text".into()));
    };
    let lines = match wpl::parse_lines(&text) {
        Ok(lines) => lines,
        Err(e) => return Ok(Err(e.to_string())),
    };
    let line_of: Vec<usize> = lines.iter().map(|(line, _)| *line).collect();
    let items = lines.into_iter().map(|(_, item)| item).collect();
    Ok(match validate_plan(mission_type, items) {
        Ok(plan) => Ok(Some(plan)),
        Err((seq, result)) => {
            let at = line_of
                .get(usize::from(seq))
                .map_or(String::new(), |l| format!("line {l}: "));
            Err(format!(
                "{at}{} item {seq}: {}",
                mission_type.name(),
                result_name(result)
            ))
        }
    })
}

/// Loads the three plans from `dir`. Missing files are empty plans;
/// unreadable ones are moved aside and reported in the notices (and logged).
pub fn load(dir: &Path) -> (Plans, Vec<(MavSeverity, String)>) {
    let (plans, notices) = load_quietly(dir);
    for (_, text) in &notices {
        tracing::error!("{}: {text}", dir.display());
    }
    for t in MissionType::ALL {
        let n = plans.get(t).len();
        if n > 0 {
            tracing::info!("{n} {} items loaded from {}", t.name(), path(dir, t).display());
        }
    }
    (plans, notices)
}

/// [`load`] without logging (for the offline tools, which print).
pub fn load_quietly(dir: &Path) -> (Plans, Vec<(MavSeverity, String)>) {
    let mut plans = Plans::default();
    let mut notices = Vec::new();
    for mission_type in MissionType::ALL {
        let name = file_name(mission_type);
        let empty = mission_type.name();
        let text = match read_plan(&path(dir, mission_type), mission_type) {
            Ok(Ok(Some(plan))) => {
                plans.set(mission_type, plan);
                continue;
            }
            Ok(Ok(None)) => continue,
            Ok(Err(why)) => match move_aside(&path(dir, mission_type)) {
                Ok(moved) => format!(
                    "{name} unreadable ({why}): moved to {}; {empty} empty",
                    moved
                        .file_name()
                        .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                ),
                Err(e) => format!("{name} unreadable ({why}) and not moved aside ({e}); {empty} empty"),
            },
            Err(e) => format!("{name} could not be read ({e}); {empty} empty"),
        };
        notices.push((MavSeverity::MAV_SEVERITY_CRITICAL, text));
    }
    (plans, notices)
}

/// Where a plan's file is in `dir`.
pub fn path(dir: &Path, mission_type: MissionType) -> PathBuf {
    dir.join(file_name(mission_type))
}

/// What a plan's file holds (for [`save`], or for the core's file writer:
/// `writer.write(path(dir, t), contents(&plan))`).
pub fn contents(plan: &Plan) -> Vec<u8> {
    wpl::render(plan).into_bytes()
}

/// Saves one plan into `dir`, atomically.
pub fn save(dir: &Path, mission_type: MissionType, plan: &Plan) -> io::Result<()> {
    params::store::write_atomic(&path(dir, mission_type), &contents(plan))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mission::MissionItem;
    use mission::command::{cmd, frame};

    fn wp(seq: u16, x: i32, y: i32) -> MissionItem {
        MissionItem {
            seq,
            frame: frame::GLOBAL_RELATIVE_ALT,
            command: cmd::NAV_WAYPOINT,
            current: false,
            autocontinue: true,
            params: [0.0, 0.0, 0.0, f32::NAN],
            x,
            y,
            z: 0.0,
        }
    }

    fn mission() -> Plan {
        validate_plan(
            MissionType::Mission,
            vec![
                wp(0, 291_330_000, 1_196_400_000),
                wp(1, 291_335_413, 1_196_400_001),
                wp(2, -1, -1),
            ],
        )
        .unwrap()
    }

    fn rally() -> Plan {
        let mut p = wp(0, 291_330_000, 1_196_400_000);
        p.command = cmd::NAV_RALLY_POINT;
        validate_plan(MissionType::Rally, vec![p]).unwrap()
    }

    #[test]
    fn plans_are_saved_and_load_back_with_the_same_ids() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        save(dir, MissionType::Mission, &mission()).unwrap();
        save(dir, MissionType::Rally, &rally()).unwrap();
        let (plans, notices) = load(dir);
        assert!(notices.is_empty(), "{notices:?}");
        assert_eq!(plans.mission.opaque_id(), mission().opaque_id());
        assert_eq!(plans.rally.opaque_id(), rally().opaque_id());
        assert!(plans.fence.is_empty(), "no file: empty");
        assert!(!dir.join("mission.waypoints.tmp").exists());
        let text = fs::read_to_string(dir.join("mission.waypoints")).unwrap();
        assert!(text.starts_with("QGC WPL 110\n0\t0\t3\t16\t"), "{text}");
    }

    #[test]
    fn unreadable_and_invalid_files_are_moved_aside_and_never_overwritten() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        save(dir, MissionType::Rally, &rally()).unwrap();
        fs::write(
            dir.join("mission.waypoints"),
            "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\n",
        )
        .unwrap();
        // Parses, but a fence polygon of 3 vertices has only 2.
        fs::write(
            dir.join("fence.waypoints"),
            "QGC WPL 110\n0\t0\t0\t5001\t3\t0\t0\t0\t29.1\t119.6\t0\t0\n1\t0\t0\t5001\t3\t0\t0\t0\t29.2\t119.6\t0\t0\n",
        )
        .unwrap();
        let (plans, notices) = load(dir);
        assert!(plans.mission.is_empty() && plans.fence.is_empty());
        assert_eq!(plans.rally.opaque_id(), rally().opaque_id());
        assert_eq!(notices.len(), 2, "{notices:?}");
        assert!(notices[0].1.contains("line 2"), "{notices:?}");
        assert!(
            notices[1].1.contains("fence item 2") && notices[1].1.contains("INVALID_PARAM1"),
            "{notices:?}"
        );
        assert!(!dir.join("mission.waypoints").exists() && !dir.join("fence.waypoints").exists());
        // The same name again: a second file aside, the first kept.
        fs::write(dir.join("mission.waypoints"), "garbage").unwrap();
        let (_, notices) = load(dir);
        assert_eq!(notices.len(), 1);
        let aside: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("mission.waypoints.corrupt-"))
            .collect();
        assert_eq!(aside.len(), 2, "{aside:?}");
    }

    #[test]
    fn the_file_writer_can_save_plans() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        {
            let (w, _done) = crate::storage::file_writer::FileWriter::start();
            w.save(
                1,
                path(dir, MissionType::Rally),
                contents(&Plan::new(MissionType::Rally, Vec::new())),
            );
            w.save(2, path(dir, MissionType::Mission), contents(&mission()));
            w.save(3, path(dir, MissionType::Rally), contents(&rally()));
        }
        let (plans, notices) = load(dir);
        assert!(notices.is_empty());
        assert_eq!(plans.mission.opaque_id(), mission().opaque_id());
        assert_eq!(plans.rally.opaque_id(), rally().opaque_id());
    }
}
