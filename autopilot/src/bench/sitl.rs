//! `furrow bench sitl`: how fast the simulation runs with nothing pacing it,
//! how long a core tick takes, and how much memory the process holds.

use std::time::Instant;

use crate::sitl::runner::InstantTimer;
use crate::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};

#[derive(clap::Args, Debug)]
pub struct SitlBenchArgs {
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 600.0)]
    pub seconds: f64,
}

pub fn run(args: &SitlBenchArgs) -> Result<(), String> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        return Err(format!(
            "--seconds {}: must be a positive number",
            args.seconds
        ));
    }
    let config = SimulationConfig {
        model: ModelKind::Ackermann,
        ..SimulationConfig::default()
    };
    let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
    let mut timer = InstantTimer::default();
    let start = Instant::now();
    while sim.time().as_secs_f64() < args.seconds {
        let wall = start.elapsed();
        sim.step(wall, &mut timer).mavlink.clear();
    }
    let wall = start.elapsed().as_secs_f64();
    let ticks = sim.core().scheduler().tick_stats();
    println!(
        "simulated {:.0} s in {:.3} s wall: {:.0}x real time",
        sim.time().as_secs_f64(),
        wall,
        sim.time().as_secs_f64() / wall
    );
    println!(
        "core tick: {} ticks, median {} us, p99 {} us, max {} us",
        ticks.runs,
        ticks.histogram.quantile_us(0.5),
        ticks.histogram.quantile_us(0.99),
        ticks.histogram.max_us()
    );
    Ok(())
}
