//! `furrow-bench logs plot FILE --xtrack`: an onboard DataFlash log's course
//! and cross-track as the tracking benchmark's SVG. Here, not in `furrow`,
//! so the shipping binary carries no plotting code; the log is read by the
//! autopilot's own reader (`furrow logs` lists, summarises and exports it).

use std::collections::BTreeMap;
use std::path::PathBuf;

use autopilot::geo::{GeoPoint, LocalFrame, Ned};
use autopilot::logging::reader::DataFlashLog;
use autopilot::offline::logs::course;

use crate::plot::{Class, Labels, PlotData, write_svg};

#[derive(clap::Args, Debug)]
pub struct LogsArgs {
    #[command(subcommand)]
    pub action: LogsAction,
}

#[derive(clap::Subcommand, Debug)]
pub enum LogsAction {
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
