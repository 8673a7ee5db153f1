//! `furrow params list|get|set|import|export --data-dir DIR`: the stored
//! parameter table, offline. Every change is validated first and written
//! atomically; a bad request changes nothing.

use std::path::{Path, PathBuf};

use params::files::{FileFormat, format_mission_planner, format_qgroundcontrol, format_value, parse};
use params::store::{self, Snapshot};
use params::{ParamTable, SetError};

use crate::sitl::simulation::SimulationParams;
use crate::storage::data_dir::{DataDir, Profile};

#[derive(clap::Args, Debug)]
pub struct ParamsArgs {
    /// The data directory (as given to `furrow sitl --data-dir`).
    #[arg(long, global = true, default_value = "furrow-data")]
    pub data_dir: PathBuf,
    #[command(subcommand)]
    pub action: ParamsAction,
}

#[derive(clap::Subcommand, Debug)]
pub enum ParamsAction {
    /// Every parameter with its value (and its default when it differs).
    List {
        /// Only parameters that differ from their defaults.
        #[arg(long)]
        changed: bool,
    },
    /// One parameter's value.
    Get { name: String },
    /// Sets one parameter.
    Set { name: String, value: String },
    /// Sets parameters from a Mission Planner .param or QGroundControl .params file.
    Import { file: PathBuf },
    /// Writes every parameter to a .param (Mission Planner) or .params (QGroundControl) file.
    Export {
        file: PathBuf,
        /// File layout; by default from the extension (.params: QGroundControl).
        #[arg(long, value_enum)]
        format: Option<FormatArg>,
    },
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum FormatArg {
    /// Mission Planner / MAVProxy `NAME,VALUE`.
    Param,
    /// QGroundControl tab-separated.
    Params,
}

pub fn run(args: &ParamsArgs) -> Result<(), String> {
    let (dir, profile) = DataDir::open_offline(&args.data_dir)?;
    let mut table = match profile {
        Profile::Sitl(model) => SimulationParams::new(model).table,
        Profile::Vehicle(model) => crate::run::runner::vehicle_params(model).0,
    };
    let report = store::load(dir.path(), &mut table).map_err(|e| format!("{}: {e}", dir.path().display()))?;
    if let Some((moved, why)) = report.corrupt {
        eprintln!(
            "warning: stored parameters unreadable ({why}); moved to {}, showing defaults",
            moved.display()
        );
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    match &args.action {
        ParamsAction::List { changed } => list(&table, *changed),
        ParamsAction::Get { name } => {
            let index = table
                .index_of(name)
                .ok_or_else(|| format!("unknown parameter {name}"))?;
            println!("{}", format_value(table.def(index).ty, table.value(index)));
            Ok(())
        }
        ParamsAction::Set { name, value } => {
            let v = parse_number(name, value)?;
            let now = table.set_by_name(name, v).map_err(|e| explain(name, v, e))?;
            save(dir.path(), &table)?;
            let index = table.index_of(name).unwrap_or_default();
            println!("{name} = {}", format_value(table.def(index).ty, now));
            Ok(())
        }
        ParamsAction::Import { file } => import(dir.path(), &mut table, file),
        ParamsAction::Export { file, format } => export(&table, file, *format),
    }
}

fn parse_number(name: &str, text: &str) -> Result<f64, String> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("{name}: {text:?} is not a number"))
}

fn explain(name: &str, value: f64, e: SetError) -> String {
    match e {
        SetError::UnknownName(_) => format!("unknown parameter {name}"),
        other => format!("{name} = {value}: {other}"),
    }
}

fn save(dir: &Path, table: &ParamTable) -> Result<(), String> {
    store::save(dir, &Snapshot::of(table)).map_err(|e| format!("saving parameters in {}: {e}", dir.display()))
}

fn list(table: &ParamTable, changed_only: bool) -> Result<(), String> {
    for (def, value) in table.iter() {
        let changed = value != def.default;
        if changed_only && !changed {
            continue;
        }
        let shown = format_value(def.ty, value);
        let unit = if def.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", def.unit)
        };
        if changed {
            println!(
                "{:<16} {shown}{unit} (default {})",
                def.name,
                format_value(def.ty, def.default)
            );
        } else {
            println!("{:<16} {shown}{unit}", def.name);
        }
    }
    Ok(())
}

/// A file as text; not UTF-8 (a binary file, a wrong encoding) says which
/// line and byte, as a syntax error does.
fn read_text(file: &Path) -> Result<String, String> {
    let bytes = std::fs::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = good.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = good.len() - good.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1) + 1;
        format!(
            "{}: line {line}: byte {column} is not UTF-8 text (a binary file, or another encoding)",
            file.display()
        )
    })
}

/// All or nothing: syntax errors and refused values abort; unknown and
/// read-only parameters (from another vehicle's file, or an export that
/// includes counters) are skipped and listed.
fn import(dir: &Path, table: &mut ParamTable, file: &Path) -> Result<(), String> {
    let text = read_text(file)?;
    let entries = parse(&text, FileFormat::from_path(file)).map_err(|e| format!("{}: {e}", file.display()))?;
    let mut staged = table.clone();
    let mut errors = Vec::new();
    let mut skipped = Vec::new();
    let mut changed = 0;
    for e in &entries {
        let Some(index) = staged.index_of(&e.name) else {
            skipped.push(format!("{} (line {}): unknown parameter", e.name, e.line));
            continue;
        };
        if staged.def(index).flags.read_only {
            skipped.push(format!("{} (line {}): read-only", e.name, e.line));
            continue;
        }
        let before = staged.value(index);
        match staged.set(index, e.value) {
            Ok(now) if now != before => changed += 1,
            Ok(_) => {}
            Err(err) => errors.push(format!("line {}: {}", e.line, explain(&e.name, e.value, err))),
        }
    }
    if !errors.is_empty() {
        return Err(format!(
            "{}: nothing imported:\n  {}",
            file.display(),
            errors.join("\n  ")
        ));
    }
    *table = staged;
    save(dir, table)?;
    println!(
        "{}: {} parameters read, {changed} changed, {} skipped",
        file.display(),
        entries.len(),
        skipped.len()
    );
    for s in skipped {
        println!("  skipped {s}");
    }
    Ok(())
}

fn export(table: &ParamTable, file: &Path, format: Option<FormatArg>) -> Result<(), String> {
    let format = match format {
        Some(FormatArg::Param) => FileFormat::MissionPlanner,
        Some(FormatArg::Params) => FileFormat::QGroundControl,
        None => FileFormat::from_path(file),
    };
    let header = format!("Furrow {} parameters", env!("CARGO_PKG_VERSION"));
    let text = match format {
        FileFormat::MissionPlanner => format_mission_planner(table.iter(), &header),
        FileFormat::QGroundControl => {
            let sysid = table.value_of("SYSID_THISMAV").unwrap_or(1.0) as u8;
            format_qgroundcontrol(
                table.iter(),
                sysid,
                crate::vehicle::COMPONENT_ID,
                &format!("{header}\nStack: ArduPilot\nVehicle: Rover"),
            )
        }
    };
    store::write_atomic(file, text.as_bytes()).map_err(|e| format!("{}: {e}", file.display()))?;
    println!("{}: {} parameters written", file.display(), table.len());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_binary_file_names_its_line() {
        let scratch = tempfile::Builder::new().suffix(".param").tempfile().unwrap();
        let file = scratch.path();
        std::fs::write(file, b"WP_SPEED,2\nWP_RADIUS,\xff\xfe1\n").unwrap();
        let e = read_text(file).unwrap_err();
        assert!(e.contains("line 2: byte 11 is not UTF-8"), "{e}");
        std::fs::write(file, b"WP_SPEED,2\n").unwrap();
        assert_eq!(read_text(file).unwrap(), "WP_SPEED,2\n");
    }
}
