//! Crash safety: `furrow sitl` is SIGKILLed at seeded random moments while a
//! ground station uploads a mission or sets a burst of parameters, then
//! started again on the same data directory, where the mission and the
//! parameters must be the old ones or the new ones, never a mix, and the
//! files must load without a "damaged file" notice.
//!
//! What Furrow promises (and this checks):
//! - a mission is replaced as a whole: after any kill the vehicle has the
//!   complete old mission or the complete new one (the protocol replaces
//!   the plan only at the final ACK; the file is written to a temporary
//!   file, fsynced and renamed);
//! - each PARAM_SET is its own save, so a burst cut by a kill may leave some
//!   parameters new and others old; each one is its old or its new value;
//! - the MISSION_ACK ACCEPTED / PARAM_VALUE echo of a new value means "on
//!   disk": it goes out only after the file is written, fsynced and renamed.
//!   Any acknowledged change not found after the restart is a loss, however
//!   soon after the acknowledgement the kill came. Half the kills come at
//!   random instants of a transfer, the other half [`AFTER_ACK_MAX`] or less
//!   after an ACK or echo, where a change acknowledged early would be lost.

use std::collections::BTreeSet;
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mission::command::{cmd, frame};
use mission::{HomeItem, MissionItem, MissionType, Plan, validate_plan};
use params::files::{FileFormat, parse as parse_params};
use params::{ParamTable, ParamType};

use super::Row;
use super::gcs_client::{GcsClient, SitlProcess};
use autopilot::sitl::simulation::{ModelKind, SimulationParams};

/// Parameters changed together in one burst.
const BURST_PARAMS: usize = 20;
/// Kills aimed just after an acknowledgement come within this of it.
const AFTER_ACK_MAX: Duration = Duration::from_millis(5);
/// Home of the generated missions (the bench course's).
const HOME_DEG_E7: (i32, i32) = (291_330_000, 1_196_400_000);

/// A seeded generator (ChaCha8): the same seed gives the same kill
/// moments, missions and values.
pub(super) struct SeededRng(rand_chacha::ChaCha8Rng);

impl SeededRng {
    pub(super) fn new(seed: u64) -> Self {
        use rand::SeedableRng;
        SeededRng(rand_chacha::ChaCha8Rng::seed_from_u64(seed))
    }

    pub(super) fn next_u64(&mut self) -> u64 {
        rand::RngCore::next_u64(&mut self.0)
    }

    /// Uniform in `[0, 1)`.
    pub(super) fn unit(&mut self) -> f64 {
        rand::Rng::random::<f64>(&mut self.0)
    }

    /// Uniform in `lo..=hi`.
    pub(super) fn between(&mut self, lo: i64, hi: i64) -> i64 {
        rand::Rng::random_range(&mut self.0, lo..=hi)
    }
}

/// A parameter of the burst and its allowed range.
struct BurstParam {
    name: String,
    default: f64,
    min: f64,
    max: f64,
}

/// Real-valued parameters that do nothing while the vehicle holds
/// disarmed (tracker and magnetic-mode tuning).
fn burst_params(table: &ParamTable) -> Vec<BurstParam> {
    (0..table.len() as u16)
        .map(|i| table.def(i))
        .filter(|d| d.ty == ParamType::Real32 && !d.flags.read_only && !d.flags.reboot_required)
        .filter(|d| {
            let name = d.name.to_string();
            name.starts_with("PVW_") || name.starts_with("MAG_")
        })
        .take(BURST_PARAMS)
        .map(|d| BurstParam {
            name: d.name.to_string(),
            default: d.default,
            min: d.min,
            max: d.max,
        })
        .collect()
}

/// What the data directory holds, as far as the test knows.
struct Stored {
    mission: Plan,
    params: Vec<f32>,
}

/// The change a run started before its kill.
enum Pending {
    Mission {
        plan: Plan,
        /// How long before the kill the final ACK arrived.
        acked_before_kill: Option<Duration>,
    },
    Params {
        values: Vec<f32>,
        echoed_before_kill: Vec<Option<Duration>>,
    },
}

#[derive(Default)]
struct Tally {
    runs: u32,
    verified: u32,
    mission_kills: u32,
    mission_before_ack: u32,
    mission_after_ack: u32,
    mission_new_found: u32,
    mission_acked_lost: u32,
    param_kills: u32,
    /// Kills aimed 0–[`AFTER_ACK_MAX`] after an ACK or echo.
    kills_after_ack: u32,
    params_echoed: u32,
    params_new_found: u32,
    params_echoed_lost: u32,
    partial_bursts: u32,
    failures: Vec<String>,
    /// The shortest ACK-to-kill time of a kill aimed after an ACK.
    shortest_after_ack: Option<Duration>,
}

impl Tally {
    fn killed_after_ack(&mut self, gap: Duration) {
        self.kills_after_ack += 1;
        self.shortest_after_ack = Some(self.shortest_after_ack.map_or(gap, |w| w.min(gap)));
    }
}

/// Calibrated durations, for spreading the kills over the transfers.
struct Timing {
    upload_per_item: Duration,
    burst: Duration,
    mission_ack_to_disk: Duration,
    params_echo_to_disk: Duration,
}

struct Bench<'a> {
    exe: &'a Path,
    dir: PathBuf,
    udp_port: u16,
    params: Vec<BurstParam>,
    rng: SeededRng,
    seed: u64,
}

pub fn run(exe: &Path, runs: u32, seed: u64) -> Result<Vec<Row>, String> {
    let scratch = crate::scratch_dir(&format!("furrow-kill-{seed}-"))?;
    let dir = scratch.path().to_path_buf();
    // The UDP link sends here; held so nothing else receives it.
    let udp_sink = UdpSocket::bind("127.0.0.1:0").map_err(|e| format!("udp: {e}"))?;
    let udp_port = udp_sink.local_addr().map_err(|e| e.to_string())?.port();
    let table = SimulationParams::new(ModelKind::Ackermann).table;
    let mut bench = Bench {
        exe,
        dir: dir.clone(),
        udp_port,
        params: burst_params(&table),
        rng: SeededRng::new(seed),
        seed,
    };
    if bench.params.len() < BURST_PARAMS {
        return Err(format!("only {} burst parameters found", bench.params.len()));
    }
    // A failed run keeps its directory: the logs and data say what happened.
    bench
        .run_all(runs)
        .map_err(|e| format!("{e} (logs kept in {})", scratch.keep().display()))
}

impl Bench<'_> {
    fn start(&self, tag: &str) -> Result<(SitlProcess, GcsClient), String> {
        let args: Vec<String> = [
            "--speedup",
            "max",
            "--tcp-port",
            "0",
            "--udp-port",
            &self.udp_port.to_string(),
            "--seed",
            &self.seed.to_string(),
            "--data-dir",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([self.dir.join("data").display().to_string()])
        .collect();
        let sitl = SitlProcess::start(self.exe, &args, &self.dir.join(format!("{tag}.log")))?;
        let mut gcs = GcsClient::connect(sitl.tcp_port)?;
        gcs.wait_heartbeat(Duration::from_secs(10))?;
        Ok((sitl, gcs))
    }

    fn run_all(&mut self, runs: u32) -> Result<Vec<Row>, String> {
        let (mut stored, timing) = self.calibrate()?;
        let mut tally = Tally::default();
        let mut pending = None;
        for run in 0..runs {
            let (sitl, mut gcs) = self.start(&format!("run{run}"))?;
            tally.runs += 1;
            self.verify(&sitl, &mut gcs, &mut stored, pending.take(), &mut tally)?;
            // Random instants, then just after an acknowledgement, in turn.
            let after_ack = (run / 2) % 2 == 1;
            pending = Some(if run % 2 == 0 {
                let size = match (run / 4) % 3 {
                    0 => 1,
                    1 => self.rng.between(5, 40),
                    _ => self.rng.between(150, 300),
                };
                self.kill_during_upload(sitl, gcs, size as usize, &timing, run, after_ack, &mut tally)?
            } else {
                self.kill_during_burst(sitl, gcs, &timing, after_ack, &mut tally)?
            });
        }
        let (sitl, mut gcs) = self.start("final")?;
        self.verify(&sitl, &mut gcs, &mut stored, pending.take(), &mut tally)?;
        let _ = sitl.interrupt(Duration::from_secs(5));
        Ok(rows(&tally, &timing))
    }

    /// One clean run: checks the fresh directory (empty mission, defaults),
    /// then times an unbroken 300-item upload and a parameter burst, and how
    /// long each takes to reach the disk after its acknowledgement.
    fn calibrate(&mut self) -> Result<(Stored, Timing), String> {
        let (sitl, mut gcs) = self.start("calibration")?;
        for p in &self.params {
            let value = gcs.param_read(&p.name)?;
            if value != p.default as f32 {
                return Err(format!("fresh data directory: {} = {value}, not its default", p.name));
            }
        }
        let (items, id) = gcs.download_mission()?;
        let empty = Plan::new(MissionType::Mission, Vec::new());
        if id != empty.opaque_id() || items.len() > 1 {
            return Err(format!("fresh data directory: {} mission items", items.len()));
        }
        let plan = random_mission(&mut self.rng, 300, 0)?;
        let started = Instant::now();
        let (acked_id, acked_at) = gcs.upload_mission(plan.items(), |_| {})?;
        if acked_id != plan.opaque_id() {
            return Err(format!(
                "calibration upload acknowledged id {acked_id:#x}, expected {:#x}",
                plan.opaque_id()
            ));
        }
        let upload = acked_at - started;
        let mission_file = self.dir.join("data").join("mission.waypoints");
        let mission_ack_to_disk = wait_on_disk(acked_at, || mission_file_id(&mission_file) == Some(plan.opaque_id()))?;

        let values = self.random_values();
        let started = Instant::now();
        let echoed = self.burst(&mut gcs, &values);
        let last_echo = echoed.iter().flatten().max().copied().unwrap_or(started);
        if echoed.iter().any(Option::is_none) {
            return Err("calibration burst: not every PARAM_SET was echoed".into());
        }
        let params_file = self.dir.join("data").join(params::store::STORE_FILE);
        let names: Vec<&str> = self.params.iter().map(|p| p.name.as_str()).collect();
        let params_echo_to_disk = wait_on_disk(last_echo, || params_file_has(&params_file, &names, &values))?;
        sitl.interrupt(Duration::from_secs(5))?;
        Ok((
            Stored {
                mission: plan,
                params: values,
            },
            Timing {
                upload_per_item: upload / 300,
                burst: last_echo - started,
                mission_ack_to_disk,
                params_echo_to_disk,
            },
        ))
    }

    fn random_values(&mut self) -> Vec<f32> {
        let mut values = Vec::with_capacity(self.params.len());
        for p in &self.params {
            let v = p.min + (p.max - p.min) * self.rng.unit();
            values.push(v as f32);
        }
        values
    }

    /// Sets the parameters one after the other, each after the echo of the
    /// one before (as QGroundControl and MAVProxy do), until all are echoed
    /// or the connection dies; returns when each was echoed.
    fn burst(&self, gcs: &mut GcsClient, values: &[f32]) -> Vec<Option<Instant>> {
        let mut echoed = vec![None; values.len()];
        for ((p, v), at) in self.params.iter().zip(values).zip(&mut echoed) {
            if gcs.param_set(&p.name, *v).is_err() {
                break;
            }
            *at = Some(Instant::now());
        }
        echoed
    }

    /// Uploads `size` items and kills the process at a random instant of
    /// the transfer, or (`after_ack`) 0–[`AFTER_ACK_MAX`] after its ACK.
    #[allow(clippy::too_many_arguments)]
    fn kill_during_upload(
        &mut self,
        sitl: SitlProcess,
        mut gcs: GcsClient,
        size: usize,
        timing: &Timing,
        run: u32,
        after_ack: bool,
        tally: &mut Tally,
    ) -> Result<Pending, String> {
        let plan = random_mission(&mut self.rng, size, run + 1)?;
        let (outcome, killed_at) = if after_ack {
            let delay = AFTER_ACK_MAX.mul_f64(self.rng.unit());
            let outcome = gcs.upload_mission(plan.items(), |_| {});
            std::thread::sleep(delay);
            sitl.killer().kill();
            let killed_at = Instant::now();
            if let Ok((_, acked_at)) = &outcome {
                tally.killed_after_ack(killed_at - *acked_at);
            }
            (outcome, killed_at)
        } else {
            let window =
                timing.upload_per_item * size as u32 + timing.mission_ack_to_disk * 3 + Duration::from_millis(2);
            let delay = window.mul_f64(self.rng.unit());
            let killer = sitl.killer();
            let kill = std::thread::spawn(move || {
                std::thread::sleep(delay);
                killer.kill();
                Instant::now()
            });
            let outcome = gcs.upload_mission(plan.items(), |_| {});
            (outcome, kill.join().map_err(|_| "kill thread panicked".to_string())?)
        };
        drop(sitl);
        tally.mission_kills += 1;
        let acked_before_kill = match outcome {
            Ok((_, acked_at)) if acked_at <= killed_at => {
                tally.mission_after_ack += 1;
                Some(killed_at - acked_at)
            }
            _ => {
                tally.mission_before_ack += 1;
                None
            }
        };
        Ok(Pending::Mission {
            plan,
            acked_before_kill,
        })
    }

    /// Sets a burst and kills the process at a random instant of it, or
    /// (`after_ack`) 0–[`AFTER_ACK_MAX`] after the echo of a random one.
    fn kill_during_burst(
        &mut self,
        sitl: SitlProcess,
        mut gcs: GcsClient,
        timing: &Timing,
        after_ack: bool,
        tally: &mut Tally,
    ) -> Result<Pending, String> {
        let values = self.random_values();
        let (echoed, killed_at) = if after_ack {
            let last = self.rng.between(0, values.len() as i64 - 1) as usize;
            let delay = AFTER_ACK_MAX.mul_f64(self.rng.unit());
            let mut echoed = self.burst(&mut gcs, &values[..=last]);
            std::thread::sleep(delay);
            sitl.killer().kill();
            let killed_at = Instant::now();
            if let Some(Some(at)) = echoed.last() {
                tally.killed_after_ack(killed_at - *at);
            }
            echoed.resize(values.len(), None);
            (echoed, killed_at)
        } else {
            let window = timing.burst + timing.params_echo_to_disk * 3 + Duration::from_millis(2);
            let delay = window.mul_f64(self.rng.unit());
            let killer = sitl.killer();
            let kill = std::thread::spawn(move || {
                std::thread::sleep(delay);
                killer.kill();
                Instant::now()
            });
            let echoed = self.burst(&mut gcs, &values);
            (echoed, kill.join().map_err(|_| "kill thread panicked".to_string())?)
        };
        drop(sitl);
        tally.param_kills += 1;
        let echoed_before_kill: Vec<Option<Duration>> = echoed
            .iter()
            .map(|e| e.filter(|&t| t <= killed_at).map(|t| killed_at - t))
            .collect();
        tally.params_echoed += echoed_before_kill.iter().flatten().count() as u32;
        Ok(Pending::Params {
            values,
            echoed_before_kill,
        })
    }

    /// After a restart: the mission and every parameter must be the old or
    /// the new, what was acknowledged long enough before the kill must be
    /// there, and nothing may have been reported damaged.
    fn verify(
        &self,
        sitl: &SitlProcess,
        gcs: &mut GcsClient,
        stored: &mut Stored,
        pending: Option<Pending>,
        tally: &mut Tally,
    ) -> Result<(), String> {
        let failures_before = tally.failures.len();
        let run = tally.runs;
        let (items, id) = gcs.download_mission()?;
        let mut values = Vec::new();
        for p in &self.params {
            values.push(gcs.param_read(&p.name)?);
        }
        let log = sitl.stderr();
        for line in log
            .lines()
            .filter(|l| l.contains("unreadable") || l.contains("could not be read"))
        {
            tally.failures.push(format!("start {run}: {line}"));
        }
        let aside = corrupt_files(&self.dir.join("data"));
        if !aside.is_empty() {
            tally
                .failures
                .push(format!("start {run}: files moved aside: {aside:?}"));
        }
        let found_mission = |plan: &Plan| same_mission(plan, &items, id);
        match pending {
            Some(Pending::Mission {
                plan,
                acked_before_kill,
            }) => {
                if found_mission(&plan) {
                    tally.mission_new_found += 1;
                    stored.mission = plan;
                } else if found_mission(&stored.mission) {
                    if let Some(gap) = acked_before_kill {
                        tally.mission_acked_lost += 1;
                        tally.failures.push(format!(
                            "start {run}: mission acknowledged {:.2} ms before the kill was lost",
                            gap.as_secs_f64() * 1e3
                        ));
                    }
                } else {
                    tally.failures.push(format!(
                        "start {run}: mission is neither old ({} items) nor new ({} items): {} items, id {id:#x}",
                        stored.mission.len(),
                        plan.len(),
                        items.len()
                    ));
                }
            }
            other => {
                if !found_mission(&stored.mission) {
                    tally.failures.push(format!(
                        "start {run}: mission changed without an upload: {} items, id {id:#x}",
                        items.len()
                    ));
                }
                self.verify_params(run, &values, stored, other, tally);
            }
        }
        if tally.failures.len() == failures_before {
            tally.verified += 1;
        }
        Ok(())
    }

    fn verify_params(&self, run: u32, found: &[f32], stored: &mut Stored, pending: Option<Pending>, tally: &mut Tally) {
        let (new, echoed) = match pending {
            Some(Pending::Params {
                values,
                echoed_before_kill,
            }) => (Some(values), echoed_before_kill),
            _ => (None, vec![None; found.len()]),
        };
        let mut kinds = BTreeSet::new();
        for (i, p) in self.params.iter().enumerate() {
            let old = stored.params[i];
            let is_new = new.as_ref().is_some_and(|n| n[i].to_bits() == found[i].to_bits());
            let is_old = old.to_bits() == found[i].to_bits();
            if is_new {
                tally.params_new_found += 1;
                stored.params[i] = found[i];
                kinds.insert("new");
            } else if is_old {
                kinds.insert("old");
                if let Some(gap) = echoed[i] {
                    tally.params_echoed_lost += 1;
                    tally.failures.push(format!(
                        "start {run}: {} echoed {:.2} ms before the kill was lost",
                        p.name,
                        gap.as_secs_f64() * 1e3
                    ));
                }
            } else {
                tally.failures.push(format!(
                    "start {run}: {} = {} is neither old {} nor new {:?}",
                    p.name,
                    found[i],
                    old,
                    new.as_ref().map(|n| n[i])
                ));
            }
        }
        if kinds.len() == 2 {
            tally.partial_bursts += 1;
        }
    }
}

/// A mission of `size` items (home first), distinct for each `salt`:
/// waypoints with hold times, and a speed change every tenth item.
fn random_mission(rng: &mut SeededRng, size: usize, salt: u32) -> Result<Plan, String> {
    let mut items = Vec::with_capacity(size);
    for seq in 0..size {
        let seq16 = seq as u16;
        let item = if seq == 0 {
            HomeItem {
                lat_e7: HOME_DEG_E7.0 + salt as i32,
                lon_e7: HOME_DEG_E7.1,
                alt_m: 40.0,
            }
            .to_item()
        } else if seq % 10 == 0 {
            MissionItem {
                seq: seq16,
                frame: frame::MISSION,
                command: cmd::DO_CHANGE_SPEED,
                current: false,
                autocontinue: true,
                params: [1.0, (0.5 + 2.5 * rng.unit()) as f32, -1.0, 0.0],
                x: 0,
                y: 0,
                z: 0.0,
            }
        } else {
            MissionItem {
                seq: seq16,
                frame: frame::GLOBAL_RELATIVE_ALT,
                command: cmd::NAV_WAYPOINT,
                current: false,
                autocontinue: true,
                params: [(10.0 * rng.unit()) as f32, 0.0, 0.0, 0.0],
                x: HOME_DEG_E7.0 + rng.between(-45_000, 45_000) as i32,
                y: HOME_DEG_E7.1 + rng.between(-45_000, 45_000) as i32,
                z: (5.0 * rng.unit()) as f32,
            }
        };
        items.push(item);
    }
    validate_plan(MissionType::Mission, items).map_err(|(seq, r)| format!("generated mission item {seq}: {r:?}"))
}

/// Whether a download (items and opaque id) is `plan`. Item 0 is home,
/// replaced by the current home in downloads, so it is covered by the id
/// (a CRC of the stored items); the others are compared field by field.
fn same_mission(plan: &Plan, items: &[MissionItem], id: u32) -> bool {
    if id != plan.opaque_id() {
        return false;
    }
    if plan.is_empty() {
        return items.len() <= 1;
    }
    items.len() == plan.len()
        && plan.items().iter().zip(items).skip(1).all(|(a, b)| {
            a.seq == b.seq
                && a.frame == b.frame
                && a.command == b.command
                && a.autocontinue == b.autocontinue
                && a.params.map(f32::to_bits) == b.params.map(f32::to_bits)
                && a.x == b.x
                && a.y == b.y
                && a.z.to_bits() == b.z.to_bits()
        })
}

/// The opaque id of the plan in a mission file, if it reads as one.
fn mission_file_id(path: &Path) -> Option<u32> {
    let text = std::fs::read_to_string(path).ok()?;
    let items = mission::files::wpl::parse(&text).ok()?;
    validate_plan(MissionType::Mission, items).ok().map(|p| p.opaque_id())
}

/// Whether the parameter file holds every `names[i] = values[i]`.
fn params_file_has(path: &Path, names: &[&str], values: &[f32]) -> bool {
    let Ok(text) = std::fs::read_to_string(path) else {
        return false;
    };
    let Ok(entries) = parse_params(&text, FileFormat::MissionPlanner) else {
        return false;
    };
    names.iter().zip(values).all(|(name, value)| {
        entries
            .iter()
            .any(|e| e.name == *name && (e.value as f32).to_bits() == value.to_bits())
    })
}

/// Polls until `done`, returning how long after `since` it became true.
fn wait_on_disk(since: Instant, mut done: impl FnMut() -> bool) -> Result<Duration, String> {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        if done() {
            return Ok(since.elapsed());
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    Err("an acknowledged change was not on disk within 5 s".into())
}

/// Files storage moved aside as unreadable.
fn corrupt_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(".corrupt-"))
                .collect()
        })
        .unwrap_or_default()
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

fn rows(t: &Tally, timing: &Timing) -> Vec<Row> {
    let acknowledged = t.mission_after_ack + t.params_echoed;
    let lost = t.mission_acked_lost + t.params_echoed_lost;
    vec![
        Row {
            part: "kill",
            case: "SIGKILL runs, each restart verified".into(),
            expected: format!("{} of {} verified", t.runs + 1, t.runs + 1),
            measured: format!("{} of {} restarts verified", t.verified, t.runs + 1),
            ok: t.verified == t.runs + 1,
        },
        Row {
            part: "kill",
            case: "kills during mission uploads (1–300 items)".into(),
            expected: "mission = old or new, field by field".into(),
            measured: format!(
                "{} kills: {} before the final ACK, {} after it; new mission found {} times, \
                 acknowledged but old {} times",
                t.mission_kills, t.mission_before_ack, t.mission_after_ack, t.mission_new_found, t.mission_acked_lost
            ),
            ok: t.mission_kills > 0,
        },
        Row {
            part: "kill",
            case: format!("kills during bursts of {BURST_PARAMS} PARAM_SET"),
            expected: "each param old or new (a partial set is legal)".into(),
            measured: format!(
                "{} kills: {} of {} sets echoed before the kill, {} new values found, {} partial sets, \
                 echoed but old {}",
                t.param_kills,
                t.params_echoed,
                t.param_kills as usize * BURST_PARAMS,
                t.params_new_found,
                t.partial_bursts,
                t.params_echoed_lost
            ),
            ok: t.param_kills > 0,
        },
        Row {
            part: "kill",
            case: "failures (mix, loss, damaged file)".into(),
            expected: "0".into(),
            measured: match t.failures.first() {
                None => "0".into(),
                Some(first) => format!("{}; first: {first}", t.failures.len()),
            },
            ok: t.failures.is_empty(),
        },
        Row {
            part: "kill",
            case: format!("kills 0–{} ms after an ACK/echo", AFTER_ACK_MAX.as_millis()),
            expected: "half the runs".into(),
            measured: format!(
                "{} kills, the soonest {} after its ACK/echo",
                t.kills_after_ack,
                t.shortest_after_ack.map_or("-".into(), ms)
            ),
            ok: t.kills_after_ack > 0,
        },
        Row {
            part: "kill",
            case: "acknowledged changes lost".into(),
            expected: "0 (any ACKed/echoed change missing after restart)".into(),
            measured: format!(
                "{lost} of {acknowledged} acknowledged before a kill; calibration: the file held the change \
                 at the first check after the ACK ({} mission, {} params)",
                ms(timing.mission_ack_to_disk),
                ms(timing.params_echo_to_disk)
            ),
            ok: lost == 0,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_rng_is_repeatable_and_in_range() {
        let mut a = SeededRng::new(7);
        let mut b = SeededRng::new(7);
        for _ in 0..1000 {
            let x = a.between(5, 300);
            assert_eq!(x, b.between(5, 300));
            assert!((5..=300).contains(&x));
            let u = a.unit();
            assert_eq!(u, b.unit());
            assert!((0.0..1.0).contains(&u));
        }
        assert_ne!(SeededRng::new(1).next_u64(), SeededRng::new(2).next_u64());
    }

    #[test]
    fn generated_missions_are_valid_and_distinct() {
        let mut rng = SeededRng::new(1);
        let a = random_mission(&mut rng, 300, 1).unwrap();
        let b = random_mission(&mut rng, 300, 2).unwrap();
        assert_eq!(a.len(), 300);
        assert_ne!(a.opaque_id(), b.opaque_id());
    }

    #[test]
    fn a_download_matches_only_its_own_plan() {
        let mut rng = SeededRng::new(3);
        let plan = random_mission(&mut rng, 20, 1).unwrap();
        let mut items = plan.items().to_vec();
        // Home as the vehicle reports it: another position, same plan.
        items[0].x += 5;
        assert!(same_mission(&plan, &items, plan.opaque_id()));
        items[7].params[0] += 0.5;
        assert!(!same_mission(&plan, &items, plan.opaque_id()), "a changed item");
        assert!(!same_mission(&plan, &items[..19], plan.opaque_id()), "a missing item");
        let empty = Plan::new(MissionType::Mission, Vec::new());
        assert!(same_mission(&empty, &items[..1], empty.opaque_id()));
        assert!(!same_mission(&empty, &items[..1], plan.opaque_id()));
    }

    #[test]
    fn the_burst_parameters_exist_and_are_harmless() {
        let table = SimulationParams::new(ModelKind::Ackermann).table;
        let params = burst_params(&table);
        assert_eq!(params.len(), BURST_PARAMS);
        assert!(
            params
                .iter()
                .all(|p| p.name.starts_with("PVW_") || p.name.starts_with("MAG_"))
        );
    }
}
