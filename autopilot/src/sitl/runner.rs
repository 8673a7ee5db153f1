//! `furrow sitl`: the simulation on its own thread, paced against the wall
//! clock, talking to ground stations through the link layer.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;

use super::simulation::{Simulation, SimulationConfig, SimulationParams};
use crate::link::endpoint::{Endpoint, LinkEndpoint};
use crate::link::hub::{self, LinkConfig, ToCore};
use crate::storage::data_dir::{DataDir, Profile};
use crate::storage::file_writer::FileWriter;
use crate::storage::missions;
use crate::storage::session::SessionParams;
use crate::time::TaskTimer;
use crate::vehicle::{Core, Inputs, Outbound, Outputs, SaveDone, SaveRequest, SaveWhat, Storage};
use mission::MissionType;

/// `--speedup`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Speedup {
    Factor(f64),
    Max,
}

#[derive(Clone, Debug)]
pub struct SitlOptions {
    pub sim: SimulationConfig,
    /// Overrides `SIM_SPEEDUP` at start.
    pub speedup: Option<Speedup>,
    pub instance: u16,
    pub data_dir: PathBuf,
    /// TCP server port (default 5760 + 10·instance; 0 picks a free port).
    pub tcp_port: Option<u16>,
    /// Where the UDP link sends (default 127.0.0.1:14550 + 10·instance).
    pub udp_port: Option<u16>,
    pub mavlink: Vec<Endpoint>,
    /// Extra endpoints that are secure links (SETUP_SIGNING accepted,
    /// unsigned packets always accepted); slots after `mavlink`'s.
    pub secure_mavlink: Vec<Endpoint>,
    pub tlog: Option<PathBuf>,
    /// A magnetic tape through a waypoint file's points, corner radius.
    pub tape: Option<(PathBuf, f64)>,
    /// A world file (obstacles, moving people, tape), reloaded when it
    /// changes.
    pub world: Option<PathBuf>,
}

/// Reads the wall clock for task timing (the edge's clock, injected into
/// the core).
pub struct InstantTimer(Instant);

impl Default for InstantTimer {
    fn default() -> Self {
        InstantTimer(Instant::now())
    }
}

impl TaskTimer for InstantTimer {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

/// Keeps simulated time at `speedup` × wall time. After a stall it
/// re-anchors instead of racing to catch up.
#[derive(Debug, Default)]
pub struct Pacer {
    anchor: Option<(Duration, Duration, Option<f64>)>,
    pub late_restarts: u64,
    /// Ticks that started a whole period (wall time) or more after their
    /// paced time: deadlines missed.
    pub late_ticks: u64,
}

impl Pacer {
    const MAX_LAG: Duration = Duration::from_millis(200);

    /// How long to sleep before the step that ends at simulated time `sim`
    /// (`period`: the simulated loop period).
    pub fn delay(&mut self, sim: Duration, wall: Duration, speedup: Option<f64>, period: Duration) -> Option<Duration> {
        let (wall0, sim0, s0) = *self.anchor.get_or_insert((wall, sim, speedup));
        if s0 != speedup {
            self.anchor = Some((wall, sim, speedup));
            return None;
        }
        let speedup = speedup?;
        let target = wall0 + sim.saturating_sub(sim0).div_f64(speedup);
        if wall >= target + period.div_f64(speedup) {
            self.late_ticks += 1;
        }
        if wall > target + Self::MAX_LAG {
            self.late_restarts += 1;
            self.anchor = Some((wall, sim, Some(speedup)));
            return None;
        }
        target.checked_sub(wall).filter(|d| !d.is_zero())
    }
}

/// Runs until SIGINT/SIGTERM.
pub fn run(options: SitlOptions) -> Result<(), String> {
    let data_dir = DataDir::open(&options.data_dir, Profile::Sitl(options.sim.model))?;
    let mut params = SimulationParams::new(options.sim.model);
    let mut session = SessionParams::load(data_dir.path(), &mut params.table)?;
    if let Some(speedup) = options.speedup {
        let value = match speedup {
            Speedup::Factor(f) => f,
            Speedup::Max => 0.0,
        };
        session
            .set_override(&mut params.table, "SIM_SPEEDUP", value)
            .map_err(|e| format!("--speedup: {e}"))?;
    }
    let mut sim = Simulation::new(&options.sim, params);
    if let Some((path, radius_m)) = &options.tape {
        let tape = super::tape::load(path, sim.world(), *radius_m).map_err(|e| format!("--tape {e}"))?;
        tracing::info!("magnetic tape laid: {:.1} m from {}", tape.length_m(), path.display());
        sim.world_mut().set_tape(Some(tape));
    }
    let mut world_watch = match &options.world {
        Some(path) => {
            let file = drivers::sim::load_world_file(path).map_err(|e| format!("--world {}: {e}", path.display()))?;
            if file.tape().is_some() && options.tape.is_some() {
                return Err(format!(
                    "--world {} lays a tape and so does --tape: give one",
                    path.display()
                ));
            }
            apply_world(&mut sim, &file);
            tracing::info!("world loaded from {}", path.display());
            Some(WorldWatch::new(path.clone()))
        }
        None => None,
    };
    for (severity, text) in session.notices.drain(..) {
        sim.core_mut().add_startup_notice(severity, text);
    }
    let (plans, plan_notices) = missions::load(data_dir.path());
    for mission_type in MissionType::ALL {
        sim.core_mut().load_plan(mission_type, plans.get(mission_type).clone());
    }
    for (severity, text) in plan_notices {
        sim.core_mut().add_startup_notice(severity, text);
    }
    let mut persistence = Persistence::start(&data_dir, sim.core_mut());

    let offset = 10 * options.instance;
    let tcp_port = options.tcp_port.unwrap_or(5760 + offset);
    let udp_port = options.udp_port.unwrap_or(14550 + offset);
    let (links, mut channels) = hub::start(LinkConfig {
        sysid: sim.core().sysid(),
        tcp_server: Some(format!("0.0.0.0:{tcp_port}")),
        udp_out: Some(format!("127.0.0.1:{udp_port}")),
        extra: extra_endpoints(&options.mavlink, &options.secure_mavlink),
        tlog: options.tlog.clone(),
        signing_dir: Some(data_dir.path().to_path_buf()),
        sign_require_mask: sim.core().sign_require_mask(),
    })
    .map_err(|e| format!("MAVLink links: {e}"))?;

    let mut logger = crate::logging::edge::Logger::start(data_dir.path(), channels.outbound.clone());
    let shutdown = shutdown_on_signal();
    let tcp = links.bound.tcp.map_or("none".into(), |a| a.to_string());
    let udp = links.bound.udp_local.map_or("none".into(), |a| a.to_string());
    let secure: String = links.bound.secure.iter().map(|s| format!(", secure {s}")).collect();
    // One line on stdout that scripts and tests parse for the bound ports
    // (new fields go at the end).
    println!(
        "furrow sitl ready: tcp {tcp}, udp {udp} to 127.0.0.1:{udp_port}, sysid {}{secure}",
        sim.core().sysid()
    );
    tracing::info!(
        "SITL: home {:.7},{:.7} heading {:.1}°, model {:?}, seed {}, data {}",
        options.sim.home.lat_deg,
        options.sim.home.lon_deg,
        options.sim.home_heading_deg,
        options.sim.model,
        options.sim.seed,
        options.data_dir.display()
    );

    let start = Instant::now();
    let mut timer = InstantTimer::default();
    let mut pacer = Pacer::default();
    let mut dropped_out = 0u64;
    // Waits for link traffic until the next tick is due (a tokio receiver
    // awaited from this thread with a deadline).
    let waiter = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .map_err(|e| format!("runtime: {e}"))?;
    while !shutdown.load(Ordering::Relaxed) {
        drain(&mut channels.inbound, sim.inputs_mut(), None);
        persistence.collect(sim.inputs_mut());
        let outputs = sim.step(start.elapsed(), &mut timer);
        let saves = std::mem::take(&mut outputs.saves);
        forward(outputs, &channels.outbound, &mut dropped_out);
        logger.send(&mut outputs.log);
        persistence.save(saves, sim.core(), &session);
        links.set_sign_require_mask(sim.core().sign_require_mask());
        if let Some(watch) = &mut world_watch {
            watch.poll(start.elapsed(), &mut sim);
        }
        // Until the next tick: answer link traffic as it comes.
        let next_sim = sim.time() + sim.core().loop_period();
        if let Some(delay) = pacer.delay(next_sim, start.elapsed(), sim.speedup(), sim.core().loop_period()) {
            let deadline = tokio::time::Instant::now() + delay;
            while let Some(first) = persistence.wait(&waiter, deadline, &mut channels.inbound, sim.inputs_mut()) {
                drain(&mut channels.inbound, sim.inputs_mut(), first);
                let outputs = sim.service_links(start.elapsed());
                let saves = std::mem::take(&mut outputs.saves);
                forward(outputs, &channels.outbound, &mut dropped_out);
                logger.send(&mut outputs.log);
                persistence.save(saves, sim.core(), &session);
                links.set_sign_require_mask(sim.core().sign_require_mask());
            }
        }
    }
    persistence.finish();
    crate::logging::edge::report(logger);
    let ticks = sim.core().scheduler().tick_stats();
    tracing::info!(
        "SITL stopped after {:.1} s simulated in {:.1} s: tick median {:.2} µs, p99 {:.2} µs, {} overruns, {} pacing restarts, {} messages dropped to links, {} late ticks",
        sim.time().as_secs_f64(),
        start.elapsed().as_secs_f64(),
        ticks.histogram.quantile_ns(0.5) as f64 / 1000.0,
        ticks.histogram.quantile_ns(0.99) as f64 / 1000.0,
        sim.core().scheduler().total_overruns(),
        pacer.late_restarts,
        dropped_out,
        pacer.late_ticks,
    );
    drop(links);
    Ok(())
}

/// The extra links: plain ones first, then the secure ones.
pub(crate) fn extra_endpoints(plain: &[Endpoint], secure: &[Endpoint]) -> Vec<LinkEndpoint> {
    let link = |secure: bool| {
        move |endpoint: &Endpoint| LinkEndpoint {
            endpoint: endpoint.clone(),
            secure,
        }
    };
    plain
        .iter()
        .map(link(false))
        .chain(secure.iter().map(link(true)))
        .collect()
}

/// Puts a world file's obstacles (and tape, if it has one) into the
/// simulation.
fn apply_world(sim: &mut Simulation, file: &drivers::sim::WorldFile) {
    sim.world_mut().set_obstacles(Some(file.obstacles()));
    if let Some(tape) = file.tape() {
        sim.world_mut().set_tape(Some(tape));
    }
}

/// Reloads the world file when its modification time changes (checked
/// once a wall second). A file that no longer parses keeps the old world
/// and says why.
struct WorldWatch {
    path: PathBuf,
    modified: Option<std::time::SystemTime>,
    next_check: Duration,
}

impl WorldWatch {
    const EVERY: Duration = Duration::from_secs(1);

    fn new(path: PathBuf) -> Self {
        let modified = std::fs::metadata(&path).and_then(|m| m.modified()).ok();
        WorldWatch {
            path,
            modified,
            next_check: Self::EVERY,
        }
    }

    fn poll(&mut self, wall: Duration, sim: &mut Simulation) {
        if wall < self.next_check {
            return;
        }
        self.next_check = wall + Self::EVERY;
        let modified = std::fs::metadata(&self.path).and_then(|m| m.modified()).ok();
        if modified.is_none() || modified == self.modified {
            return;
        }
        self.modified = modified;
        use mavlink::dialects::ardupilotmega::MavSeverity;
        match drivers::sim::load_world_file(&self.path) {
            Ok(file) => {
                apply_world(sim, &file);
                tracing::info!("world reloaded from {}", self.path.display());
                sim.core_mut()
                    .announce(MavSeverity::MAV_SEVERITY_INFO, "SIM: world reloaded");
            }
            Err(e) => {
                tracing::warn!("world file {}: {e}; keeping the old world", self.path.display());
                sim.core_mut().announce(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "SIM: world file invalid, kept old world",
                );
            }
        }
    }
}

/// Does the core's saves (see `vehicle::Storage`): turns each request into
/// a file for the writer thread and hands the writer's reports back to the
/// core, which acknowledges a change only then.
pub(crate) struct Persistence {
    dir: PathBuf,
    writer: Option<FileWriter>,
    done: tokio::sync::mpsc::UnboundedReceiver<SaveDone>,
}

impl Persistence {
    /// Opens the data directory's storage for `core`: durable when it can
    /// be written, else read-only (the vehicle runs on what it loaded).
    pub(crate) fn start(data_dir: &DataDir, core: &mut Core) -> Persistence {
        match data_dir.read_only() {
            Some(why) => {
                tracing::error!("data directory {}: {why}; changes refused", data_dir.path().display());
                core.set_storage(Storage::ReadOnly(why.to_owned()));
            }
            None => core.set_storage(Storage::Durable),
        }
        let (writer, done) = FileWriter::start();
        Persistence {
            dir: data_dir.path().to_path_buf(),
            writer: Some(writer),
            done,
        }
    }

    /// Hands the saves the core asked for to the writer thread.
    pub(crate) fn save(&mut self, requests: Vec<SaveRequest>, core: &Core, session: &SessionParams) {
        let Some(writer) = &self.writer else {
            return;
        };
        for SaveRequest { token, what } in requests {
            let (path, bytes) = match what {
                SaveWhat::Params { changes } => (
                    self.dir.join(params::store::STORE_FILE),
                    session.snapshot_with(core.params(), &changes).render().into_bytes(),
                ),
                SaveWhat::Plan { mission_type, plan } => {
                    (missions::path(&self.dir, mission_type), missions::contents(&plan))
                }
            };
            writer.save(token, path, bytes);
        }
    }

    /// Moves the saves finished so far into the core's inputs.
    pub(crate) fn collect(&mut self, inputs: &mut Inputs) {
        while let Ok(done) = self.done.try_recv() {
            inputs.saved.push(done);
        }
    }

    /// Waits up to `deadline` for link traffic or a finished save (moved
    /// into `inputs` with any others): `None` when the deadline passed with
    /// neither, else the first link item if that is what came.
    pub(crate) fn wait(
        &mut self,
        waiter: &tokio::runtime::Runtime,
        deadline: tokio::time::Instant,
        inbound: &mut tokio::sync::mpsc::Receiver<ToCore>,
        inputs: &mut Inputs,
    ) -> Option<Option<ToCore>> {
        let done = &mut self.done;
        let (first, saved) = waiter.block_on(async {
            tokio::select! {
                item = inbound.recv() => (item, None),
                save = done.recv() => (None, save),
                () = tokio::time::sleep_until(deadline) => (None, None),
            }
        });
        match saved {
            Some(save) => inputs.saved.push(save),
            None if first.is_none() => return None,
            None => {}
        }
        self.collect(inputs);
        Some(first)
    }

    /// Finishes the pending writes (their changes were never acknowledged:
    /// the process is going).
    pub(crate) fn finish(&mut self) {
        self.writer.take();
    }
}

/// Moves what the links delivered into the next step's inputs.
pub(crate) fn drain(inbound: &mut tokio::sync::mpsc::Receiver<ToCore>, inputs: &mut Inputs, first: Option<ToCore>) {
    let mut take = |item: ToCore| match item {
        ToCore::Event(e) => inputs.link_events.push(e),
        ToCore::Message(m) => inputs.messages.push(m),
        ToCore::UndecodableItem(i) => inputs.undecodable_items.push(i),
    };
    if let Some(item) = first {
        take(item);
    }
    while let Ok(item) = inbound.try_recv() {
        take(item);
    }
}

/// Hands the core's messages to the links (never waiting: a full queue
/// drops and counts).
pub(crate) fn forward(outputs: &mut Outputs, outbound: &tokio::sync::mpsc::Sender<Outbound>, dropped: &mut u64) {
    for out in outputs.mavlink.drain(..) {
        if let MavMessage::STATUSTEXT(t) = &out.message {
            tracing::info!("STATUSTEXT: {}", t.text.to_str().unwrap_or("?"));
        }
        if outbound.try_send(out).is_err() {
            *dropped += 1;
        }
    }
}

/// A flag set by SIGINT or SIGTERM, watched from a small thread of its own.
pub(crate) fn shutdown_on_signal() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            let Ok(rt) = tokio::runtime::Builder::new_current_thread().enable_all().build() else {
                return;
            };
            rt.block_on(async {
                let Ok(mut term) = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) else {
                    return;
                };
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            });
            set.store(true, Ordering::Relaxed);
        })
        .expect("spawn signal thread");
    flag
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    #[test]
    fn real_time_sleeps_until_the_step_is_due() {
        let mut p = Pacer::default();
        assert_eq!(
            p.delay(ms(20), ms(0), Some(1.0), ms(20)),
            None,
            "anchors on the first step"
        );
        assert_eq!(p.delay(ms(40), ms(5), Some(1.0), ms(20)), Some(ms(15)));
    }

    #[test]
    fn speedup_scales_and_max_never_sleeps() {
        let mut p = Pacer::default();
        p.delay(ms(0), ms(0), Some(10.0), ms(20));
        assert_eq!(p.delay(ms(1000), ms(50), Some(10.0), ms(20)), Some(ms(50)));
        let mut p = Pacer::default();
        for k in 0..100 {
            assert_eq!(p.delay(ms(20 * k), ms(0), None, ms(20)), None);
        }
    }

    #[test]
    fn a_stall_re_anchors_instead_of_racing() {
        let mut p = Pacer::default();
        p.delay(ms(0), ms(0), Some(1.0), ms(20));
        assert_eq!(p.delay(ms(20), ms(1000), Some(1.0), ms(20)), None);
        assert_eq!(p.late_restarts, 1);
        assert_eq!(p.delay(ms(40), ms(1000), Some(1.0), ms(20)), Some(ms(20)));
    }
}
