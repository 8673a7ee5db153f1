//! `furrow-bench tracking`: the accuracy of the navigation core on the
//! reference courses in `tests/data/bench` (their README gives the vehicle and receiver).
//!
//! Each course runs in AUTO for every seed, in-process at full speed (world,
//! simulated NMEA GNSS and heading, the real driver and the whole core), and
//! the error is measured from the simulator's *true* pose, not the
//! estimate: against the path the autopilot planned from the mission (its
//! straights and corner arcs, mapped from the simulator's frame through
//! WGS-84 into the autopilot's), on straights from 3 m after a turn ends, on
//! arcs, and at each precision stop once the vehicle rests there.

use std::path::PathBuf;
use std::time::Duration;

use mission::{ExecState, MissionType, Plan};

use crate::plot::{self, PlotData};

use autopilot::edge::clock::InstantTimer;
use autopilot::geo::{GeoPoint, LocalFrame, Ned, wrap_pi};
use autopilot::guidance::navigator::{NavTarget, Navigator};
use autopilot::guidance::path::{LegPath, PathProjection, Piece};
use autopilot::guidance::tracker::Direction;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};

/// The reference courses, built in so the benchmark runs from anywhere.
const BUILT_IN: [(&str, &str); 2] = [
    (
        "agv_course",
        include_str!("../../tests/data/bench/agv_course.waypoints"),
    ),
    (
        "square_40m",
        include_str!("../../tests/data/bench/square_40m.waypoints"),
    ),
];

/// Straights count from this far after a turn ends (bench README).
const AFTER_TURN_M: f64 = 3.0;
/// A stop's settling time runs from the vehicle first coming this close to
/// the point (true pose) to the stop report.
const SETTLE_WINDOW_M: f64 = 0.03;
/// The vehicle is at rest below this true speed, and moving again (a
/// re-approach) above the second figure.
const REST_MPS: f64 = 0.002;
const MOVING_AGAIN_MPS: f64 = 0.005;
/// A stop should settle within this long (the tracking target); slower ones are
/// listed one by one.
const SETTLE_TARGET_S: f64 = 8.0;

/// Where a stop's settling time goes, from the truth: from first coming
/// within [`SETTLE_WINDOW_M`] of the point to first resting (the final
/// creep), and how often it moved off again (re-approaches).
#[derive(Clone, Copy, Debug, Default)]
struct SettleWatch {
    within_since_s: Option<f64>,
    first_rest_s: Option<f64>,
    resting: bool,
    restarts: u32,
}

impl SettleWatch {
    fn update(&mut self, time_s: f64, to_go_m: f64, speed_mps: f64) {
        if self.within_since_s.is_none() && to_go_m <= SETTLE_WINDOW_M {
            self.within_since_s = Some(time_s);
        }
        if self.within_since_s.is_none() {
            return;
        }
        if speed_mps.abs() < REST_MPS {
            self.first_rest_s.get_or_insert(time_s);
            self.resting = true;
        } else if self.resting && speed_mps.abs() > MOVING_AGAIN_MPS {
            self.resting = false;
            self.restarts += 1;
        }
    }
}

#[derive(clap::Args, Debug)]
pub struct TrackingBenchArgs {
    /// A course (QGC WPL 110); repeat for several. Default: the two
    /// reference courses.
    #[arg(long = "course")]
    pub courses: Vec<PathBuf>,
    /// Seeds 1..=N.
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// Where the SVG plots go.
    #[arg(long, default_value = "target/bench")]
    pub out_dir: PathBuf,
    /// A run that has not finished after this many simulated seconds fails.
    #[arg(long, default_value_t = 1200.0)]
    pub timeout_s: f64,
    /// Heading at the start, degrees (the courses start facing north).
    #[arg(long, default_value_t = 0.0)]
    pub heading_deg: f64,
    /// Also write the plotted seed's tick-by-tick trace as CSV next to the
    /// plots (for tuning).
    #[arg(long)]
    pub trace: bool,
    /// The seed whose plot (and trace) is written.
    #[arg(long, default_value_t = 1)]
    pub plot_seed: u64,
    /// Only the manoeuvre section (pose goals 1–10 m away and RTL from
    /// them, both models), with this many seeds.
    #[arg(long)]
    pub manoeuvres_only: Option<u64>,
    /// Run with a parameter changed, NAME=VALUE (repeatable): to see what a
    /// gain does to the figures.
    #[arg(long = "param", value_parser = parse_param)]
    pub params: Vec<(String, f64)>,
    /// Vehicle models to run each course with (repeatable). Default: both.
    #[arg(long = "model", value_enum)]
    pub models: Vec<BenchModel>,
    /// The manoeuvre section: only the goals of this run seed (as the
    /// misses list names them; repeatable), with `--trace` printed tick by
    /// tick.
    #[arg(long = "manoeuvre-seed")]
    pub manoeuvre_seeds: Vec<u64>,
}

/// `--model` of the tracking bench.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchModel {
    Ackermann,
    Differential,
}

impl BenchModel {
    fn kind(self) -> ModelKind {
        match self {
            BenchModel::Ackermann => ModelKind::Ackermann,
            BenchModel::Differential => ModelKind::Differential,
        }
    }
}

pub(crate) fn parse_param(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("{text:?}: expected NAME=VALUE"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("{text:?}: {value:?} is not a number"))?;
    Ok((name.trim().to_ascii_uppercase(), value))
}

/// One course with its mission.
pub(crate) struct Course {
    pub(crate) name: String,
    pub(crate) items: Vec<mission::MissionItem>,
    pub(crate) home: GeoPoint,
}

/// Where the vehicle stopped, from the truth, when the autopilot reported
/// the stop.
#[derive(Clone, Copy, Debug)]
pub struct StopRecord {
    pub seq: u16,
    pub position_m: f64,
    pub along_m: f64,
    pub crosstrack_m: f64,
    pub yaw_rad: f64,
    /// The autopilot's own figure (from its estimate), for comparison.
    pub reported_mm: f64,
    pub reported_yaw_deg: f64,
    /// How far the estimate was from the truth then.
    pub estimate_error_m: f64,
    pub estimate_yaw_error_rad: f64,
    /// From first coming within [`SETTLE_WINDOW_M`] of the point (truth) to
    /// the report; None if it never came that close.
    pub settle_s: Option<f64>,
    /// Of which the final creep: from within [`SETTLE_WINDOW_M`] to first
    /// resting.
    pub creep_s: Option<f64>,
    /// Times it moved off again after resting (re-approaches).
    pub restarts: u32,
    pub direction: Direction,
    pub seed: u64,
}

/// One cross-track sample: the true pose's, and the autopilot's own (its
/// estimate's), whose difference is the estimate's error across the path.
/// A tracker steers the estimate onto the path; it cannot see the rest.
#[derive(Clone, Copy, Debug)]
pub struct LateralSample {
    pub true_m: f64,
    pub estimate_m: f64,
}

/// One run of one course with one seed.
#[derive(Default)]
pub struct RunRecord {
    pub completion_s: Option<f64>,
    /// time, true/estimated crosstrack, steering, speeds… (the plotted seed, with --trace).
    pub trace: Vec<String>,
    pub straight_m: Vec<LateralSample>,
    pub arc_m: Vec<LateralSample>,
    /// The same samples as `straight_m`/`arc_m`, split by the direction the
    /// leg is driven in.
    pub forward_straight_m: Vec<LateralSample>,
    pub reverse_straight_m: Vec<LateralSample>,
    pub forward_arc_m: Vec<LateralSample>,
    pub reverse_arc_m: Vec<LateralSample>,
    /// Straights within `AFTER_TURN_M` after a turn ends (where a turn's
    /// exit leaves the vehicle off the line), both directions.
    pub turn_exit_m: Vec<LateralSample>,
    pub stops: Vec<StopRecord>,
    pub plot: PlotData,
    pub core_tick_overruns: u64,
}

pub fn run(args: &TrackingBenchArgs) -> Result<(), String> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    if !(args.timeout_s.is_finite() && args.timeout_s > 0.0) {
        return Err(format!("--timeout-s {}: must be a positive number", args.timeout_s));
    }
    // Refuse a bad --param before running anything.
    let mut probe = SimulationParams::new(ModelKind::Ackermann);
    probe.apply(&args.params)?;
    if let Some(seeds) = args.manoeuvres_only {
        let models: Vec<ModelKind> = args.models.iter().map(|m| m.kind()).collect();
        let options = super::manoeuvre::Options {
            seeds: seeds.max(1),
            params: &args.params,
            models: &models,
            run_seeds: &args.manoeuvre_seeds,
            trace: args.trace,
        };
        super::manoeuvre::report(&options);
        return Ok(());
    }
    let courses = load_courses(&args.courses)?;
    std::fs::create_dir_all(&args.out_dir).map_err(|e| format!("{}: {e}", args.out_dir.display()))?;
    let models = if args.models.is_empty() {
        vec![BenchModel::Ackermann, BenchModel::Differential]
    } else {
        args.models.clone()
    };
    print_conditions(&probe, args.seeds, &models);
    for (course, model) in courses.iter().flat_map(|c| models.iter().map(move |m| (c, *m))) {
        let started = std::time::Instant::now();
        let runs: Vec<RunRecord> = (1..=args.seeds)
            .map(|seed| {
                run_course(
                    course,
                    &RunOptions {
                        seed,
                        model: model.kind(),
                        heading_deg: args.heading_deg,
                        timeout_s: args.timeout_s,
                        keep_plot: seed == args.plot_seed,
                        trace: args.trace && seed == args.plot_seed,
                        params: &args.params,
                    },
                )
            })
            .collect();
        println!();
        println!("# {:?}", model.kind());
        report(course, &runs, started.elapsed());
        report_directions(&runs);
        report_settling(&runs);
        write_outputs(args, course, model, &runs)?;
    }
    if args.courses.is_empty() {
        super::magnetic::report(args.seeds.min(4));
        super::manoeuvre::report(&super::manoeuvre::Options {
            seeds: 1,
            params: &args.params,
            models: &[],
            run_seeds: &[],
            trace: false,
        });
    }
    Ok(())
}

/// The bench's conditions, and how often the GNSS walk alone lets even a
/// perfect stop land within 10 mm.
fn print_conditions(probe: &SimulationParams, seeds: u64, models: &[BenchModel]) {
    let value = |name: &str| probe.table.value_of(name).unwrap_or(f64::NAN);
    let (noise_mm, walk_mm) = (value("SIM_GPS_NOISE") * 1000.0, value("SIM_GPS_WALK") * 1000.0);
    let (rate_hz, heading_deg) = (value("SIM_GPS_RATE"), value("SIM_HDG_NOISE"));
    println!(
        "furrow-bench tracking: seeds 1..={seeds}, bench vehicle {models:?}, RTK GNSS σ {noise_mm:.1} mm white + \
         {walk_mm:.1} mm walk (τ 60 s) per axis at {rate_hz:.0} Hz, dual-antenna heading σ {heading_deg:.3}°; \
         errors are of the true pose"
    );
    // The walk is a slow bias of every fix: no filter of these fixes can see
    // it, so it alone sets how often even a perfect stop lands within 10 mm
    // (a 2-D Gaussian of σ per axis: Rayleigh).
    let ceiling = 1.0 - (-(10.0f64 * 10.0) / (2.0 * walk_mm * walk_mm)).exp();
    println!(
        "noise floor: the walk alone puts a perfectly estimated-and-controlled stop within 10 mm in {:.1} % of cases",
        100.0 * ceiling
    );
}

/// The first seed's plot, and its trace with `--trace`, in the output
/// folder.
fn write_outputs(
    args: &TrackingBenchArgs,
    course: &Course,
    model: BenchModel,
    runs: &[RunRecord],
) -> Result<(), String> {
    let name = match model {
        BenchModel::Ackermann => course.name.clone(),
        BenchModel::Differential => format!("{}-differential", course.name),
    };
    let svg = args.out_dir.join(format!("tracking-{name}.svg"));
    // Seeds run from 1: the plotted one's record, if it ran.
    let Some(plotted) = runs.get((args.plot_seed as usize).wrapping_sub(1)) else {
        return Ok(());
    };
    plot::write_svg(
        &svg,
        &format!("{} (seed {})", course.name, args.plot_seed),
        &plotted.plot,
    )?;
    println!("  plot: {}", svg.display());
    if args.trace {
        let csv = args.out_dir.join(format!("tracking-{name}.csv"));
        let mut text = String::from(TRACE_HEADER);
        for line in &plotted.trace {
            text.push_str(line);
            text.push('\n');
        }
        std::fs::write(&csv, text).map_err(|e| format!("{}: {e}", csv.display()))?;
        println!("  trace: {}", csv.display());
    }
    Ok(())
}

pub(crate) fn load_courses(paths: &[PathBuf]) -> Result<Vec<Course>, String> {
    let texts: Vec<(String, String)> = if paths.is_empty() {
        BUILT_IN.iter().map(|(n, t)| (n.to_string(), t.to_string())).collect()
    } else {
        paths
            .iter()
            .map(|p| {
                let text = std::fs::read_to_string(p).map_err(|e| format!("{}: {e}", p.display()))?;
                let name = p
                    .file_stem()
                    .map_or("course".into(), |s| s.to_string_lossy().into_owned());
                Ok((name, text))
            })
            .collect::<Result<_, String>>()?
    };
    texts
        .into_iter()
        .map(|(name, text)| {
            let items = mission::files::wpl::parse(&text).map_err(|e| format!("{name}: {e}"))?;
            let home = items
                .first()
                .filter(|i| i.x != 0 || i.y != 0)
                .map(|i| GeoPoint {
                    lat_deg: f64::from(i.x) * 1e-7,
                    lon_deg: f64::from(i.y) * 1e-7,
                    alt_m: f64::from(i.z),
                })
                .ok_or_else(|| format!("{name}: item 0 (home) has no position"))?;
            mission::validate_plan(MissionType::Mission, items.clone())
                .map_err(|(seq, why)| format!("{name}: item {seq} refused: {why:?}"))?;
            Ok(Course { name, items, home })
        })
        .collect()
}

/// The leg being driven, to notice a new one.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LegKey {
    seq: Option<u16>,
    from: Option<Ned>,
    point: Ned,
}

const TRACE_HEADER: &str = "t_s,seq,piece,class,true_xtrack_mm,est_xtrack_mm,est_minus_true_along_mm,steer_deg,ff_deg,lat_err_mm,yaw_err_deg,speed_cmd_mps,true_speed_mps,true_steer_deg,capturing,est_speed_mps,true_to_go_mm,est_to_go_mm,stopping\n";

struct RunOptions<'a> {
    seed: u64,
    model: ModelKind,
    heading_deg: f64,
    timeout_s: f64,
    keep_plot: bool,
    trace: bool,
    params: &'a [(String, f64)],
}

/// Where a run is on its course, by the truth: the leg and path piece
/// being driven, the distance driven, where the last turn ended, and the
/// current stop's settling.
#[derive(Default)]
struct CourseProgress {
    leg: Option<LegKey>,
    piece: usize,
    last_pos: Option<Ned>,
    odometer_m: f64,
    turn_end_odometer_m: f64,
    last_heading: Option<f64>,
    settle: SettleWatch,
    /// The last mission stop's leg and its settling, for a stop report that
    /// comes on the tick the navigator has already moved on (to a retry).
    stop_leg: Option<(NavTarget, LegPath, SettleWatch)>,
}

impl CourseProgress {
    fn drive_to(&mut self, position: Ned) {
        if let Some(last) = self.last_pos {
            self.odometer_m += last.distance_to(&position);
        }
        self.last_pos = Some(position);
    }

    /// Starts on the leg `key` if it is a new one; true if it is.
    fn enter_leg(&mut self, key: LegKey, path: &LegPath) -> bool {
        if self.leg == Some(key) {
            return false;
        }
        if let Some((target, _, settle)) = self.stop_leg.as_mut()
            && self.leg.is_some_and(|leg| leg.seq == target.seq)
        {
            *settle = self.settle;
        }
        self.leg = Some(key);
        self.piece = 0;
        self.settle = SettleWatch::default();
        // A leg that starts with a change of heading and no arc is a
        // turn too (a corner too tight for an arc).
        let start_heading = path.heading_at(0.0);
        if self
            .last_heading
            .is_some_and(|h| wrap_pi(h - start_heading).abs() > 1f64.to_radians())
            && !matches!(path.pieces()[0], Piece::Arc(_))
        {
            self.turn_end_odometer_m = self.odometer_m;
        }
        true
    }

    /// The true position projected onto the leg's path, and whether it is
    /// on an arc (where a turn's end moves on).
    fn project(&mut self, path: &LegPath, position: Ned) -> (PathProjection, bool) {
        let projection = path.project(&position, self.piece);
        self.piece = projection.piece;
        self.last_heading = Some(path.heading_at(path.end_m()));
        let on_arc = matches!(path.pieces()[self.piece], Piece::Arc(_));
        if on_arc {
            self.turn_end_odometer_m = self.odometer_m;
        }
        (projection, on_arc)
    }
}

/// What one tick saw of the leg being driven, by the truth.
struct LegSample<'a> {
    target: NavTarget,
    path: &'a LegPath,
    piece: usize,
    position: Ned,
    yaw_rad: f64,
    along_m: f64,
    crosstrack_m: f64,
}

fn run_course(course: &Course, options: &RunOptions<'_>) -> RunRecord {
    let (mut sim, mut timer) = start_course(course, options.seed, options.model, options.heading_deg, options.params);
    let (keep_plot, trace) = (options.keep_plot, options.trace);
    let start_s = sim.time().as_secs_f64();

    let mut record = RunRecord::default();
    let mut progress = CourseProgress::default();
    let mut ticks = 0u64;
    while sim.time().as_secs_f64() - start_s < options.timeout_s {
        let texts = crate::status_texts(sim.step(Duration::ZERO, &mut timer));
        ticks += 1;
        let core = sim.core();
        let Some(frame) = core.estimator().frame().copied() else {
            continue;
        };
        let truth = *sim.world().truth();
        let position = true_local(&sim, &frame, truth.north_m, truth.east_m);
        let yaw = wrap_pi(truth.yaw_rad + frame_rotation(&sim, &frame));
        progress.drive_to(position);

        let nav = core.navigator();
        let (Some(target), Some(path)) = (nav.target().copied(), nav.path()) else {
            if core.mission_state() == ExecState::Complete {
                record.completion_s = Some(sim.time().as_secs_f64() - start_s);
                break;
            }
            continue;
        };
        enter_leg(&mut progress, &mut record, nav, keep_plot);
        let (projection, on_arc) = progress.project(path, position);
        let error = projection.crosstrack_m;
        // Only while the vehicle drives the leg (not resting at a stop).
        let moving = truth.speed_mps.abs() > 0.01;
        let reverse = target.direction == Direction::Reverse;
        let after_turn = progress.odometer_m - progress.turn_end_odometer_m >= AFTER_TURN_M;
        let lateral = LateralSample {
            true_m: error,
            estimate_m: core.navigator().status().crosstrack_m,
        };
        let class = classify_error(&mut record, moving, on_arc, after_turn, reverse, lateral);
        let sample = LegSample {
            target,
            path,
            piece: progress.piece,
            position,
            yaw_rad: yaw,
            along_m: projection.along_m,
            crosstrack_m: error,
        };
        if trace {
            record.trace.push(trace_row(&sim, &sample, class));
        }
        if keep_plot && ticks.is_multiple_of(5) {
            record.plot.add_sample(position, progress.odometer_m, error, class);
        }

        let to_go_m = (path.end_m() - projection.along_m).hypot(error);
        if target.stop {
            progress
                .settle
                .update(sim.time().as_secs_f64(), to_go_m, truth.speed_mps);
        }
        record
            .stops
            .extend(stop_reports(&sim, &progress, &sample, &texts, options.seed));
        if core.mission_state() == ExecState::Complete && core.navigator().target().is_none() {
            record.completion_s = Some(sim.time().as_secs_f64() - start_s);
            break;
        }
    }
    record.core_tick_overruns = sim.core().scheduler().tick_stats().overruns;
    record
}

/// Notes the leg being driven: a new one starts its piece count, its plot
/// and, for a numbered stop, the stop's settling watch.
fn enter_leg(progress: &mut CourseProgress, record: &mut RunRecord, nav: &Navigator, keep_plot: bool) {
    let (Some(target), Some(path)) = (nav.target().copied(), nav.path()) else {
        return;
    };
    let key = LegKey {
        seq: target.seq,
        from: nav.leg_start(),
        point: target.point,
    };
    let new_leg = progress.enter_leg(key, path);
    if new_leg && keep_plot {
        record.plot.add_leg(path);
    }
    if new_leg && target.stop && target.seq.is_some() {
        progress.stop_leg = Some((target, path.clone(), SettleWatch::default()));
    }
}

/// The "Stop #n" reports among this tick's texts, each measured against the
/// stop it names: one for a stop the navigator has just left (a retry has
/// taken over) against that stop's leg, else against the leg driven now.
fn stop_reports(
    sim: &Simulation,
    progress: &CourseProgress,
    sample: &LegSample<'_>,
    texts: &[String],
    seed: u64,
) -> Vec<StopRecord> {
    let target = sample.target;
    texts
        .iter()
        .filter(|t| t.starts_with("Stop"))
        .map(|text| match &progress.stop_leg {
            Some((stop_target, stop_path, settle))
                if reported_seq(text).is_some_and(|seq| Some(seq) != target.seq && Some(seq) == stop_target.seq) =>
            {
                let last_piece = stop_path.pieces().len() - 1;
                let projection = stop_path.project(&sample.position, last_piece);
                let left = LegSample {
                    target: *stop_target,
                    path: stop_path,
                    piece: projection.piece,
                    position: sample.position,
                    yaw_rad: sample.yaw_rad,
                    along_m: projection.along_m,
                    crosstrack_m: projection.crosstrack_m,
                };
                stop_record(sim, &left, text, settle, seed)
            }
            _ => stop_record(sim, sample, text, &progress.settle, seed),
        })
        .collect()
}

/// One row of the tick-by-tick trace ([`TRACE_HEADER`]).
fn trace_row(sim: &Simulation, sample: &LegSample<'_>, class: plot::Class) -> String {
    let LegSample {
        target,
        path,
        piece,
        position,
        crosstrack_m: error,
        ..
    } = *sample;
    let core = sim.core();
    let truth = sim.world().truth();
    let st = core.navigator().status();
    let est = core.estimator().estimate().position;
    let along_true = path.project(&position, piece).along_m;
    let along_est = path.project(&est, piece).along_m;
    format!(
        "{:.2},{},{},{:?},{:.1},{:.1},{:.1},{:.3},{:.3},{:.1},{:.4},{:.3},{:.3},{:.3},{},{:.4},{:.1},{:.1},{}",
        sim.time().as_secs_f64(),
        target.seq.unwrap_or(0),
        piece,
        class,
        error * 1000.0,
        st.crosstrack_m * 1000.0,
        (along_est - along_true) * 1000.0,
        st.tracker.steer_rad.to_degrees(),
        st.tracker.feedforward_rad.to_degrees(),
        st.tracker.lateral_error_m * 1000.0,
        st.tracker.yaw_error_rad.to_degrees(),
        st.speed.speed_mps,
        truth.speed_mps,
        truth.steer_rad.to_degrees(),
        st.tracker.capturing as u8,
        core.estimator().estimate().speed_mps,
        (path.end_m() - along_true) * 1000.0,
        st.remaining_m * 1000.0,
        core.navigator().stopping() as u8,
    )
}

/// A stop, by the truth, when the autopilot reported it (`text`, whose
/// figures are kept beside the truth's).
fn stop_record(sim: &Simulation, sample: &LegSample<'_>, text: &str, settle: &SettleWatch, seed: u64) -> StopRecord {
    let LegSample {
        target,
        path,
        position,
        yaw_rad: yaw,
        along_m,
        crosstrack_m: error,
        ..
    } = *sample;
    let core = sim.core();
    let (reported_mm, reported_yaw_deg) = parse_reported(text).unwrap_or((f64::NAN, f64::NAN));
    let flip = if target.direction == Direction::Reverse {
        std::f64::consts::PI
    } else {
        0.0
    };
    let along = path.end_m() - along_m;
    StopRecord {
        seq: target.seq.unwrap_or(0),
        position_m: along.hypot(error),
        along_m: along,
        crosstrack_m: error,
        yaw_rad: wrap_pi(yaw - path.heading_at(path.end_m()) - flip),
        reported_mm,
        reported_yaw_deg,
        estimate_error_m: core.estimator().estimate().position.distance_to(&position),
        estimate_yaw_error_rad: wrap_pi(core.estimator().estimate().yaw_rad - yaw),
        settle_s: settle.within_since_s.map(|t| sim.time().as_secs_f64() - t),
        creep_s: settle.within_since_s.zip(settle.first_rest_s).map(|(a, b)| b - a),
        restarts: settle.restarts,
        direction: target.direction,
        seed,
    }
}

/// The simulation for one run, the plan loaded, settled for 5 s on its
/// first fixes (as an operator would wait) and then set to AUTO and armed.
fn start_course(
    course: &Course,
    seed: u64,
    model: ModelKind,
    heading_deg: f64,
    params: &[(String, f64)],
) -> (Simulation, InstantTimer) {
    let config = SimulationConfig {
        home: course.home,
        home_heading_deg: heading_deg,
        model,
        seed,
        ..SimulationConfig::default()
    };
    let mut sim_params = SimulationParams::new(config.model);
    sim_params.apply(params).expect("checked before the runs");
    let mut sim = Simulation::new(&config, sim_params);
    sim.core_mut().load_plan(
        MissionType::Mission,
        Plan::new(MissionType::Mission, course.items.clone()),
    );
    let mut timer = InstantTimer::default();
    crate::warm_up_and_arm(&mut sim, &mut timer, 5.0, 10);
    (sim, timer)
}

/// Files a cross-track sample under the part of the path it was taken on
/// (only while moving; straights within AFTER_TURN_M after a turn apart)
/// and returns its plot class.
fn classify_error(
    record: &mut RunRecord,
    moving: bool,
    on_arc: bool,
    after_turn: bool,
    reverse: bool,
    error: LateralSample,
) -> plot::Class {
    if !moving {
        plot::Class::Other
    } else if on_arc {
        record.arc_m.push(error);
        if reverse {
            record.reverse_arc_m.push(error);
        } else {
            record.forward_arc_m.push(error);
        }
        plot::Class::Arc
    } else if after_turn {
        record.straight_m.push(error);
        if reverse {
            record.reverse_straight_m.push(error);
        } else {
            record.forward_straight_m.push(error);
        }
        plot::Class::Straight
    } else {
        record.turn_exit_m.push(error);
        plot::Class::Other
    }
}

/// The simulator's point in the autopilot's frame, through WGS-84.
pub(crate) fn true_local(sim: &Simulation, frame: &LocalFrame, north_m: f64, east_m: f64) -> Ned {
    let g = sim.world().local_to_geodetic(north_m, east_m);
    frame.to_local(&g)
}

/// How much the autopilot's north axis is turned from the simulator's at
/// the vehicle (zero for the same tangent plane; a projection's grid
/// convergence otherwise).
fn frame_rotation(sim: &Simulation, frame: &LocalFrame) -> f64 {
    let truth = sim.world().truth();
    let a = true_local(sim, frame, truth.north_m, truth.east_m);
    let b = true_local(sim, frame, truth.north_m + 10.0, truth.east_m);
    a.bearing_to(&b)
}

/// "Stop #8: 3.2 mm, …" → 8 (None for a stop with no mission item).
fn reported_seq(text: &str) -> Option<u16> {
    text.strip_prefix("Stop #")?.split(':').next()?.trim().parse().ok()
}

/// "Stop #8: 3.2 mm, yaw 0.010 deg, …" → (3.2, 0.010).
fn parse_reported(text: &str) -> Option<(f64, f64)> {
    let rest = text.split(": ").nth(1)?;
    let mm = rest.split(" mm").next()?.trim().parse().ok()?;
    let yaw = rest.split("yaw ").nth(1)?.split(" deg").next()?.trim().parse().ok()?;
    Some((mm, yaw))
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * (sorted.len() - 1) as f64).round() as usize;
    sorted[rank.min(sorted.len() - 1)]
}

/// RMS, p95, p99, max of |error|, in mm.
fn error_figures(errors: impl Iterator<Item = f64>) -> Option<(f64, f64, f64, f64)> {
    let mut abs: Vec<f64> = errors.map(f64::abs).collect();
    if abs.is_empty() {
        return None;
    }
    abs.sort_by(f64::total_cmp);
    let rms = (abs.iter().map(|e| e * e).sum::<f64>() / abs.len() as f64).sqrt();
    Some((
        rms * 1000.0,
        quantile(&abs, 0.95) * 1000.0,
        quantile(&abs, 0.99) * 1000.0,
        abs[abs.len() - 1] * 1000.0,
    ))
}

fn report(course: &Course, runs: &[RunRecord], wall: Duration) {
    let seeds = runs.len();
    println!();
    println!("## {} ({} seeds, {:.1} s wall)", course.name, seeds, wall.as_secs_f64());
    println!();
    report_lateral(runs);
    println!();

    report_stops(runs);
    report_completion(runs, seeds);
    let overruns: u64 = runs.iter().map(|r| r.core_tick_overruns).sum();
    println!("core tick overruns: {overruns}");
}

/// The columns of a lateral error table: the truth's figures, then where
/// they come from. "Steering" is the error the autopilot sees and steers
/// out (its estimate's offset from the path); "estimate" is the estimate's
/// own error across the path (estimate − truth), which no steering can
/// remove.
const LATERAL_COLUMNS: &str = "| samples | RMS mm | p95 mm | p99 mm | max mm | steering p99 mm | estimate error p99 mm |\n|---|---:|---:|---:|---:|---:|---:|---:|";

/// One row of a lateral error table ([`LATERAL_COLUMNS`]).
fn print_lateral_row(label: &str, samples: &[LateralSample]) {
    let figures = error_figures(samples.iter().map(|s| s.true_m));
    let p99 = |pick: fn(&LateralSample) -> f64| error_figures(samples.iter().map(pick)).map_or(f64::NAN, |f| f.2);
    match figures {
        Some((rms, p95, p99_true, max)) => println!(
            "| {label} | {} | {rms:.1} | {p95:.1} | {p99_true:.1} | {max:.1} | {:.1} | {:.1} |",
            samples.len(),
            p99(|s| s.estimate_m),
            p99(|s| s.estimate_m - s.true_m),
        ),
        None => println!("| {label} | 0 | – | – | – | – | – | – |"),
    }
}

type PickLateral = fn(&RunRecord) -> &Vec<LateralSample>;

/// The lateral error table: straights (after a turn) and arcs.
fn report_lateral(runs: &[RunRecord]) {
    println!("| lateral error (true pose) {LATERAL_COLUMNS}");
    let rows: [(&str, PickLateral); 3] = [
        ("straights (≥ 3 m after a turn)", |r| &r.straight_m),
        ("arcs", |r| &r.arc_m),
        ("straights, first 3 m after a turn", |r| &r.turn_exit_m),
    ];
    for (label, pick) in rows {
        let samples: Vec<LateralSample> = runs.iter().flat_map(|r| pick(r).iter().copied()).collect();
        print_lateral_row(label, &samples);
    }
}

/// One row per stop item (position and yaw at rest, the autopilot's own
/// figures, the estimate's), then the share within tolerance.
fn report_stops(runs: &[RunRecord]) {
    let mut seqs: Vec<u16> = runs.iter().flat_map(|r| r.stops.iter().map(|s| s.seq)).collect();
    seqs.sort_unstable();
    seqs.dedup();
    let (tol_m, tol_deg) = (0.010, 0.05);
    if !seqs.is_empty() {
        println!(
            "| stop (item) | stops | within 10 mm & 0.05° | p95 mm | worst mm | worst along / across mm | p95 yaw ° | worst yaw ° | autopilot's own p95 mm / worst yaw ° | estimate error p95 mm / worst yaw ° |"
        );
        println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    }
    let mut all_within = 0;
    let mut all = 0;
    for seq in &seqs {
        let stops: Vec<&StopRecord> = runs
            .iter()
            .flat_map(|r| r.stops.iter().filter(|s| s.seq == *seq))
            .collect();
        let within = stops
            .iter()
            .filter(|s| s.position_m <= tol_m && s.yaw_rad.to_degrees().abs() <= tol_deg)
            .count();
        all_within += within;
        all += stops.len();
        let mut pos: Vec<f64> = stops.iter().map(|s| s.position_m * 1000.0).collect();
        pos.sort_by(f64::total_cmp);
        let mut yaw: Vec<f64> = stops.iter().map(|s| s.yaw_rad.to_degrees().abs()).collect();
        yaw.sort_by(f64::total_cmp);
        let mut own: Vec<f64> = stops.iter().map(|s| s.reported_mm).collect();
        own.sort_by(f64::total_cmp);
        let mut estimate: Vec<f64> = stops.iter().map(|s| s.estimate_error_m * 1000.0).collect();
        estimate.sort_by(f64::total_cmp);
        let worst = stops
            .iter()
            .max_by(|a, b| a.position_m.total_cmp(&b.position_m))
            .expect("a stop");
        println!(
            "| #{seq} | {} | {within} ({:.0} %) | {:.1} | {:.1} | {:.1} / {:.1} | {:.3} | {:.3} | {:.1} / {:.3} | {:.1} / {:.3} |",
            stops.len(),
            100.0 * within as f64 / stops.len() as f64,
            quantile(&pos, 0.95),
            pos[pos.len() - 1],
            worst.along_m * 1000.0,
            worst.crosstrack_m * 1000.0,
            quantile(&yaw, 0.95),
            yaw[yaw.len() - 1],
            quantile(&own, 0.95),
            stops.iter().map(|s| s.reported_yaw_deg.abs()).fold(0.0, f64::max),
            quantile(&estimate, 0.95),
            stops
                .iter()
                .map(|s| s.estimate_yaw_error_rad.to_degrees().abs())
                .fold(0.0, f64::max),
        );
    }
    if all > 0 {
        println!();
        println!(
            "stops within 10 mm and 0.05°: {all_within} of {all} ({:.1} %)",
            100.0 * all_within as f64 / all as f64
        );
    }
}

/// How long the runs took to finish, and how many did not.
fn report_completion(runs: &[RunRecord], seeds: usize) {
    let mut times: Vec<f64> = runs.iter().filter_map(|r| r.completion_s).collect();
    times.sort_by(f64::total_cmp);
    let failed = seeds - times.len();
    if times.is_empty() {
        println!("completion: no run finished");
    } else {
        println!(
            "completion time: median {:.1} s (min {:.1}, max {:.1}){}",
            quantile(&times, 0.5),
            times[0],
            times[times.len() - 1],
            if failed > 0 {
                format!(", {failed} runs did NOT finish")
            } else {
                String::new()
            }
        );
    }
}

/// Cross-track error by the direction each leg is driven in (the main table
/// mixes both).
fn report_directions(runs: &[RunRecord]) {
    println!();
    println!("| lateral error by direction (true pose) {LATERAL_COLUMNS}");
    let rows: [(&str, PickLateral); 4] = [
        ("straights forward", |r| &r.forward_straight_m),
        ("straights reverse", |r| &r.reverse_straight_m),
        ("arcs forward", |r| &r.forward_arc_m),
        ("arcs reverse", |r| &r.reverse_arc_m),
    ];
    for (label, pick) in rows {
        let samples: Vec<LateralSample> = runs.iter().flat_map(|r| pick(r).iter().copied()).collect();
        print_lateral_row(label, &samples);
    }
}

/// How long stops take to settle: from first coming within 30 mm of the
/// point (true pose) to the stop report, by direction of the approach; and
/// where it goes: the final creep to first rest, and the re-approaches.
fn report_settling(runs: &[RunRecord]) {
    println!();
    println!(
        "| stop settling (within 30 mm → report) | stops | median s | p95 s | max s | worst stop | never within 30 mm | creep to first rest median / max s | re-approached stops (moves) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (label, direction) in [("forward", Direction::Forward), ("reverse", Direction::Reverse)] {
        let stops: Vec<&StopRecord> = runs
            .iter()
            .flat_map(|r| r.stops.iter())
            .filter(|s| s.direction == direction)
            .collect();
        let never = stops.iter().filter(|s| s.settle_s.is_none()).count();
        let mut times: Vec<(f64, u16)> = stops.iter().filter_map(|s| s.settle_s.map(|t| (t, s.seq))).collect();
        times.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(&(max_s, worst_seq)) = times.last() else {
            println!("| {label} | {} | – | – | – | – | {never} | – | – |", stops.len());
            continue;
        };
        let seconds: Vec<f64> = times.iter().map(|t| t.0).collect();
        let mut creep: Vec<f64> = stops.iter().filter_map(|s| s.creep_s).collect();
        creep.sort_by(f64::total_cmp);
        let reapproached = stops.iter().filter(|s| s.restarts > 0).count();
        let moves: u32 = stops.iter().map(|s| s.restarts).sum();
        println!(
            "| {label} | {} | {:.1} | {:.1} | {max_s:.1} | #{worst_seq} | {never} | {:.1} / {:.1} | {reapproached} ({moves}) |",
            stops.len(),
            quantile(&seconds, 0.5),
            quantile(&seconds, 0.95),
            quantile(&creep, 0.5),
            creep.last().copied().unwrap_or(f64::NAN),
        );
    }
    report_slow_stops(runs);
    report_stray_stops(runs);
}

/// Stops reported on a leg without a mission item (item 0 in the stop
/// table: a stop the course does not ask for, such as a hold), one line
/// each, so the run can be replayed.
fn report_stray_stops(runs: &[RunRecord]) {
    let stray: Vec<&StopRecord> = runs
        .iter()
        .flat_map(|r| r.stops.iter())
        .filter(|s| s.seq == 0)
        .collect();
    if stray.is_empty() {
        return;
    }
    println!();
    println!("stops on a leg that is no mission item:");
    for s in stray {
        println!(
            "- seed {} ({:?}): true stop {:.1} mm from the leg's end, the autopilot's own {:.1} mm",
            s.seed,
            s.direction,
            s.position_m * 1000.0,
            s.reported_mm
        );
    }
}

/// The stops that took longer than [`SETTLE_TARGET_S`] to settle, one line
/// each, with where their time went.
fn report_slow_stops(runs: &[RunRecord]) {
    let slow: Vec<&StopRecord> = runs
        .iter()
        .flat_map(|r| r.stops.iter())
        .filter(|s| s.settle_s.is_some_and(|t| t > SETTLE_TARGET_S))
        .collect();
    if slow.is_empty() {
        return;
    }
    println!();
    println!("stops that took longer than {SETTLE_TARGET_S:.0} s to settle:");
    for s in slow {
        println!(
            "- seed {} #{} ({:?}): {:.1} s, creep to first rest {:.1} s, {} re-approaches, true stop {:.1} mm",
            s.seed,
            s.seq,
            s.direction,
            s.settle_s.unwrap_or(f64::NAN),
            s.creep_s.unwrap_or(f64::NAN),
            s.restarts,
            s.position_m * 1000.0
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reported_stop_error_is_parsed() {
        assert_eq!(
            parse_reported("Stop #8: 3.2 mm, yaw 0.010 deg, in tolerance"),
            Some((3.2, 0.01))
        );
        assert_eq!(
            parse_reported("Stop: 12.0 mm, yaw -0.1 deg, OUT of tolerance"),
            Some((12.0, -0.1))
        );
        assert_eq!(reported_seq("Stop #19: 4.0 mm, yaw 0.010 deg, in tolerance"), Some(19));
        assert_eq!(reported_seq("Stop: 12.0 mm, yaw -0.1 deg, OUT of tolerance"), None);
    }

    #[test]
    fn built_in_courses_load() {
        let courses = load_courses(&[]).unwrap();
        assert_eq!(courses.len(), 2);
        assert_eq!(courses[0].items.len(), 26);
        assert!((courses[0].home.lat_deg - 29.133).abs() < 1e-9);
    }

    /// The whole measurement on one short run: the AGV course finishes and
    /// every precision stop is seen.
    #[test]
    fn one_agv_course_run_finishes_with_its_stops() {
        let courses = load_courses(&[]).unwrap();
        let record = run_course(
            &courses[0],
            &RunOptions {
                seed: 1,
                model: ModelKind::Ackermann,
                heading_deg: 0.0,
                timeout_s: 900.0,
                keep_plot: false,
                trace: false,
                params: &[],
            },
        );
        assert!(record.completion_s.is_some());
        let seqs: Vec<u16> = record.stops.iter().map(|s| s.seq).collect();
        assert_eq!(seqs, vec![4, 8, 15, 19, 25], "direction changes, pickup, release, end");
        assert!(!record.straight_m.is_empty() && !record.arc_m.is_empty());
        // The course drives legs both ways, and every stop came within 30 mm.
        assert!(!record.reverse_straight_m.is_empty() && !record.forward_straight_m.is_empty());
        assert_eq!(
            record.forward_straight_m.len() + record.reverse_straight_m.len(),
            record.straight_m.len()
        );
        assert!(record.stops.iter().all(|s| s.settle_s.is_some_and(|t| t >= 0.0)));
    }
}
