//! `furrow-bench`: Furrow's benchmarks, a binary of their own so that the
//! shipping `furrow` carries no benchmark or plotting code. The benchmarks
//! that run SITL as a process start the `furrow` binary built beside this one.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "furrow-bench",
    version,
    about = "Measure Furrow (prints figures; not a test)"
)]
struct Cli {
    #[command(subcommand)]
    which: BenchCommand,
}

#[derive(Subcommand)]
enum BenchCommand {
    /// SITL speed with --speedup max, core tick timing and memory.
    Sitl(furrow_bench::sitl::SitlBenchArgs),
    /// Path-tracking and stop accuracy on the reference courses, seeds 1..20, with SVG plots.
    Tracking(furrow_bench::tracking::TrackingBenchArgs),
    /// Obstacle scenarios (crossing people, head-on, parked car, box, reversing, corridor) at 1 and 2 m/s.
    Obstacles(furrow_bench::obstacles::ObstacleBenchArgs),
    /// Safety: injected faults and the failsafe that answers, SIGKILL during saves, a MAVLink flood while driving.
    Safety(furrow_bench::safety::SafetyBenchArgs),
    /// MAGNETIC mode's guide back on the tape: three starts, straight and arcs, 0.5–1.5 m/s, two vehicles.
    Magnetic(furrow_bench::magnetic::MagneticBenchArgs),
    /// A simulated fleet (`furrow sitl --fleet N`) against a real Mosquitto: VDA 5050 latency, state rates, CPU and RSS per vehicle, scaling.
    Fleet(furrow_bench::fleet::FleetBenchArgs),
    /// An onboard log (DataFlash .BIN) drawn as an SVG: the course and its cross-track.
    Logs(furrow_bench::log_plot::LogsArgs),
}

fn main() -> ExitCode {
    autopilot::stderr_log::init();
    let result = match Cli::parse().which {
        BenchCommand::Sitl(args) => furrow_bench::sitl::run(&args),
        BenchCommand::Tracking(args) => furrow_bench::tracking::run(&args),
        BenchCommand::Obstacles(args) => furrow_bench::obstacles::run(&args),
        BenchCommand::Safety(args) => furrow_bench::safety::run(&args),
        BenchCommand::Magnetic(args) => furrow_bench::magnetic::run_bench(&args),
        BenchCommand::Fleet(args) => furrow_bench::fleet::run(&args),
        BenchCommand::Logs(args) => furrow_bench::log_plot::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("furrow-bench: {e}");
            ExitCode::FAILURE
        }
    }
}
