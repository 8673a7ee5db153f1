//! The tracking benchmark's plot (and `furrow-bench logs plot`'s): the
//! planned path and the driven track on a map, and the lateral error along
//! the distance driven, as an SVG (plotters' SVG backend: no font libraries
//! needed).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use autopilot::geo::Ned;
use autopilot::guidance::path::LegPath;

/// Which part of the course a sample belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    Straight,
    Arc,
    /// Turn transitions and resting at a stop: not in the figures.
    Other,
}

/// What the figure calls its series: the bench plots the truth, a log
/// the vehicle's own estimate.
#[derive(Clone, Debug)]
pub struct Labels {
    pub track_caption: String,
    pub planned: String,
    pub track: String,
    pub error_caption: String,
}

impl Default for Labels {
    fn default() -> Self {
        Labels {
            track_caption: "planned path and true track".into(),
            planned: "planned path (straights and corner arcs)".into(),
            track: "true track (rear axle)".into(),
            error_caption: "lateral error of the true pose (mm) along the distance driven".into(),
        }
    }
}

#[derive(Default)]
pub struct PlotData {
    pub labels: Labels,
    /// Each leg's planned path up to its end, (east, north).
    legs: Vec<Vec<(f64, f64)>>,
    /// The true track, (east, north).
    track: Vec<(f64, f64)>,
    /// (distance driven m, lateral error mm, class).
    errors: Vec<(f64, f64, Class)>,
}

impl PlotData {
    pub fn add_leg(&mut self, path: &LegPath) {
        let steps = (path.end_m() / 0.25).ceil().max(1.0) as usize;
        let points = (0..=steps)
            .map(|i| {
                let p = path.point_at(path.end_m() * i as f64 / steps as f64);
                (p.east_m, p.north_m)
            })
            .collect();
        self.legs.push(points);
    }

    /// A planned path given by its points (east, north).
    pub fn add_leg_points(&mut self, points: Vec<(f64, f64)>) {
        self.legs.push(points);
    }

    pub fn add_sample(&mut self, position: Ned, distance_m: f64, error_m: f64, class: Class) {
        self.track.push((position.east_m, position.north_m));
        self.errors.push((distance_m, error_m * 1000.0, class));
    }
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

pub fn write_svg(path: &Path, title: &str, data: &PlotData) -> Result<(), String> {
    draw(path, title, data).map_err(|e| format!("{}: {e}", path.display()))
}

fn draw(path: &Path, title: &str, data: &PlotData) -> Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::new(path, (1000, 1300)).into_drawing_area();
    root.fill(&WHITE)?;
    let (map_area, error_area) = root.split_vertically(900);
    draw_map(&map_area, title, data)?;
    draw_errors(&error_area, data)?;
    root.present()?;
    Ok(())
}

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// The map, with equal scales on both axes: the planned legs and the track.
fn draw_map(map_area: &Area, title: &str, data: &PlotData) -> Result<(), Box<dyn std::error::Error>> {
    let all = data.legs.iter().flatten().chain(data.track.iter());
    let (e0, e1) = range(all.clone().map(|p| p.0));
    let (n0, n1) = range(all.map(|p| p.1));
    if !(e0.is_finite() && n0.is_finite()) {
        return Err("nothing to plot".into());
    }
    let half = 0.5 * (e1 - e0).max(n1 - n0) + 5.0;
    let (ec, nc) = (0.5 * (e0 + e1), 0.5 * (n0 + n1));
    let mut map = ChartBuilder::on(map_area)
        .caption(format!("{title}: {}", data.labels.track_caption), ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(ec - half..ec + half, nc - half..nc + half)?;
    map.configure_mesh()
        .x_desc("east (m)")
        .y_desc("north (m)")
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (i, leg) in data.legs.iter().enumerate() {
        let series = map.draw_series(LineSeries::new(leg.iter().copied(), BLUE.stroke_width(3)))?;
        if i == 0 {
            series
                .label(data.labels.planned.as_str())
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(3)));
        }
    }
    map.draw_series(LineSeries::new(data.track.iter().copied(), RED.stroke_width(1)))?
        .label(data.labels.track.as_str())
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    map.configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// The lateral error along the way, coloured by the kind of path.
fn draw_errors(error_area: &Area, data: &PlotData) -> Result<(), Box<dyn std::error::Error>> {
    let (d0, d1) = range(data.errors.iter().map(|e| e.0));
    let limit = data
        .errors
        .iter()
        .filter(|e| e.2 != Class::Other)
        .map(|e| e.1.abs())
        .fold(10.0, f64::max)
        .min(200.0)
        * 1.1;
    let mut chart = ChartBuilder::on(error_area)
        .caption(data.labels.error_caption.as_str(), ("sans-serif", 18))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(d0..d1.max(d0 + 1.0), -limit..limit)?;
    chart
        .configure_mesh()
        .x_desc("distance driven (m)")
        .y_desc("mm")
        .draw()?;
    for (class, colour, label) in [
        (Class::Straight, BLUE, "straights"),
        (Class::Arc, GREEN, "arcs"),
        (Class::Other, RGBColor(160, 160, 160), "turn transitions, stops"),
    ] {
        chart
            .draw_series(
                data.errors
                    .iter()
                    .filter(|e| e.2 == class)
                    .map(|e| Circle::new((e.0, e.1.clamp(-limit, limit)), 1, colour.filled())),
            )?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, colour.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
