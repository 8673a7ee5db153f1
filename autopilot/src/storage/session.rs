//! The parameter table of one run: the profile's defaults, then the values
//! stored in the data directory, then this run's command-line overrides
//! (such as `--speedup`), which are not saved: the stored value stays in the
//! file unless a ground station changes the parameter during the run.

use std::path::Path;

use mavlink::dialects::ardupilotmega::MavSeverity;
use params::ParamTable;
use params::store::{self, Snapshot};

/// A command-line value in force for this run only.
#[derive(Clone, Copy, Debug)]
struct Override {
    index: u16,
    value: f64,
    /// What the data directory held (or the default).
    stored: f64,
}

/// Loads and tracks a run's parameters.
#[derive(Debug, Default)]
pub struct SessionParams {
    overrides: Vec<Override>,
    /// Things to tell the operator (corrupt file, skipped entries).
    pub notices: Vec<(MavSeverity, String)>,
}

impl SessionParams {
    /// Loads the stored values into `table` and counts a boot.
    pub fn load(dir: &Path, table: &mut ParamTable) -> Result<SessionParams, String> {
        let report = store::load(dir, table).map_err(|e| format!("loading parameters from {}: {e}", dir.display()))?;
        let mut session = SessionParams::default();
        if let Some((moved, why)) = &report.corrupt {
            let text = format!(
                "Parameter file unreadable ({why}): moved to {}; defaults loaded",
                moved.display()
            );
            tracing::error!("{text}");
            session.notices.push((MavSeverity::MAV_SEVERITY_CRITICAL, text));
        }
        for warning in &report.warnings {
            tracing::warn!("{warning}");
            session
                .notices
                .push((MavSeverity::MAV_SEVERITY_WARNING, warning.clone()));
        }
        if report.applied > 0 {
            tracing::info!("{} stored parameters loaded from {}", report.applied, dir.display());
        }
        if let Some(index) = table.index_of("STAT_BOOTCNT") {
            let _ = table.set_internal(index, table.value(index) + 1.0);
        }
        Ok(session)
    }

    /// Applies a command-line value for this run only.
    pub fn set_override(&mut self, table: &mut ParamTable, name: &str, value: f64) -> Result<(), String> {
        let index = table
            .index_of(name)
            .ok_or_else(|| format!("unknown parameter {name}"))?;
        let stored = table.value(index);
        let value = table.set(index, value).map_err(|e| format!("{name} = {value}: {e}"))?;
        self.overrides.push(Override { index, value, stored });
        Ok(())
    }

    /// What to write to the data directory now: the table, except that a
    /// parameter still holding its override keeps its stored value.
    pub fn snapshot(&self, table: &ParamTable) -> Snapshot {
        self.snapshot_with(table, &[])
    }

    /// [`SessionParams::snapshot`] of the table with `changes` (`(index,
    /// value)`, in order) applied: changes not yet in force.
    pub fn snapshot_with(&self, table: &ParamTable, changes: &[(u16, f64)]) -> Snapshot {
        Snapshot::of_adjusted(table, |index, value| {
            if let Some(&(_, changed)) = changes.iter().rev().find(|(i, _)| *i == index) {
                return changed;
            }
            match self.overrides.iter().find(|o| o.index == index) {
                Some(o) if o.value == value => o.stored,
                _ => value,
            }
        })
    }
}
