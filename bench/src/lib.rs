//! Benchmarks printed by `furrow-bench …`: figures, not pass/fail tests.
//! Kept out of the `furrow` binary, and so are rand_chacha and plotters (the
//! SVG plot of the tracking benchmark and of `furrow-bench logs plot`).

pub mod ekf_cost;
pub mod fleet;
pub mod log_plot;
pub mod magnetic;
pub mod magnetic_bound;
pub mod manoeuvre;
pub mod obstacles;
pub mod plot;
pub mod safety;
pub mod sitl;
pub mod tracking;

use std::alloc::System;
use std::path::PathBuf;
use std::time::Duration;

use autopilot::edge::clock::InstantTimer;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::Simulation;
use autopilot::vehicle::Outputs;
use mavlink::dialects::ardupilotmega::MavMessage;
use stats_alloc::{INSTRUMENTED_SYSTEM, StatsAlloc};

/// Counts the benchmarks' allocations (`furrow-bench sitl` reports them per
/// tick): an atomic add beside the system allocator. Only the benchmark
/// binary links this crate.
#[global_allocator]
pub static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// A fresh directory under the system's temp dir for one benchmark's
/// `furrow sitl` runs (data directory, stderr logs), named `prefix…`; it is
/// removed when dropped unless kept with `TempDir::keep`.
pub fn scratch_dir(prefix: &str) -> Result<tempfile::TempDir, String> {
    tempfile::Builder::new()
        .prefix(prefix)
        .tempdir()
        .map_err(|e| format!("scratch directory {prefix}*: {e}"))
}

/// Connects a ground station, steps until `warm_up_s` of simulated time
/// (the first fixes, as an operator would wait), then selects `mode` and
/// arms.
pub fn warm_up_and_arm(sim: &mut Simulation, timer: &mut InstantTimer, warm_up_s: f64, mode: u32) {
    gcs::connect(sim);
    while sim.time().as_secs_f64() < warm_up_s {
        sim.step(Duration::ZERO, timer).mavlink.clear();
    }
    gcs::send(sim, gcs::set_mode(mode));
    gcs::send(sim, gcs::arm());
}

/// The STATUSTEXTs an in-process simulation step sent, as text (the rest
/// of its MAVLink output is dropped).
pub fn status_texts(outputs: &mut Outputs) -> Vec<String> {
    outputs
        .mavlink
        .drain(..)
        .filter_map(|o| match o.message {
            MavMessage::STATUSTEXT(t) => t.text.to_str().ok().map(str::to_string),
            _ => None,
        })
        .collect()
}

/// The `furrow` binary the process benchmarks start: `FURROW_BIN` if set
/// (as the end-to-end tests take it), else the one built beside
/// `furrow-bench` (both land in the same `target/<profile>/`).
pub fn furrow_exe() -> Result<PathBuf, String> {
    if let Some(path) = std::env::var_os("FURROW_BIN") {
        return Ok(PathBuf::from(path));
    }
    let own = std::env::current_exe().map_err(|e| format!("own executable: {e}"))?;
    let beside = own.with_file_name(format!("furrow{}", std::env::consts::EXE_SUFFIX));
    if beside.is_file() {
        Ok(beside)
    } else {
        Err(format!(
            "no furrow binary at {} (build it: cargo build --release -p autopilot --bin furrow, or set FURROW_BIN)",
            beside.display()
        ))
    }
}
