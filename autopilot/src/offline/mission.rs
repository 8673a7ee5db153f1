//! `furrow mission import|export|list --data-dir DIR`: the stored mission,
//! fence and rally plans, offline. Files are QGC WPL 110 (`.waypoints`,
//! `.txt`: one plan) or QGroundControl `.plan` (all three). An import is
//! validated exactly as an upload is, and changes nothing unless every
//! plan it brings is valid; errors name the line (or item) and the
//! MAV_MISSION_RESULT a ground station would have been told.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mission::files::{FileKind, format_f32, format_xy, plan_json, wpl};
use mission::validate::{command_name, frame_name, result_name};
use mission::{MissionItem, MissionType, Plan, Plans, validate_plan};

use crate::storage::data_dir::DataDir;
use crate::storage::missions;

#[derive(clap::Args, Debug)]
pub struct MissionArgs {
    /// The data directory (as given to `furrow sitl --data-dir`).
    #[arg(long, global = true, default_value = "furrow-data")]
    pub data_dir: PathBuf,
    #[command(subcommand)]
    pub action: MissionAction,
}

#[derive(clap::Subcommand, Debug)]
pub enum MissionAction {
    /// Replaces stored plans from a file: .waypoints or .txt (QGC WPL 110, one plan) or .plan (QGroundControl).
    ///
    /// A WPL file replaces the mission (or the plan --type names); a .plan file replaces all
    /// three (or only the one --type names). Nothing changes unless every plan is valid.
    Import {
        file: PathBuf,
        /// Which plan (default: mission for WPL files, all three for .plan files).
        #[arg(long = "type", value_enum, value_name = "TYPE")]
        plan: Option<PlanArg>,
    },
    /// Writes the stored plans to a file: .waypoints or .txt (QGC WPL 110, one plan) or .plan (all three).
    Export {
        file: PathBuf,
        /// Which plan, for WPL files (default: mission).
        #[arg(long = "type", value_enum, value_name = "TYPE")]
        plan: Option<PlanArg>,
    },
    /// Lists the stored plans, one line per item.
    List {
        /// Only this plan (default: all three).
        #[arg(long = "type", value_enum, value_name = "TYPE")]
        plan: Option<PlanArg>,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PlanArg {
    Mission,
    Fence,
    Rally,
}

impl PlanArg {
    fn mission_type(self) -> MissionType {
        match self {
            PlanArg::Mission => MissionType::Mission,
            PlanArg::Fence => MissionType::Fence,
            PlanArg::Rally => MissionType::Rally,
        }
    }
}

pub fn run(args: &MissionArgs) -> Result<(), String> {
    let (dir, _profile) = DataDir::open_offline(&args.data_dir)?;
    let (plans, notices) = missions::load_quietly(dir.path());
    for (_, text) in &notices {
        eprintln!("warning: {text}");
    }
    let text = match &args.action {
        MissionAction::Import { file, plan } => import(dir.path(), file, *plan)?,
        MissionAction::Export { file, plan } => export(&plans, file, *plan)?,
        MissionAction::List { plan } => list(&plans, *plan),
    };
    print!("{text}");
    Ok(())
}

fn read(file: &Path) -> Result<(String, FileKind), String> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let kind = FileKind::from_path(file)
        .or_else(|| FileKind::sniff(&text))
        .ok_or_else(|| {
            format!(
                "{}: not a mission file: use .waypoints or .txt (QGC WPL 110) or .plan (QGroundControl)",
                file.display()
            )
        })?;
    Ok((text, kind))
}

/// What a validation error means, with the line it came from when known.
fn explain(
    mission_type: MissionType,
    seq: u16,
    result: mavlink::dialects::ardupilotmega::MavMissionResult,
    line: Option<usize>,
) -> String {
    let at = line.map_or(String::new(), |l| format!("line {l}, "));
    format!("{at}{} item {seq}: {}", mission_type.name(), result_name(result))
}

/// A hint when a file looks like another kind of plan than the one asked.
fn hint(mission_type: MissionType, items: &[MissionItem]) -> &'static str {
    let looks = |lo: u16, hi: u16| items.iter().skip(1).any(|it| (lo..=hi).contains(&it.command));
    match mission_type {
        MissionType::Fence | MissionType::Rally if looks(16, 16) => " (a mission file? use --type mission)",
        MissionType::Mission | MissionType::Rally if looks(5000, 5004) => " (a fence file? use --type fence)",
        MissionType::Mission | MissionType::Fence if looks(5100, 5100) => " (a rally file? use --type rally)",
        _ => "",
    }
}

/// Validates and stores the plans in `file`. All or nothing: nothing is
/// written unless every plan it brings is valid.
fn import(dir: &Path, file: &Path, plan: Option<PlanArg>) -> Result<String, String> {
    let (text, kind) = read(file)?;
    let nothing = |why: String| format!("{}: nothing imported: {why}", file.display());
    let staged: Vec<(MissionType, Plan)> = match kind {
        FileKind::Wpl => {
            let t = plan.map_or(MissionType::Mission, PlanArg::mission_type);
            let lines = wpl::parse_lines(&text).map_err(|e| nothing(e.to_string()))?;
            let line_of: Vec<usize> = lines.iter().map(|(l, _)| *l).collect();
            let items: Vec<MissionItem> = lines.into_iter().map(|(_, it)| it).collect();
            let hint = hint(t, &items);
            let plan = validate_plan(t, items).map_err(|(seq, result)| {
                nothing(format!(
                    "{}{hint}",
                    explain(t, seq, result, line_of.get(usize::from(seq)).copied())
                ))
            })?;
            vec![(t, plan)]
        }
        FileKind::PlanJson => {
            let parsed = plan_json::parse(&text).map_err(|e| nothing(e.to_string()))?;
            let all = [
                (MissionType::Mission, parsed.mission),
                (MissionType::Fence, parsed.fence),
                (MissionType::Rally, parsed.rally),
            ];
            let mut staged = Vec::new();
            let mut errors = Vec::new();
            for (t, items) in all {
                if plan.is_some_and(|p| p.mission_type() != t) {
                    continue;
                }
                match validate_plan(t, items) {
                    Ok(p) => staged.push((t, p)),
                    Err((seq, result)) => errors.push(explain(t, seq, result, None)),
                }
            }
            if !errors.is_empty() {
                return Err(nothing(errors.join("; ")));
            }
            staged
        }
    };
    let mut report = String::new();
    for (t, p) in &staged {
        missions::save(dir, *t, p).map_err(|e| format!("saving the {} in {}: {e}", t.name(), dir.display()))?;
        let _ = writeln!(
            report,
            "{}: {} {} items imported (id {:08x})",
            file.display(),
            p.len(),
            t.name(),
            p.opaque_id()
        );
    }
    Ok(report)
}

fn export(plans: &Plans, file: &Path, plan: Option<PlanArg>) -> Result<String, String> {
    let (text, what) = match FileKind::from_path(file) {
        Some(FileKind::PlanJson) => {
            if plan.is_some() {
                return Err(format!(
                    "{}: a .plan file holds all three plans: --type applies to .waypoints files only",
                    file.display()
                ));
            }
            let what = MissionType::ALL
                .iter()
                .map(|t| format!("{} {}", plans.get(*t).len(), t.name()))
                .collect::<Vec<_>>()
                .join(", ");
            (plan_json::render(plans, None), format!("{what} items"))
        }
        _ => {
            let t = plan.map_or(MissionType::Mission, PlanArg::mission_type);
            let p = plans.get(t);
            (wpl::render(p), format!("{} {} items", p.len(), t.name()))
        }
    };
    params::store::write_atomic(file, text.as_bytes()).map_err(|e| format!("{}: {e}", file.display()))?;
    Ok(format!("{}: {what} written\n", file.display()))
}

fn describe(mission_type: MissionType, it: &MissionItem) -> String {
    let mut line = format!(
        "{:>5}  {:<26} {:<22} {:>13} {:>13} {:>8}   {} {} {} {}",
        it.seq,
        command_name(it.command),
        frame_name(it.frame),
        format_xy(it.frame, it.x),
        format_xy(it.frame, it.y),
        format_f32(it.z),
        format_f32(it.params[0]),
        format_f32(it.params[1]),
        format_f32(it.params[2]),
        format_f32(it.params[3]),
    );
    if mission_type == MissionType::Mission && it.seq == 0 {
        line.push_str("  (home)");
    }
    if it.current {
        line.push_str("  current");
    }
    if !it.autocontinue && mission_type == MissionType::Mission {
        line.push_str("  no-autocontinue");
    }
    line
}

fn list(plans: &Plans, plan: Option<PlanArg>) -> String {
    let mut text = String::new();
    for t in MissionType::ALL {
        if plan.is_some_and(|p| p.mission_type() != t) {
            continue;
        }
        let p = plans.get(t);
        let _ = writeln!(text, "{}: {} items (id {:08x})", t.name(), p.len(), p.opaque_id());
        if !p.is_empty() {
            let _ = writeln!(
                text,
                "{:>5}  {:<26} {:<22} {:>13} {:>13} {:>8}   params 1-4",
                "seq", "command", "frame", "x/lat", "y/lon", "z/alt"
            );
        }
        for it in p.items() {
            let _ = writeln!(text, "{}", describe(t, it));
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sitl::simulation::ModelKind;
    use crate::storage::data_dir::Profile;
    use std::fs;

    fn bench(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data/bench")
            .join(name)
    }

    fn args(dir: &Path, action: MissionAction) -> MissionArgs {
        MissionArgs {
            data_dir: dir.to_path_buf(),
            action,
        }
    }

    #[test]
    fn import_list_export_and_back() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let out = import(dir, &bench("agv_course.waypoints"), None).unwrap();
        assert!(out.contains("26 mission items imported"), "{out}");
        let (plans, notices) = missions::load_quietly(dir);
        assert!(notices.is_empty());
        assert_eq!(plans.mission.len(), 26);
        let listed = list(&plans, Some(PlanArg::Mission));
        assert_eq!(listed.lines().count(), 2 + 26, "{listed}");
        assert!(listed.contains("(home)") && listed.contains("DO_SET_SERVO"), "{listed}");
        // A fence and rally points by hand, then everything through a .plan file.
        let fence = dir.join("fence.txt");
        fs::write(
            &fence,
            "QGC WPL 110\n\
             0\t0\t0\t5001\t3\t0\t0\t0\t29.1330000\t119.6400000\t0\t0\n\
             1\t0\t0\t5001\t3\t0\t0\t0\t29.1340000\t119.6400000\t0\t0\n\
             2\t0\t0\t5001\t3\t0\t0\t0\t29.1340000\t119.6410000\t0\t0\n",
        )
        .unwrap();
        import(dir, &fence, Some(PlanArg::Fence)).unwrap();
        let exported = dir.join("all.plan");
        let out = export(&missions::load_quietly(dir).0, &exported, None).unwrap();
        assert!(out.contains("26 mission, 3 fence, 0 rally items"), "{out}");
        let before = missions::load_quietly(dir).0;
        fs::remove_file(dir.join("fence.waypoints")).unwrap();
        let out = import(dir, &exported, None).unwrap();
        assert_eq!(out.lines().count(), 3, "{out}");
        let after = missions::load_quietly(dir).0;
        assert_eq!(after.fence.opaque_id(), before.fence.opaque_id());
        for (a, b) in after.mission.items().iter().zip(before.mission.items()).skip(1) {
            assert_eq!((a.command, a.x, a.y, a.params), (b.command, b.x, b.y, b.params));
        }
        // WPL export is lossless.
        let wp = dir.join("out.waypoints");
        export(&before, &wp, None).unwrap();
        import(dir, &wp, None).unwrap();
        assert_eq!(
            missions::load_quietly(dir).0.mission.opaque_id(),
            before.mission.opaque_id()
        );
        assert!(export(&before, &exported, Some(PlanArg::Fence)).is_err());
    }

    #[test]
    fn a_delay_beyond_a_day_is_refused_at_import_and_a_stored_one_is_not_run() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let huge = "QGC WPL 110\n\
                    0\t1\t0\t16\t0\t0\t0\t0\t29.1330000\t119.6400000\t40\t1\n\
                    1\t0\t2\t93\t1e20\t0\t0\t0\t0\t0\t0\t1\n";
        let file = dir.join("huge.waypoints");
        fs::write(&file, huge).unwrap();
        let e = import(dir, &file, None).unwrap_err();
        assert!(e.contains("line 3") && e.contains("INVALID_PARAM1"), "{e}");
        // The same plan written straight into the data directory (an older
        // version's file, or a damaged one): loaded as a notice, not run.
        fs::write(missions::path(dir, MissionType::Mission), huge).unwrap();
        let (plans, notices) = missions::load_quietly(dir);
        assert!(plans.mission.is_empty());
        assert!(notices.iter().any(|(_, n)| n.contains("INVALID_PARAM1")), "{notices:?}");
    }

    #[test]
    fn a_bad_file_changes_nothing_and_the_error_names_line_and_result() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        import(dir, &bench("square_40m.waypoints"), None).unwrap();
        let before = missions::load_quietly(dir).0;
        let bad = dir.join("bad.waypoints");
        fs::write(
            &bad,
            "QGC WPL 110\n\
             0\t1\t0\t16\t0\t0\t0\t0\t29.1330000\t119.6400000\t40\t1\n\
             \n\
             1\t0\t3\t16\t-4\t0\t0\t0\t29.1330000\t119.6400000\t0\t1\n",
        )
        .unwrap();
        let e = import(dir, &bad, None).unwrap_err();
        assert!(e.contains("nothing imported") && e.contains("line 4"), "{e}");
        assert!(e.contains("mission item 1") && e.contains("INVALID_PARAM1"), "{e}");
        fs::write(&bad, "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\n").unwrap();
        let e = import(dir, &bad, None).unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        // A fence file imported as a mission.
        fs::write(
            &bad,
            "QGC WPL 110\n0\t0\t0\t5001\t3\t0\t0\t0\t1\t1\t0\t0\n1\t0\t0\t5001\t3\t0\t0\t0\t1\t2\t0\t0\n",
        )
        .unwrap();
        let e = import(dir, &bad, None).unwrap_err();
        assert!(e.contains("UNSUPPORTED") && e.contains("--type fence"), "{e}");
        // A .plan whose rally point is fine but whose fence polygon is short.
        let plan = dir.join("bad.plan");
        fs::write(
            &plan,
            r#"{"fileType": "Plan", "groundStation": "x", "version": 1,
                "geoFence": {"version": 2, "circles": [], "polygons": [{"inclusion": true, "polygon": [[29.1, 119.6], [29.2, 119.6]]}]},
                "rallyPoints": {"version": 2, "points": [[29.1, 119.6, 3]]}}"#,
        )
        .unwrap();
        let e = import(dir, &plan, None).unwrap_err();
        assert!(e.contains("fence item 0") && e.contains("INVALID_PARAM1"), "{e}");
        // Only its rally points: fine.
        import(dir, &plan, Some(PlanArg::Rally)).unwrap();
        let after = missions::load_quietly(dir).0;
        assert_eq!(after.mission.opaque_id(), before.mission.opaque_id());
        assert!(after.fence.is_empty());
        assert_eq!(after.rally.len(), 1);
        let e = import(dir, &dir.join("missing.waypoints"), None).unwrap_err();
        assert!(e.contains("missing.waypoints"), "{e}");
        fs::write(dir.join("x.bin"), "hello").unwrap();
        let e = import(dir, &dir.join("x.bin"), None).unwrap_err();
        assert!(e.contains("not a mission file"), "{e}");
    }

    #[test]
    fn a_running_vehicle_locks_the_directory() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let held = DataDir::open(dir, Profile::Sitl(ModelKind::Ackermann)).unwrap();
        let e = run(&args(dir, MissionAction::List { plan: None })).unwrap_err();
        assert!(e.contains("in use"), "{e}");
        drop(held);
        run(&args(dir, MissionAction::List { plan: None })).unwrap();
        let e = run(&args(&dir.join("nope"), MissionAction::List { plan: None })).unwrap_err();
        assert!(e.contains("does not exist"), "{e}");
    }
}
