//! `furrow logs list|summary|csv|plot`: the onboard DataFlash logs, offline
//! (a data directory's `logs/` folder, or a `.BIN` downloaded from a
//! vehicle).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::plot::{Class, Labels, PlotData, write_svg};
use crate::geo::{GeoPoint, LocalFrame, Ned};
use crate::logging::reader::{DataFlashLog, Message};
use crate::logging::store::LogStore;

#[derive(clap::Args, Debug)]
pub struct LogsArgs {
    #[command(subcommand)]
    pub action: LogsAction,
}

#[derive(clap::Subcommand, Debug)]
pub enum LogsAction {
    /// Lists the logs of a data directory (logs/NNNNNNNN.BIN): number, size, time, duration.
    List {
        /// The data directory (as given to `furrow sitl --data-dir`).
        #[arg(long, default_value = "furrow-data")]
        data_dir: PathBuf,
    },
    /// Prints what a log holds: duration, modes, arming, mission, distance, cross-track, stops, errors, messages.
    Summary { file: PathBuf },
    /// Writes one message type of a log as CSV (TimeUS and the fields, in units).
    Csv {
        file: PathBuf,
        /// The message type (NTUN, POS, GPS, …).
        #[arg(long = "type", value_name = "NAME")]
        message: String,
        /// Where to write (default: standard output).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Draws the course and the cross-track error along it as an SVG.
    Plot {
        file: PathBuf,
        /// The course on a map and NTUN's cross-track error along the distance driven.
        #[arg(long)]
        xtrack: bool,
        /// The SVG to write (default: FILE with .svg).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

pub fn run(args: &LogsArgs) -> Result<(), String> {
    match &args.action {
        LogsAction::List { data_dir } => {
            print!("{}", list(data_dir));
            Ok(())
        }
        LogsAction::Summary { file } => {
            print!("{}", summary(&DataFlashLog::read(file)?));
            Ok(())
        }
        LogsAction::Csv { file, message, out } => {
            let text = csv(&DataFlashLog::read(file)?, message)?;
            match out {
                Some(path) => std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display())),
                None => {
                    print!("{text}");
                    Ok(())
                }
            }
        }
        LogsAction::Plot { file, xtrack, out } => {
            if !xtrack {
                return Err("say what to plot: --xtrack".into());
            }
            let out = out.clone().unwrap_or_else(|| file.with_extension("svg"));
            let title = file
                .file_name()
                .map_or("log".into(), |n| n.to_string_lossy().into_owned());
            write_svg(&out, &title, &xtrack_plot(&DataFlashLog::read(file)?)?)?;
            println!("{}", out.display());
            Ok(())
        }
    }
}

fn utc(unix_s: u64) -> String {
    i64::try_from(unix_s)
        .ok()
        .and_then(|s| chrono::DateTime::from_timestamp(s, 0))
        .map_or_else(|| "?".into(), |t| t.format("%Y-%m-%d %H:%M:%S UTC").to_string())
}

/// First and last TimeUS, seconds.
fn span_s(log: &DataFlashLog) -> Option<(f64, f64)> {
    let times = log.records.iter().filter_map(|r| {
        let f = &log.formats[&r.id];
        (f.labels.first().map(String::as_str) == Some("TimeUS")).then(|| r.fields[0].as_f64())?
    });
    times.fold(None, |acc, t| match acc {
        None => Some((t, t)),
        Some((a, b)) => Some((a.min(t), b.max(t))),
    })
}

fn list(data_dir: &Path) -> String {
    let store = LogStore::new(data_dir);
    let logs = store.list();
    if logs.is_empty() {
        return format!("no logs in {}\n", store.dir().display());
    }
    let mut text = String::new();
    for l in logs {
        let duration = std::fs::read(&l.path)
            .ok()
            .and_then(|b| span_s(&DataFlashLog::parse(&b)))
            .map_or("?".into(), |(a, b)| format!("{:.1} s", b - a));
        let _ = writeln!(
            text,
            "{:>5}  {:>10} bytes  {}  {:>9}  {}",
            l.number,
            l.size_bytes,
            utc(l.modified_unix_s),
            duration,
            l.path.display()
        );
    }
    text
}

/// The course in metres from the first position (TimeUS, position).
fn course(log: &DataFlashLog) -> Vec<(f64, Ned)> {
    let mut frame: Option<LocalFrame> = None;
    log.messages("POS")
        .filter_map(|m| {
            let p = GeoPoint::new(m.get("Lat")?, m.get("Lng")?, 0.0);
            let frame = frame.get_or_insert_with(|| LocalFrame::new(p));
            Some((m.get("TimeUS")?, frame.to_local(&p)))
        })
        .collect()
}

fn distance_m(course: &[(f64, Ned)]) -> f64 {
    course.windows(2).map(|w| w[0].1.distance_to(&w[1].1)).sum()
}

fn summary(log: &DataFlashLog) -> String {
    let mut s = String::new();
    let (t0, t1) = span_s(log).unwrap_or((0.0, 0.0));
    let _ = writeln!(s, "duration {:.1} s (boot {:.1} s to {:.1} s)", t1 - t0, t0, t1);
    write_modes_and_arming(&mut s, log);
    let _ = writeln!(
        s,
        "mission: {} items; {} parameters",
        log.messages("CMD").count(),
        log.messages("PARM").count()
    );
    let _ = writeln!(s, "distance driven {:.1} m", distance_m(&course(log)));
    write_cross_track(&mut s, log);
    write_stops_and_failsafes(&mut s, log);
    for m in log.messages("MSG") {
        let _ = writeln!(s, "{:>8.1} s  {}", when(&m), m.text("Message").unwrap_or(""));
    }
    let counts: Vec<String> = log.counts().iter().map(|(n, c)| format!("{n} {c}")).collect();
    let _ = writeln!(s, "records: {}", counts.join(", "));
    if log.skipped_bytes > 0 {
        let _ = writeln!(s, "skipped {} bytes that were not records", log.skipped_bytes);
    }
    s
}

/// A record's time since boot, 0 where it has none.
fn when(m: &Message) -> f64 {
    m.time_s().unwrap_or(0.0)
}

/// The mode changes (MODE) and arming events (EV), in log order.
fn write_modes_and_arming(s: &mut String, log: &DataFlashLog) {
    let modes: Vec<String> = log
        .messages("MODE")
        .map(|m| {
            let name = m
                .get("ModeNum")
                .and_then(|n| crate::modes::Mode::from_number(n as u32))
                .map_or("?", |mode| mode.name());
            format!("{name} at {:.1} s", when(&m))
        })
        .collect();
    let _ = writeln!(s, "modes: {}", modes.join(", "));
    let events: Vec<String> = log
        .messages("EV")
        .map(|m| match m.get("Id") {
            Some(10.0) => format!("armed at {:.1} s", when(&m)),
            Some(11.0) => format!("disarmed at {:.1} s", when(&m)),
            other => format!("event {other:?} at {:.1} s", when(&m)),
        })
        .collect();
    let _ = writeln!(
        s,
        "arming: {}",
        if events.is_empty() {
            "-".into()
        } else {
            events.join(", ")
        }
    );
}

/// The cross-track error's p95 and maximum over the NTUN records.
fn write_cross_track(s: &mut String, log: &DataFlashLog) {
    let mut xtrack: Vec<f64> = log
        .messages("NTUN")
        .filter_map(|m| m.get("XTrack"))
        .map(f64::abs)
        .collect();
    xtrack.sort_by(f64::total_cmp);
    if let Some(&worst) = xtrack.last() {
        let p95 = xtrack[(xtrack.len() - 1) * 95 / 100];
        let _ = writeln!(
            s,
            "cross-track (NTUN, {} samples): p95 {:.1} mm, max {:.1} mm",
            xtrack.len(),
            p95 * 1000.0,
            worst * 1000.0
        );
    }
}

/// Each precision stop (PSTP) and failsafe change (ERR).
fn write_stops_and_failsafes(s: &mut String, log: &DataFlashLog) {
    for m in log.messages("PSTP") {
        let _ = writeln!(
            s,
            "precision stop #{}: {:.1} mm, yaw {:.3} deg, {}",
            m.get("Seq").unwrap_or(-1.0),
            m.get("PosErr").unwrap_or(f64::NAN) * 1000.0,
            m.get("YawErr").unwrap_or(f64::NAN).to_degrees(),
            if m.get("Ok") == Some(1.0) {
                "in tolerance"
            } else {
                "OUT of tolerance"
            }
        );
    }
    for m in log.messages("ERR") {
        let _ = writeln!(
            s,
            "failsafe {} {} at {:.1} s",
            m.get("Subsys").unwrap_or(0.0),
            if m.get("ECode") == Some(1.0) {
                "raised"
            } else {
                "cleared"
            },
            when(&m)
        );
    }
}

/// A CSV quoted field (text with commas, quotes or line breaks).
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_owned()
    }
}

fn csv(log: &DataFlashLog, name: &str) -> Result<String, String> {
    let format = log.formats.values().find(|f| f.name == name).ok_or_else(|| {
        let names: Vec<&str> = log.counts().into_keys().collect();
        format!("no {name} records in this log; it has {}", names.join(", "))
    })?;
    let mut text = format.labels.join(",") + "\n";
    for m in log.messages(name) {
        let row: Vec<String> = m.fields.iter().map(|f| csv_field(&f.to_string())).collect();
        text += &row.join(",");
        text.push('\n');
    }
    Ok(text)
}

/// The course on a map with the mission's waypoints, and NTUN's
/// cross-track along the distance driven (turning: arcs; slow: stops).
fn xtrack_plot(log: &DataFlashLog) -> Result<PlotData, String> {
    let course = course(log);
    let Some(origin) = log.messages("POS").next() else {
        return Err("no positions (POS) in this log".into());
    };
    let frame = LocalFrame::new(GeoPoint::new(
        origin.get("Lat").unwrap_or(0.0),
        origin.get("Lng").unwrap_or(0.0),
        0.0,
    ));
    let mut data = PlotData::default();
    data.labels = Labels {
        track_caption: "mission waypoints and the logged course".into(),
        planned: "mission waypoints (straight between them)".into(),
        track: "course (POS, the vehicle's estimate)".into(),
        error_caption: "cross-track error (NTUN.XTrack, mm) along the distance driven".into(),
    };
    let waypoints: Vec<(f64, f64)> = log
        .messages("CMD")
        .filter(|m| m.get("CId") == Some(16.0) && m.get("CNum") != Some(0.0))
        .filter_map(|m| {
            let p = frame.to_local(&GeoPoint::new(m.get("Lat")?, m.get("Lng")?, 0.0));
            Some((p.east_m, p.north_m))
        })
        .collect();
    if !waypoints.is_empty() {
        data.add_leg_points(waypoints);
    }
    let turn_rate: BTreeMap<u64, f64> = keyed(log, "STER", "TurnRate");
    let speed: BTreeMap<u64, f64> = keyed(log, "THR", "Speed");
    let xtrack: BTreeMap<u64, f64> = keyed(log, "NTUN", "XTrack");
    let mut driven_m = 0.0;
    let mut last: Option<Ned> = None;
    for (t_us, p) in &course {
        driven_m += last.map_or(0.0, |l| l.distance_to(p));
        last = Some(*p);
        let key = *t_us as u64;
        let Some(&error_m) = xtrack.get(&key) else {
            continue;
        };
        let class = if speed.get(&key).is_some_and(|s| s.abs() < 0.05) {
            Class::Other
        } else if turn_rate.get(&key).is_some_and(|r| r.abs() > 2.0) {
            Class::Arc
        } else {
            Class::Straight
        };
        data.add_sample(*p, driven_m, error_m, class);
    }
    if xtrack.is_empty() {
        return Err("no cross-track (NTUN) in this log: was the vehicle navigating?".into());
    }
    Ok(data)
}

fn keyed(log: &DataFlashLog, name: &str, label: &str) -> BTreeMap<u64, f64> {
    log.messages(name)
        .filter_map(|m| Some((m.get("TimeUS")? as u64, m.get(label)?)))
        .collect()
}
