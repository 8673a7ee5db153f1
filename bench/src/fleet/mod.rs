//! `furrow-bench fleet`: a simulated fleet against a real Mosquitto
//! (started by the benchmark on a Unix socket, behind a TCP port the
//! benchmark binds on port 0), as a master control sees it.
//!
//! 1. Latency, one vehicle at speedup 1: order sent → the state that
//!    carries it, → the first state with `driving`; a node reached → its
//!    state at the master (the state's timestamp, stamped as it leaves the
//!    vehicle, against the wall clock at arrival).
//! 2. Fleets of N (default 1, 10, 50, 100) at speedup 1, every vehicle
//!    driving an order: each vehicle's state rate and longest gap, CPU and
//!    RSS per vehicle, messages per second through the broker, vehicles per
//!    core. CPU is counted per simulated second: a fleet the machine cannot
//!    keep in real time falls behind (and the benchmark says so).
//! 3. The same fleets at `--speedup max`, at rest (no order): simulated
//!    seconds per CPU second, i.e. vehicles per core in real time. A
//!    vehicle at rest costs less than one driving (perf: the obstacle
//!    sweep along the path ahead alone is an eighth of a driving fleet of
//!    50's CPU), so this is not the speedup-1 run's work done faster.
//!
//! Everything received is checked against the official schemas.

mod broker;
pub(crate) mod process;
mod start;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use broker::{Master, Mosquitto, Received};
use process::FleetProcess;

#[derive(clap::Args, Debug)]
pub struct FleetBenchArgs {
    /// Fleet sizes to run (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1,10,50,100")]
    pub sizes: Vec<usize>,
    /// Wall seconds each fleet is watched at speedup 1, once driving.
    #[arg(long, default_value_t = 20.0)]
    pub seconds: f64,
    /// Wall seconds each fleet runs at `--speedup max`.
    #[arg(long, default_value_t = 5.0)]
    pub max_seconds: f64,
    /// Orders driven one after another for the latency figures.
    #[arg(long, default_value_t = 3)]
    pub orders: usize,
    /// Skip the latency run.
    #[arg(long)]
    pub no_latency: bool,
    /// Skip the `--speedup max` runs.
    #[arg(long)]
    pub no_max: bool,
    /// Keep the scratch directory (the fleets' logs and data) and say where.
    #[arg(long)]
    pub keep: bool,
}

const MAP: &str = "bench";
/// The simulated car's drive lag (s): the lead the latency run also times.
const LEAD_S: f64 = 0.3;
/// Every node's `allowedDeviationXY` (m).
const ALLOWED_DEVIATION_M: f64 = 0.3;
/// Ports 15760… and 24550… (instance 1000 on): clear of a ground station's.
const INSTANCE: &str = "1000";

pub fn run(args: &FleetBenchArgs) -> Result<(), String> {
    if !(args.seconds >= 3.0 && args.seconds <= 3600.0 && args.max_seconds > 0.0 && args.max_seconds <= 3600.0) {
        return Err("--seconds from 3 to 3600, --max-seconds up to 3600".into());
    }
    if let Some(n) = args.sizes.iter().find(|&&n| !(1..=250).contains(&n)) {
        return Err(format!("--sizes: {n} is not a fleet size from 1 to 250"));
    }
    let exe = crate::furrow_exe()?;
    let mut scratch = crate::scratch_dir("furrow-bench-fleet-")?;
    if args.keep {
        scratch.disable_cleanup(true);
        println!("scratch directory kept: {}", scratch.path().display());
    }
    let mosquitto = Mosquitto::start(scratch.path())?;
    let mut master = Master::connect(mosquitto.port, "bench-master")?;
    println!(
        "furrow-bench fleet: Mosquitto behind 127.0.0.1:{} (a port from the OS), load average {}",
        mosquitto.port,
        load_average()
    );
    let bench = Bench {
        exe: &exe,
        dir: scratch.path(),
        broker_port: mosquitto.port,
        broker_pid: mosquitto.pid(),
    };
    if !args.no_latency {
        bench.latency(&mut master, args.orders)?;
    }
    let mut curve = Vec::new();
    for &n in &args.sizes {
        let real_time = bench.real_time(&mut master, n, args.seconds)?;
        let max = if args.no_max {
            None
        } else {
            Some(bench.max_speed(&mut master, n, args.max_seconds)?)
        };
        curve.push((n, real_time, max));
    }
    print_curve(&curve);
    let schemas = master.schemas();
    println!(
        "schema check: {} messages ({}), {} violations",
        schemas.checked.values().sum::<u64>(),
        schemas
            .checked
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", "),
        schemas.violations
    );
    for example in &schemas.examples {
        println!("  {example}");
    }
    Ok(())
}

struct Bench<'a> {
    exe: &'a Path,
    dir: &'a Path,
    broker_port: u16,
    broker_pid: u32,
}

/// A fleet at speedup 1 as measured.
struct RealTime {
    cpu_per_vehicle: f64,
    rss_per_vehicle_mb: f64,
}

impl Bench<'_> {
    fn start(&self, master: &mut Master, n: usize, speedup: &str, tag: &str) -> Result<FleetProcess, String> {
        let data = self.dir.join(format!("data-{tag}-{n}"));
        let args: Vec<String> = [
            "--speedup",
            speedup,
            "--instance",
            INSTANCE,
            "--tcp-port",
            "0",
            "--vda5050",
            &format!("mqtt://127.0.0.1:{}", self.broker_port),
            "--map-id",
            MAP,
            "--data-dir",
            &data.to_string_lossy(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        // What an earlier fleet sent last (its OFFLINE, its last states)
        // must not pass for this one's.
        drain(master, Duration::from_millis(500));
        FleetProcess::start(self.exe, n, &args, self.dir)
    }

    /// One vehicle at speedup 1: orders of three nodes 6 m apart, one after
    /// another.
    fn latency(&self, master: &mut Master, orders: usize) -> Result<(), String> {
        let fleet = self.start(master, 1, "1", "latency")?;
        let serial = "furrow-0";
        let mut position = wait_localised(master, &[serial.to_owned()], Duration::from_secs(60))?[serial];
        let (mut accepted_ms, mut moving_ms, mut node_ms) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..orders {
            let order_id = format!("latency-{k}");
            let nodes = [(0.0, "a"), (6.0, "b"), (12.0, "c")].map(|(dy, id)| (id, position.0, position.1 + dy));
            master.publish(serial, "order", &order(serial, &order_id, &nodes))?;
            let sent = Instant::now();
            let (mut accepted, mut moving, mut last_node) = (None, None, String::from("?"));
            let deadline = sent + Duration::from_secs(60);
            while Instant::now() < deadline {
                let Some(m) = master.next(Duration::from_millis(200)) else {
                    continue;
                };
                if m.kind == "state"
                    && m.body["orderId"] != order_id.as_str()
                    && !m.body["errors"].as_array().is_none_or(Vec::is_empty)
                {
                    println!("  order {order_id}: {}", m.body["errors"]);
                }
                if m.kind != "state" || m.body["orderId"] != order_id.as_str() {
                    continue;
                }
                let since_ms = (m.at - sent).as_secs_f64() * 1e3;
                accepted.get_or_insert(since_ms);
                if m.body["driving"] == true {
                    moving.get_or_insert(since_ms);
                }
                let node = m.body["lastNodeId"].as_str().unwrap_or("").to_owned();
                if node != last_node && node != "a" {
                    node_ms.push(transit_ms(&m));
                }
                last_node = node;
                if last_node == "c" && m.body["nodeStates"].as_array().is_some_and(Vec::is_empty) {
                    position = state_position(&m.body).unwrap_or(position);
                    break;
                }
            }
            if accepted.is_none() {
                println!("  order {order_id}: no state carried it within 60 s");
            }
            accepted_ms.extend(accepted);
            moving_ms.extend(moving);
        }
        fleet.stop()?;
        println!(
            "latency, one vehicle at speedup 1, {orders} orders of 3 nodes (wall ms: median / max; load average {}):",
            load_average()
        );
        println!("  order sent -> state with the order   {}", median_max(&accepted_ms));
        println!(
            "  order sent -> state with driving     {} (armed, AUTO, the drive commanded)",
            median_max(&moving_ms)
        );
        println!(
            "  node reached: state leaves the vehicle -> at the master {} ({} nodes; ms timestamps)",
            median_max(&node_ms),
            node_ms.len()
        );
        let orders = orders.max(3);
        let measured = start::measure(orders, &[])?;
        print_starts(&measured.starts, &moving_ms, "");
        let lead = [("ATC_DRV_LAG".to_owned(), LEAD_S)];
        let with_lead = start::measure(orders, &lead)?;
        print_starts(
            &with_lead.starts,
            &moving_ms,
            &format!(" with ATC_DRV_LAG={LEAD_S} (the throttle leads the ramp by the drive's lag)"),
        );
        print_nodes(&measured.nodes);
        print_stop_approach(&measured.stop_approaches, &measured.coverage);
        print_standing(&measured.standing);
        Ok(())
    }

    /// A fleet of `n` at speedup 1, every vehicle driving a 300 m order.
    fn real_time(&self, master: &mut Master, n: usize, seconds: f64) -> Result<RealTime, String> {
        let fleet = self.start(master, n, "1", "real")?;
        let serials: Vec<String> = (0..n).map(|i| format!("furrow-{i}")).collect();
        let positions = wait_localised(master, &serials, Duration::from_secs_f64(60.0 + n as f64))?;
        for serial in &serials {
            let (x, y) = positions[serial.as_str()];
            let nodes = [("a", x, y), ("b", x, y + 300.0)];
            master.publish(serial, "order", &order(serial, "far", &nodes))?;
        }
        let mut last: BTreeMap<String, Value> = BTreeMap::new();
        let settle = Instant::now() + Duration::from_secs(3);
        while let Some(m) = master.next(settle.saturating_duration_since(Instant::now())) {
            if m.kind == "state" {
                last.insert(m.serial, m.body);
            }
        }
        let (cpu0, broker0, start) = (fleet.cpu_s(), process::cpu_s(self.broker_pid), Instant::now());
        let end = start + Duration::from_secs_f64(seconds);
        let mut times: BTreeMap<String, Vec<Instant>> = BTreeMap::new();
        let (mut messages, mut driving) = (0u64, 0u64);
        while let Some(m) = master.next(end.saturating_duration_since(Instant::now())) {
            messages += 1;
            if m.kind == "state" {
                driving += u64::from(m.body["driving"] == true);
                times.entry(m.serial.clone()).or_default().push(m.at);
                last.insert(m.serial, m.body);
            }
        }
        let wall_s = start.elapsed().as_secs_f64();
        let cpu_s = fleet.cpu_s() - cpu0;
        let broker_cpu_s = process::cpu_s(self.broker_pid) - broker0;
        let (rss_kb, threads) = (fleet.rss_kb(), fleet.threads());
        let (simulated_s, run_wall_s) = fleet.stop()?;
        // On a loaded machine a fleet that does not get the CPU it needs
        // falls behind and skips ticks (pacing restarts): its CPU per wall
        // second then understates the cost. Per simulated second it does not.
        let kept = (simulated_s / run_wall_s.max(1e-9)).min(1.0);
        let rates = state_rates(&serials, &times, start, start + Duration::from_secs_f64(wall_s));
        let states: u64 = times.values().map(|t| t.len() as u64).sum();
        print_not_driving(&serials, &last);
        println!(
            "fleet of {n} at speedup 1, driving, {wall_s:.0} s (load average {} at the end):",
            load_average()
        );
        println!(
            "  state per vehicle: lowest {:.2} Hz, longest gap {:.2} s; {} of {n} below 1 Hz or with a gap over 2 s; {:.0} % of states driving",
            rates.lowest_hz,
            rates.longest_gap_s,
            rates.failing,
            100.0 * driving as f64 / states.max(1) as f64
        );
        println!(
            "  kept real time: {simulated_s:.1} s simulated in {run_wall_s:.1} s ({:.0} %){}",
            100.0 * kept,
            if kept < 0.98 {
                "; the machine did not give the fleet the CPU it needed: CPU below is per simulated second"
            } else {
                ""
            }
        );
        let cpu_per_vehicle = cpu_s / (wall_s * kept) / n as f64;
        println!(
            "  CPU {:.1} % of a core per vehicle ({:.2} cores in all); RSS {:.1} MB in all, {:.2} MB per vehicle; {threads} threads",
            100.0 * cpu_per_vehicle,
            cpu_per_vehicle * n as f64,
            rss_kb as f64 / 1024.0,
            rss_kb as f64 / 1024.0 / n as f64
        );
        println!(
            "  broker: {:.0} messages/s from the fleet, Mosquitto at {:.1} % of a core",
            messages as f64 / wall_s,
            100.0 * broker_cpu_s / wall_s
        );
        Ok(RealTime {
            cpu_per_vehicle,
            rss_per_vehicle_mb: rss_kb as f64 / 1024.0 / n as f64,
        })
    }

    /// A fleet of `n` at `--speedup max` (at rest): simulated per CPU time.
    fn max_speed(&self, master: &mut Master, n: usize, seconds: f64) -> Result<f64, String> {
        let fleet = self.start(master, n, "max", "max")?;
        let cpu0 = fleet.cpu_s();
        drain(master, Duration::from_secs_f64(seconds));
        let cpu_s = fleet.cpu_s() - cpu0;
        let (simulated_s, wall_s) = fleet.stop()?;
        let vehicles_per_core = n as f64 * simulated_s / cpu_s.max(1e-3);
        println!(
            "fleet of {n} at --speedup max, at rest (no order): {:.0}x real time each over {wall_s:.1} s, {:.2} cores: {vehicles_per_core:.0} vehicles per core in real time",
            simulated_s / wall_s,
            cpu_s / seconds
        );
        Ok(vehicles_per_core)
    }
}

/// The in-process starts, and what they add to the end-to-end `driving`.
fn print_starts(starts: &[start::Start], driving_ms: &[f64], label: &str) {
    let column = |f: fn(&start::Start) -> f64| starts.iter().map(f).collect::<Vec<f64>>();
    println!(
        "order's tick -> truly moving, in-process{label} ({} starts from rest, simulated ms = wall ms at speedup 1; median / max):",
        starts.len()
    );
    println!(
        "  -> drive commanded (driving)              {}",
        median_max(&column(|s| s.commanded_ms))
    );
    println!(
        "  -> state with driving leaves the core     {}",
        median_max(&column(|s| s.state_driving_ms))
    );
    let floor = column(|s| s.rest_floor_mps).into_iter().fold(0.0, f64::max);
    println!(
        "  -> moving (true speed above its rest floor, at most {floor:.1e} m/s) {}",
        median_max(&column(|s| s.moving_ms))
    );
    println!(
        "  -> true speed past driving's 3 cm/s       {}",
        median_max(&column(|s| s.driving_speed_ms))
    );
    let Some(e2e) = median(driving_ms) else {
        return;
    };
    for (what, mark) in [
        ("moving", column(|s| s.moving_ms - s.commanded_ms)),
        ("past 3 cm/s", column(|s| s.driving_speed_ms - s.commanded_ms)),
    ] {
        if let Some(rest) = median(&mark) {
            println!(
                "  order sent -> {what}, end to end ~ {:.1} ms (the state with driving, {e2e:.1}, plus commanded -> {what}, {rest:.1})",
                e2e + rest
            );
        }
    }
}

/// Node reached -> its `state`, in-process, pass-through and stop nodes
/// apart (a node is reached once the vehicle is within its allowed
/// deviation; the stop, which gives a theta, with its heading within the
/// allowed deviation too).
fn print_nodes(nodes: &[start::NodeReach]) {
    for stops in [false, true] {
        let of =
            |f: fn(&start::NodeReach) -> f64| nodes.iter().filter(|n| n.stops == stops).map(f).collect::<Vec<f64>>();
        let count = nodes.iter().filter(|n| n.stops == stops).count();
        let false_claims = nodes.iter().filter(|n| n.stops == stops && n.false_claim).count();
        println!(
            "node reached -> state with it leaves the core, in-process, {count} {} nodes (simulated ms; median / max):",
            if stops { "stop" } else { "pass-through" }
        );
        // NaN: the state left before the navigator finished the leg.
        let after_decision: Vec<f64> = of(|n| n.from_decision_ms)
            .into_iter()
            .filter(|v| v.is_finite())
            .collect();
        println!(
            "  from the navigator's finished leg         {} ({} of {count} states left before it)",
            median_max(&after_decision),
            count - after_decision.len()
        );
        println!(
            "  from the truth {}   {}",
            if stops {
                "within the deviation, heading too"
            } else {
                "within the deviation             "
            },
            median_max(&of(|n| n.from_truth_ms))
        );
        println!(
            "  truth's distance from the node then (cm)  {}",
            median_max(&of(|n| 100.0 * n.distance_at_state_m))
        );
        println!(
            "  false claims (the truth not {} the node when its state left): {false_claims} of {count}",
            if stops {
                "within the deviation (position and heading) of"
            } else {
                "within the deviation of"
            }
        );
    }
}

/// Where a stop node's time goes, and whether the bounds it waits for are
/// true 95 % bounds.
fn print_stop_approach(approaches: &[start::StopApproach], coverage: &start::Coverage) {
    let of = |f: fn(&start::StopApproach) -> f64| approaches.iter().map(f).collect::<Vec<f64>>();
    println!(
        "the stop node at the truth's first tick within its deviation, {} stops (median / max):",
        approaches.len()
    );
    println!(
        "  true speed (cm/s)                          {}",
        median_max(&of(|a| 100.0 * a.speed_at_truth_mps))
    );
    println!(
        "  estimate's 95 % radius (1.731 sigma, cm)   {}",
        median_max(&of(|a| 100.0 * a.bound_at_truth_m))
    );
    println!(
        "  estimate's true error (cm)                 {}",
        median_max(&of(|a| 100.0 * a.error_at_truth_m))
    );
    println!(
        "  heading's bound (1.96 sigma, mrad)         {}",
        median_max(&of(|a| 1e3 * a.yaw_bound_at_truth_rad))
    );
    println!(
        "  -> estimate + radius within (ms)           {}",
        median_max(&of(|a| a.position_test_ms))
    );
    println!(
        "  -> estimate's heading + bound within (ms)  {}",
        median_max(&of(|a| a.heading_test_ms))
    );
    println!(
        "  of which behind the truth, toward the stop (cm)  {}",
        median_max(&of(|a| 100.0 * a.behind_at_truth_m))
    );
    let ticks = coverage.ticks.max(1) as f64;
    let bound_m = median(&of(|a| a.bound_at_truth_m)).unwrap_or(f64::NAN);
    let speed_mps = median(&of(|a| a.speed_at_truth_mps)).unwrap_or(f64::NAN);
    let mut ratios = coverage.error_over_bound.clone();
    ratios.sort_by(f64::total_cmp);
    let p95 = ratios.get(ratios.len() * 95 / 100).copied().unwrap_or(f64::NAN);
    println!(
        "  while moving ({} ticks of {} orders): truth within the 95 % radius {:.1} % of ticks (a calibrated bound: 95 %; true error's 95th percentile {:.2} of the radius), heading within its 1.96 sigma {:.1} %",
        coverage.ticks,
        approaches.len(),
        100.0 * coverage.position_held as f64 / ticks,
        p95,
        100.0 * coverage.heading_held as f64 / ticks
    );
    println!(
        "  (the estimate must come within the deviation less its radius: at the true speed v the truth first crosses at, that is about radius / v after it, {:.0} ms at the medians, plus the estimate's lag behind the truth / v; <= 50 ms would need v >= radius / 50 ms = {:.2} m/s here)",
        bound_m / speed_mps * 1e3,
        bound_m / 0.05
    );
}

/// The stop at each order's end: the truth at rest -> `driving: false`.
fn print_standing(standing: &[start::Standing]) {
    let from_rest: Vec<f64> = standing.iter().map(|s| s.from_rest_ms).collect();
    let false_claims: usize = standing.iter().map(|s| s.false_claims).sum();
    println!(
        "truth at rest (< 1 cm/s) within the stop's deviation -> state with driving: false leaves the core, in-process, {} stops (simulated ms; median / max):",
        standing.len()
    );
    println!(
        "  {} (rest is known from the receiver's speed, 10 Hz, or 1 s of a quiet estimate)",
        median_max(&from_rest)
    );
    println!("  states saying driving: false while the truth moved >= 1 cm/s: {false_claims}");
    let column = |f: fn(&start::Standing) -> f64| standing.iter().map(f).collect::<Vec<f64>>();
    println!(
        "order's tick -> that state (the order end to end, 12 m, simulated ms; median / max): {}",
        median_max(&column(|s| s.order_ms))
    );
    println!(
        "  truth at rest: from the stop (cm) {}, heading off its theta (mrad) {}, fastest backwards (cm/s) {}",
        median_max(&column(|s| 100.0 * s.rest_off_m)),
        median_max(&column(|s| 1e3 * s.rest_yaw_rad)),
        median_max(&column(|s| 100.0 * s.backwards_mps))
    );
}

fn median(values: &[f64]) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied()
}

/// Each vehicle's state rate over the window and its longest silence
/// (counting from the window's start and to its end).
struct Rates {
    lowest_hz: f64,
    longest_gap_s: f64,
    failing: usize,
}

fn state_rates(serials: &[String], times: &BTreeMap<String, Vec<Instant>>, start: Instant, end: Instant) -> Rates {
    let window_s = (end - start).as_secs_f64();
    let mut rates = Rates {
        lowest_hz: f64::INFINITY,
        longest_gap_s: 0.0,
        failing: 0,
    };
    for serial in serials {
        let seen = times.get(serial).map_or(&[][..], Vec::as_slice);
        let edges = std::iter::once(start)
            .chain(seen.iter().copied())
            .chain(std::iter::once(end));
        let stamps: Vec<Instant> = edges.collect();
        let gap_s = stamps
            .windows(2)
            .map(|w| (w[1] - w[0]).as_secs_f64())
            .fold(0.0, f64::max);
        let hz = seen.len() as f64 / window_s;
        rates.lowest_hz = rates.lowest_hz.min(hz);
        rates.longest_gap_s = rates.longest_gap_s.max(gap_s);
        // A state at 1 Hz or more gives at least one per whole second of
        // the window, wherever the window falls.
        let below_1_hz = (seen.len() as f64) < window_s.floor();
        rates.failing += usize::from(below_1_hz || gap_s > 2.0);
    }
    rates
}

fn print_curve(curve: &[(usize, RealTime, Option<f64>)]) {
    println!(
        "scaling (vehicles per core: at speedup 1, driving, from CPU per vehicle per simulated second; at max, at rest, from simulated per CPU second):"
    );
    println!(
        "  {:>5} {:>16} {:>16} {:>14} {:>16}",
        "N", "CPU %/vehicle", "vehicles/core@1", "MB/vehicle", "vehicles/core@max"
    );
    for (n, real, max) in curve {
        println!(
            "  {n:>5} {:>16.2} {:>16.0} {:>14.2} {:>16}",
            100.0 * real.cpu_per_vehicle,
            1.0 / real.cpu_per_vehicle.max(1e-9),
            real.rss_per_vehicle_mb,
            max.map_or("-".to_owned(), |v| format!("{v:.0}"))
        );
    }
}

/// Waits until every vehicle's state says it is localised, asking each
/// one not yet for a state once a second (`stateRequest`: at rest a state
/// is due only every 30 s); their map positions (x, y) then.
fn wait_localised<'a>(
    master: &mut Master,
    serials: &'a [String],
    timeout: Duration,
) -> Result<BTreeMap<&'a str, (f64, f64)>, String> {
    let mut positions = BTreeMap::new();
    let deadline = Instant::now() + timeout;
    let mut next_ask = Instant::now();
    while positions.len() < serials.len() {
        if Instant::now() >= next_ask {
            next_ask += Duration::from_secs(1);
            for serial in serials.iter().filter(|s| !positions.contains_key(s.as_str())) {
                master.publish(serial, "instantActions", &state_request(serial))?;
            }
        }
        if Instant::now() > deadline {
            return Err(format!(
                "{} of {} vehicles localised within {timeout:?}",
                positions.len(),
                serials.len()
            ));
        }
        let Some(m) = master.next(Duration::from_millis(100)) else {
            continue;
        };
        let localised = m.body["agvPosition"]["positionInitialized"] == true;
        if let (true, Some(serial), Some(at)) = (
            localised,
            serials.iter().find(|s| **s == m.serial),
            state_position(&m.body),
        ) {
            positions.insert(serial.as_str(), at);
        }
    }
    Ok(positions)
}

fn state_request(serial: &str) -> Value {
    json!({
        "headerId": 1, "timestamp": "2026-11-27T08:00:00.00Z", "version": "2.1.0",
        "manufacturer": "Furrow", "serialNumber": serial,
        "actions": [{"actionId": format!("ask-{}", broker::unix_ms()), "actionType": "stateRequest", "blockingType": "NONE"}],
    })
}

fn state_position(state: &Value) -> Option<(f64, f64)> {
    let p = &state["agvPosition"];
    Some((p["x"].as_f64()?, p["y"].as_f64()?))
}

fn drain(master: &mut Master, wall: Duration) {
    let end = Instant::now() + wall;
    while master.next(end.saturating_duration_since(Instant::now())).is_some() {}
}

/// How long a message took from the vehicle's timestamp to the master
/// (both wall clocks of this machine; the timestamp has ms resolution).
fn transit_ms(m: &Received) -> f64 {
    let stamp = m.body["header"]["timestamp"]
        .as_str()
        .or_else(|| m.body["timestamp"].as_str())
        .unwrap_or("");
    match ms_of_day(stamp) {
        Some(sent) => {
            let received = (m.unix_ms % 86_400_000) as i64;
            ((received - sent).rem_euclid(86_400_000)) as f64
        }
        None => f64::NAN,
    }
}

/// Milliseconds since midnight of an ISO 8601 UTC `…THH:MM:SS.sssZ`.
fn ms_of_day(stamp: &str) -> Option<i64> {
    let time = stamp.split('T').nth(1)?.trim_end_matches('Z');
    let mut parts = time.split(':');
    let h: i64 = parts.next()?.parse().ok()?;
    let m: i64 = parts.next()?.parse().ok()?;
    let s: f64 = parts.next()?.parse().ok()?;
    Some((h * 3600 + m * 60) * 1000 + (s * 1000.0).round() as i64)
}

fn median_max(values: &[f64]) -> String {
    if values.is_empty() {
        return "none".into();
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    format!("{:.1} / {:.1}", sorted[sorted.len() / 2], sorted[sorted.len() - 1])
}

/// An order along `nodes` (id, map x, map y), released, 1.5 m/s edges.
fn order(serial: &str, order_id: &str, nodes: &[(&str, f64, f64)]) -> Value {
    let node_list: Vec<Value> = nodes
        .iter()
        .enumerate()
        .map(|(i, (id, x, y))| {
            json!({"nodeId": id, "sequenceId": 2 * i, "released": true, "actions": [],
                   "nodePosition": {"x": x, "y": y, "mapId": MAP, "allowedDeviationXY": ALLOWED_DEVIATION_M}})
        })
        .collect();
    let edge_list: Vec<Value> = nodes
        .windows(2)
        .enumerate()
        .map(|(i, pair)| {
            json!({"edgeId": format!("e{}", 2 * i + 1), "sequenceId": 2 * i + 1, "released": true,
                   "startNodeId": pair[0].0, "endNodeId": pair[1].0, "maxSpeed": 1.5, "actions": []})
        })
        .collect();
    json!({
        "headerId": 1, "timestamp": "2026-11-27T08:00:00.00Z", "version": "2.1.0",
        "manufacturer": "Furrow", "serialNumber": serial,
        "orderId": order_id, "orderUpdateId": 0, "nodes": node_list, "edges": edge_list,
    })
}

/// The 1-minute load average, as /proc/loadavg says it.
pub(crate) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "?".into())
}

/// The first few vehicles not driving at the end of a real-time run, with
/// their last state: a fleet that falls behind shows why.
fn print_not_driving(serials: &[String], last: &BTreeMap<String, Value>) {
    for serial in serials
        .iter()
        .filter(|s| !last.get(*s).is_some_and(|b| b["driving"] == true))
        .take(3)
    {
        let state = last.get(serial).map_or("no state".to_owned(), |b| {
            format!("order {} driving {} errors {}", b["orderId"], b["driving"], b["errors"])
        });
        println!("  not driving at the end: {serial}: {state}");
    }
}
