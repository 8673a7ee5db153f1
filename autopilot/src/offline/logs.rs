//! `furrow logs list|summary|csv`: the onboard DataFlash logs, offline
//! (a data directory's `logs/` folder, or a `.BIN` downloaded from a
//! vehicle). Their plot is `furrow-bench logs plot`, which reads them
//! through [`DataFlashLog`] and [`course`] here.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
pub fn course(log: &DataFlashLog) -> Vec<(f64, Ned)> {
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
