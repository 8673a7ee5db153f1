//! `furrow-bench safety`: each injected fault and the failsafe that must
//! answer it, SIGKILL during mission uploads and parameter saves, and a
//! MAVLink flood while the AGV course runs. One table; a row that misses
//! its expectation is marked FAIL and the command exits non-zero.

pub mod faults;
pub mod flood;
pub mod gcs_client;
pub mod kill;

use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct SafetyBenchArgs {
    /// Parts to run (faults, kill, flood); all when none is given.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// SIGKILL runs of the crash-safety test (half at random instants,
    /// half 0–5 ms after an acknowledgement).
    #[arg(long, default_value_t = 200)]
    pub kill_runs: u32,
    /// Messages per second flooded into the UDP and the TCP link together.
    #[arg(long, default_value_t = 20_000)]
    pub flood_rate: u32,
    /// Seed of the random kill moments and the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The furrow binary the kill and flood tests start (default: this one).
    #[arg(long)]
    pub furrow: Option<PathBuf>,
}

/// One line of the table.
#[derive(Clone, Debug)]
pub struct Row {
    pub part: &'static str,
    pub case: String,
    pub expected: String,
    pub measured: String,
    pub ok: bool,
}

pub fn run(args: &SafetyBenchArgs) -> Result<(), String> {
    let wants = |part: &str| args.only.is_empty() || args.only.iter().any(|p| p == part);
    for part in &args.only {
        if !["faults", "kill", "flood"].contains(&part.as_str()) {
            return Err(format!("--only {part}: expected faults, kill or flood"));
        }
    }
    let exe = match &args.furrow {
        Some(path) => path.clone(),
        None => crate::furrow_exe()?,
    };
    let mut rows = Vec::new();
    if wants("faults") {
        rows.extend(faults::run(args.seed)?);
    }
    if wants("kill") {
        rows.extend(kill::run(&exe, args.kill_runs, args.seed)?);
    }
    if wants("flood") {
        rows.extend(flood::run(&exe, args.flood_rate, args.seed)?);
    }
    print_table(&rows);
    let failed = rows.iter().filter(|r| !r.ok).count();
    if failed > 0 {
        return Err(format!("{failed} of {} rows missed their expectation", rows.len()));
    }
    Ok(())
}

fn print_table(rows: &[Row]) {
    let width = |f: &dyn Fn(&Row) -> usize, title: &str| rows.iter().map(f).max().unwrap_or(0).max(title.len());
    let wp = width(&|r| r.part.len(), "part");
    let wc = width(&|r| r.case.chars().count(), "case");
    let we = width(&|r| r.expected.chars().count(), "expected");
    println!(
        "| {:wp$} | {:wc$} | {:we$} | result | measured |",
        "part", "case", "expected"
    );
    println!(
        "|{}|{}|{}|--------|----------|",
        "-".repeat(wp + 2),
        "-".repeat(wc + 2),
        "-".repeat(we + 2)
    );
    for r in rows {
        println!(
            "| {:wp$} | {:wc$} | {:we$} | {:6} | {} |",
            r.part,
            r.case,
            r.expected,
            if r.ok { "ok" } else { "FAIL" },
            r.measured
        );
    }
}
