//! Parameter files (`params::files`): Mission Planner / MAVProxy `.param`
//! (also the data directory's own store) and QGroundControl `.params`.
//!
//! Input: byte 0 picks the format, the rest is the file. Properties: the
//! entries written back in either format read back the same; importing them
//! into the SITL table as `furrow params import` does, exporting the table
//! and importing that into a fresh table gives the same values.
#![no_main]

use std::sync::OnceLock;

use autopilot::sitl::simulation::{ModelKind, SimulationParams};
use libfuzzer_sys::fuzz_target;
use params::ParamTable;
use params::files::{FileEntry, FileFormat, format_mission_planner, format_qgroundcontrol, parse};

/// The SITL table, built once (building it registers every parameter).
fn defaults() -> &'static ParamTable {
    static TABLE: OnceLock<ParamTable> = OnceLock::new();
    TABLE.get_or_init(|| SimulationParams::new(ModelKind::Ackermann).table)
}

fn names_values(entries: &[FileEntry]) -> Vec<(String, u64)> {
    entries.iter().map(|e| (e.name.clone(), e.value.to_bits())).collect()
}

/// Sets every entry the table accepts (unknown, read-only and refused ones
/// are skipped, as an import reports them).
fn import(table: &mut ParamTable, entries: &[FileEntry]) {
    for e in entries {
        if let Some(index) = table.index_of(&e.name)
            && let Ok(now) = table.set(index, e.value)
        {
            assert!(now.is_finite(), "{} = {} stored as {now}", e.name, e.value);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&selector, bytes)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let format = if selector & 1 == 0 {
        FileFormat::MissionPlanner
    } else {
        FileFormat::QGroundControl
    };
    let Ok(entries) = parse(text, format) else {
        return;
    };

    let mp: String = entries.iter().map(|e| format!("{},{}\n", e.name, e.value)).collect();
    let qgc: String = entries
        .iter()
        .map(|e| format!("1\t1\t{}\t{}\t9\n", e.name, e.value))
        .collect();
    for (written, format) in [(mp, FileFormat::MissionPlanner), (qgc, FileFormat::QGroundControl)] {
        let again = parse(&written, format);
        assert_eq!(
            again.as_ref().map(|e| names_values(e)),
            Ok(names_values(&entries)),
            "entries written back as {format:?} read differently:\n{written}"
        );
    }

    let mut table = defaults().clone();
    import(&mut table, &entries);
    for exported in [
        format_mission_planner(table.iter(), "fuzz"),
        format_qgroundcontrol(table.iter(), 1, 1, "fuzz"),
    ] {
        let format = if exported.contains('\t') {
            FileFormat::QGroundControl
        } else {
            FileFormat::MissionPlanner
        };
        let reread = parse(&exported, format).expect("an exported file parses");
        let mut fresh = defaults().clone();
        import(&mut fresh, &reread);
        for ((def, want), (_, got)) in table.iter().zip(fresh.iter()) {
            if def.flags.read_only {
                continue;
            }
            assert_eq!(
                want.to_bits(),
                got.to_bits(),
                "{} exported as {want} imports as {got}",
                def.name
            );
        }
    }
});
