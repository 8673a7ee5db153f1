//! World files: the SITL world's obstacles and magnetic tape in TOML
//! (format and examples: `tests/data/worlds/README.md`).
//!
//! Coordinates are `[north, east]` metres about home, angles in the file are
//! degrees (`yaw_deg`). Parsing is strict: unknown keys, keys that do not
//! belong to an entry's `kind`, non-finite numbers, numbers beyond
//! ±[`MAX_MAGNITUDE`] and impossible sizes are errors that name the key (`moving[2].speed_mps`) and its line.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::magnetic::{MagneticTape, TapeBuilder};
use super::obstacles::{MovingObstacle, ObstacleWorld, Shape};

/// A moving circle without `radius_m` is a person.
pub const PERSON_RADIUS_M: f64 = 0.25;
/// Largest magnitude of any number in a world file (metres, or degrees for
/// a yaw): a simulated site is far smaller, and beyond it the geometry's
/// squares and products lose every centimetre.
pub const MAX_MAGNITUDE: f64 = 100_000.0;

/// A parsed and checked world file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorldFile {
    pub statics: Vec<Shape>,
    pub movers: Vec<MovingObstacle>,
    pub tape: Option<MagneticTape>,
}

impl WorldFile {
    pub fn obstacles(&self) -> ObstacleWorld {
        ObstacleWorld::new(self.statics.clone(), self.movers.clone())
    }

    pub fn tape(&self) -> Option<MagneticTape> {
        self.tape.clone()
    }
}

/// What is wrong with a world file, and where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorldFileError {
    /// The file, when it was read from one.
    pub path: Option<PathBuf>,
    /// 1-based line of the offending key or value.
    pub line: Option<usize>,
    /// The offending key, e.g. `moving[2].speed_mps`; for syntax errors the
    /// best guess from the entry and the line.
    pub key: Option<String>,
    pub message: String,
}

impl fmt::Display for WorldFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(path) = &self.path {
            write!(f, "{}: ", path.display())?;
        }
        if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        if let Some(key) = &self.key {
            write!(f, "{key}: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for WorldFileError {}

/// Read and check the world file at `path`.
pub fn load_world_file(path: impl AsRef<Path>) -> Result<WorldFile, WorldFileError> {
    let path = path.as_ref();
    let in_file = |mut e: WorldFileError| {
        e.path = Some(path.to_owned());
        e
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        in_file(WorldFileError {
            path: None,
            line: None,
            key: None,
            message: format!("cannot read: {e}"),
        })
    })?;
    parse_world_file(&text).map_err(in_file)
}

/// Parse and check a world file's text.
pub fn parse_world_file(text: &str) -> Result<WorldFile, WorldFileError> {
    let raw: RawWorld = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
    let check = Checker { text };
    let statics = raw
        .statics
        .iter()
        .enumerate()
        .map(|(i, entry)| check.static_shape(i, entry))
        .collect::<Result<Vec<_>, _>>()?;
    let movers = raw
        .moving
        .iter()
        .enumerate()
        .map(|(i, entry)| check.mover(i, entry))
        .collect::<Result<Vec<_>, _>>()?;
    for (i, entry) in raw.moving.iter().enumerate() {
        if let Some(first) = movers[..i].iter().position(|m| m.name == movers[i].name) {
            return Err(check.error(
                format!("moving[{i}].name"),
                Some(entry.get_ref().name.span()),
                format!("`{}` is already the name of moving[{first}]", movers[i].name),
            ));
        }
    }
    let tape = raw.tape.as_ref().map(|t| check.tape(t)).transpose()?;
    Ok(WorldFile { statics, movers, tape })
}

type Point = [f64; 2];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    #[serde(rename = "static", default)]
    statics: Vec<Spanned<RawStatic>>,
    #[serde(default)]
    moving: Vec<Spanned<RawMoving>>,
    #[serde(default)]
    tape: Option<Spanned<RawTape>>,
}

/// Every key any static kind uses; which ones a kind allows is checked after.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStatic {
    kind: Spanned<String>,
    center: Option<Spanned<Point>>,
    radius_m: Option<Spanned<f64>>,
    length_m: Option<Spanned<f64>>,
    width_m: Option<Spanned<f64>>,
    yaw_deg: Option<Spanned<f64>>,
    points: Option<Spanned<Vec<Point>>>,
    from: Option<Spanned<Point>>,
    to: Option<Spanned<Point>>,
    thickness_m: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMoving {
    name: Spanned<String>,
    kind: Spanned<String>,
    radius_m: Option<Spanned<f64>>,
    length_m: Option<Spanned<f64>>,
    width_m: Option<Spanned<f64>>,
    yaw_deg: Option<Spanned<f64>>,
    path: Spanned<Vec<Point>>,
    speed_mps: Spanned<f64>,
    start_s: Option<Spanned<f64>>,
    #[serde(rename = "loop", default)]
    looped: bool,
    #[serde(default)]
    vanish_at_end: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTape {
    points: Spanned<Vec<Point>>,
    arc_radius_m: Option<Spanned<f64>>,
    width_m: Option<Spanned<f64>>,
}

/// What a number may be.
#[derive(Clone, Copy)]
enum Rule {
    Finite,
    Positive,
    NonNegative,
}

/// One `[[static]]` or `[[moving]]` entry being checked: where it is and what kind.
struct Entry<'a> {
    check: &'a Checker<'a>,
    name: &'a str,
    span: Range<usize>,
    kind: &'a str,
}

impl Entry<'_> {
    /// A key the entry's kind cannot do without.
    fn need<'v, T>(&self, key: &str, value: &'v Option<T>) -> Result<&'v T, WorldFileError> {
        value.as_ref().ok_or_else(|| {
            self.check.error(
                format!("{}.{key}", self.name),
                Some(self.span.clone()),
                format!("a {} needs `{key}`", self.kind),
            )
        })
    }
}

/// Turns raw entries into checked ones, with errors pointing into `text`.
struct Checker<'a> {
    text: &'a str,
}

impl Checker<'_> {
    fn error(&self, key: String, span: Option<Range<usize>>, message: String) -> WorldFileError {
        WorldFileError {
            path: None,
            line: span.map(|s| toml_report::place(self.text, s.start).line),
            key: Some(key),
            message,
        }
    }

    fn number(&self, key: String, value: &Spanned<f64>, rule: Rule) -> Result<f64, WorldFileError> {
        let v = *value.get_ref();
        let bounded = v.abs() <= MAX_MAGNITUDE;
        let (ok, wanted) = match rule {
            Rule::Finite => (bounded, "a finite number within ±100 000"),
            Rule::Positive => (bounded && v > 0.0, "a finite number > 0 and ≤ 100 000"),
            Rule::NonNegative => (bounded && v >= 0.0, "a finite number ≥ 0 and ≤ 100 000"),
        };
        if ok {
            Ok(v)
        } else {
            Err(self.error(key, Some(value.span()), format!("must be {wanted}, not {v}")))
        }
    }

    fn point(&self, key: String, value: &Spanned<Point>) -> Result<Point, WorldFileError> {
        let p = *value.get_ref();
        if p.iter().all(|v| v.abs() <= MAX_MAGNITUDE) {
            Ok(p)
        } else {
            Err(self.error(
                key,
                Some(value.span()),
                format!("{p:?} is not a finite point within ±100 km"),
            ))
        }
    }

    fn points(&self, key: String, value: &Spanned<Vec<Point>>, at_least: usize) -> Result<Vec<Point>, WorldFileError> {
        let points = value.get_ref();
        if points.len() < at_least {
            let message = format!("needs at least {at_least} points [north, east], has {}", points.len());
            return Err(self.error(key, Some(value.span()), message));
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.abs() <= MAX_MAGNITUDE)) {
            let message = format!("point {i} {:?} is not finite and within ±100 km", points[i]);
            return Err(self.error(key, Some(value.span()), message));
        }
        Ok(points.clone())
    }

    /// Refuse keys that the entry's kind does not use: a stray `radius_m` on
    /// a box is a mistake, not something to ignore.
    fn only(
        &self,
        entry: &str,
        kind: &str,
        allowed: &[&str],
        present: &[(&str, Option<Range<usize>>)],
    ) -> Result<(), WorldFileError> {
        for (name, span) in present {
            if let Some(span) = span
                && !allowed.contains(name)
            {
                let message = format!("not a key of a {kind} (its keys: {})", allowed.join(", "));
                return Err(self.error(format!("{entry}.{name}"), Some(span.clone()), message));
            }
        }
        Ok(())
    }

    fn static_shape(&self, index: usize, spanned: &Spanned<RawStatic>) -> Result<Shape, WorldFileError> {
        let entry = format!("static[{index}]");
        let raw = spanned.get_ref();
        let at = spanned.span();
        let key = |name: &str| format!("{entry}.{name}");
        let kind = raw.kind.get_ref().as_str();
        let present = [
            ("center", raw.center.as_ref().map(Spanned::span)),
            ("radius_m", raw.radius_m.as_ref().map(Spanned::span)),
            ("length_m", raw.length_m.as_ref().map(Spanned::span)),
            ("width_m", raw.width_m.as_ref().map(Spanned::span)),
            ("yaw_deg", raw.yaw_deg.as_ref().map(Spanned::span)),
            ("points", raw.points.as_ref().map(Spanned::span)),
            ("from", raw.from.as_ref().map(Spanned::span)),
            ("to", raw.to.as_ref().map(Spanned::span)),
            ("thickness_m", raw.thickness_m.as_ref().map(Spanned::span)),
        ];
        let at = Entry {
            check: self,
            name: &entry,
            span: at,
            kind,
        };
        match kind {
            "circle" => {
                self.only(&entry, kind, &["center", "radius_m"], &present)?;
                Ok(Shape::Circle {
                    center: self.point(key("center"), at.need("center", &raw.center)?)?,
                    radius_m: self.number(key("radius_m"), at.need("radius_m", &raw.radius_m)?, Rule::Positive)?,
                })
            }
            "box" => {
                self.only(&entry, kind, &["center", "length_m", "width_m", "yaw_deg"], &present)?;
                Ok(Shape::Box {
                    center: self.point(key("center"), at.need("center", &raw.center)?)?,
                    length_m: self.number(key("length_m"), at.need("length_m", &raw.length_m)?, Rule::Positive)?,
                    width_m: self.number(key("width_m"), at.need("width_m", &raw.width_m)?, Rule::Positive)?,
                    yaw_rad: self.yaw_rad(key("yaw_deg"), &raw.yaw_deg)?,
                })
            }
            "polygon" => {
                self.only(&entry, kind, &["points"], &present)?;
                Ok(Shape::Polygon {
                    points: self.points(key("points"), at.need("points", &raw.points)?, 3)?,
                })
            }
            "wall" => {
                self.only(&entry, kind, &["from", "to", "thickness_m"], &present)?;
                let from = self.point(key("from"), at.need("from", &raw.from)?)?;
                let to_value = at.need("to", &raw.to)?;
                let to = self.point(key("to"), to_value)?;
                if from == to {
                    let message = "a wall needs two different end points".to_owned();
                    return Err(self.error(key("to"), Some(to_value.span()), message));
                }
                let thickness = at.need("thickness_m", &raw.thickness_m)?;
                Ok(Shape::Wall {
                    from,
                    to,
                    thickness_m: self.number(key("thickness_m"), thickness, Rule::NonNegative)?,
                })
            }
            other => Err(self.error(
                key("kind"),
                Some(raw.kind.span()),
                format!("unknown kind `{other}` (box, circle, polygon or wall)"),
            )),
        }
    }

    fn yaw_rad(&self, key: String, value: &Option<Spanned<f64>>) -> Result<f64, WorldFileError> {
        value
            .as_ref()
            .map_or(Ok(0.0), |v| self.number(key, v, Rule::Finite).map(f64::to_radians))
    }

    fn mover(&self, index: usize, spanned: &Spanned<RawMoving>) -> Result<MovingObstacle, WorldFileError> {
        let entry = format!("moving[{index}]");
        let raw = spanned.get_ref();
        let at = spanned.span();
        let key = |name: &str| format!("{entry}.{name}");
        let kind = raw.kind.get_ref().as_str();
        let present = [
            ("radius_m", raw.radius_m.as_ref().map(Spanned::span)),
            ("length_m", raw.length_m.as_ref().map(Spanned::span)),
            ("width_m", raw.width_m.as_ref().map(Spanned::span)),
            ("yaw_deg", raw.yaw_deg.as_ref().map(Spanned::span)),
        ];
        let at = Entry {
            check: self,
            name: &entry,
            span: at,
            kind,
        };
        let shape = match kind {
            "circle" => {
                self.only(&entry, kind, &["radius_m"], &present)?;
                let radius_m = match &raw.radius_m {
                    Some(r) => self.number(key("radius_m"), r, Rule::Positive)?,
                    None => PERSON_RADIUS_M,
                };
                Shape::Circle {
                    center: [0.0, 0.0],
                    radius_m,
                }
            }
            "box" => {
                self.only(&entry, kind, &["length_m", "width_m", "yaw_deg"], &present)?;
                Shape::Box {
                    center: [0.0, 0.0],
                    length_m: self.number(key("length_m"), at.need("length_m", &raw.length_m)?, Rule::Positive)?,
                    width_m: self.number(key("width_m"), at.need("width_m", &raw.width_m)?, Rule::Positive)?,
                    yaw_rad: self.yaw_rad(key("yaw_deg"), &raw.yaw_deg)?,
                }
            }
            other => {
                return Err(self.error(
                    key("kind"),
                    Some(raw.kind.span()),
                    format!("unknown kind `{other}` for a moving obstacle (circle or box)"),
                ));
            }
        };
        let name = raw.name.get_ref().trim();
        if name.is_empty() {
            return Err(self.error(key("name"), Some(raw.name.span()), "must not be empty".to_owned()));
        }
        Ok(MovingObstacle {
            name: name.to_owned(),
            shape,
            path: self.points(key("path"), &raw.path, 1)?,
            speed_mps: self.number(key("speed_mps"), &raw.speed_mps, Rule::NonNegative)?,
            start_s: match &raw.start_s {
                Some(s) => self.number(key("start_s"), s, Rule::NonNegative)?,
                None => 0.0,
            },
            looped: raw.looped,
            vanish_at_end: raw.vanish_at_end,
        })
    }

    fn tape(&self, spanned: &Spanned<RawTape>) -> Result<MagneticTape, WorldFileError> {
        let raw = spanned.get_ref();
        let points = self.points("tape.points".to_owned(), &raw.points, 2)?;
        if let Some(i) = points.windows(2).position(|w| w[0] == w[1]) {
            let message = format!("points {i} and {} are the same", i + 1);
            return Err(self.error("tape.points".to_owned(), Some(raw.points.span()), message));
        }
        let width_m = match &raw.width_m {
            Some(w) => self.number("tape.width_m".to_owned(), w, Rule::Positive)?,
            None => MagneticTape::DEFAULT_WIDTH_M,
        };
        let radius = raw.arc_radius_m.as_ref();
        let radius_m = match radius {
            Some(r) => self.number("tape.arc_radius_m".to_owned(), r, Rule::NonNegative)?,
            None => 0.0,
        };
        if radius_m == 0.0 {
            let corners: Vec<(f64, f64)> = points.iter().map(|p| (p[0], p[1])).collect();
            return Ok(MagneticTape::polyline(&corners, width_m));
        }
        let span = radius.map(Spanned::span);
        rounded_tape(&points, radius_m, width_m)
            .map_err(|message| self.error("tape.arc_radius_m".to_owned(), span, message))
    }
}

/// Tape along the polyline `points` with every corner rounded by an arc of
/// `radius_m`, each arc tangent to both legs (the way tape is laid).
fn rounded_tape(points: &[Point], radius_m: f64, width_m: f64) -> Result<MagneticTape, String> {
    let headings: Vec<f64> = points
        .windows(2)
        .map(|w| (w[1][1] - w[0][1]).atan2(w[1][0] - w[0][0]))
        .collect();
    // Turn at each interior point (positive = right) and how much of each
    // adjacent leg its arc takes up.
    let mut turns = Vec::with_capacity(headings.len().saturating_sub(1));
    for (i, h) in headings.windows(2).enumerate() {
        let turn = wrap_pi(h[1] - h[0]);
        if turn.abs() >= std::f64::consts::PI - 1e-9 {
            return Err(format!("the tape doubles back on itself at points[{}]", i + 1));
        }
        turns.push((turn, radius_m * (turn.abs() / 2.0).tan()));
    }
    let mut builder = TapeBuilder::new(points[0][0], points[0][1], headings[0]);
    for (leg, w) in points.windows(2).enumerate() {
        let length_m = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        let arc_before = if leg > 0 { turns[leg - 1].1 } else { 0.0 };
        let arc_after = turns.get(leg).map_or(0.0, |t| t.1);
        let straight_m = length_m - arc_before - arc_after;
        if straight_m < -1e-9 {
            return Err(format!(
                "arcs of {radius_m} m do not fit on the {length_m:.3} m leg from points[{leg}] to points[{}]",
                leg + 1
            ));
        }
        builder = builder.line(straight_m);
        if let Some(&(turn, _)) = turns.get(leg) {
            builder = builder.arc(radius_m, turn);
        }
    }
    Ok(builder.build(width_m))
}

fn wrap_pi(angle_rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// A TOML error (syntax, unknown key, wrong type, missing key), placed by
/// the workspace's one TOML error locator; the offending line is quoted.
fn syntax_error(text: &str, error: &toml::de::Error) -> WorldFileError {
    let problem = toml_report::problem(text, error);
    let message = match error.span() {
        Some(span) => format!("{} (`{}`)", problem.message, toml_report::source_line(text, span.start)),
        None => problem.message,
    };
    WorldFileError {
        path: None,
        line: problem.place.map(|p| p.line),
        key: Some(problem.key).filter(|k| !k.is_empty()),
        message,
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_2;

    use super::*;

    fn worlds_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/worlds")
    }

    /// The error for `text`, which must not parse.
    fn error(text: &str) -> WorldFileError {
        match parse_world_file(text) {
            Ok(world) => panic!("parsed: {world:?}"),
            Err(e) => e,
        }
    }

    fn assert_error(text: &str, key: &str, line: usize, says: &str) {
        let e = error(text);
        assert_eq!(e.key.as_deref(), Some(key), "{e}");
        assert_eq!(e.line, Some(line), "{e}");
        assert!(e.message.contains(says), "{e}");
        let shown = e.to_string();
        assert!(
            shown.contains(key) && shown.contains(&format!("line {line}")),
            "{shown}"
        );
    }

    #[test]
    fn every_example_world_parses_and_has_obstacles() {
        let mut seen = 0;
        for dir_entry in std::fs::read_dir(worlds_dir()).unwrap() {
            let path = dir_entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let world = load_world_file(&path).unwrap_or_else(|e| panic!("{e}"));
                assert!(!world.statics.is_empty() || !world.movers.is_empty(), "{path:?}");
                seen += 1;
            }
        }
        assert!(seen >= 3, "{seen}");
        let yard = load_world_file(worlds_dir().join("yard.toml")).unwrap();
        assert!(yard.tape().is_some_and(|t| t.length_m() > 10.0));
    }

    #[test]
    fn numbers_beyond_100_km_are_refused() {
        let circle = |center: &str, radius: &str| {
            parse_world_file(&format!(
                "[[static]]\nkind = \"circle\"\ncenter = {center}\nradius_m = {radius}\n"
            ))
        };
        assert!(circle("[1, 2]", "0.5").is_ok());
        let e = circle("[1, 2]", "1e30").unwrap_err().to_string();
        assert!(e.contains("radius_m") && e.contains("100 000"), "{e}");
        let e = circle("[1e30, 2]", "0.5").unwrap_err().to_string();
        assert!(e.contains("100 km"), "{e}");
        let e = parse_world_file("[tape]\npoints = [[0, 0], [2e5, 0]]\nwidth_m = 0.05\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("100 km"), "{e}");
    }

    #[test]
    fn every_kind_becomes_its_shape() {
        let world = parse_world_file(
            r#"
            [[static]]
            kind = "box"
            center = [10, -2.5]
            length_m = 2
            width_m = 1.2
            yaw_deg = 90

            [[static]]
            kind = "circle"
            center = [3.0, 4.0]
            radius_m = 0.3

            [[static]]
            kind = "polygon"
            points = [[0, 0], [1, 0], [0, 1]]

            [[static]]
            kind = "wall"
            from = [0, -5]
            to = [0, 5]
            thickness_m = 0

            [[moving]]
            name = "walker"
            kind = "circle"
            path = [[5, -5], [5, 5]]
            speed_mps = 1.4
            start_s = 2
            vanish_at_end = true

            [[moving]]
            name = "forklift"
            kind = "box"
            length_m = 2.5
            width_m = 1.2
            path = [[20, 0], [20, 10]]
            speed_mps = 2
            loop = true
            "#,
        )
        .unwrap();
        assert_eq!(
            world.statics[0],
            Shape::Box {
                center: [10.0, -2.5],
                length_m: 2.0,
                width_m: 1.2,
                yaw_rad: FRAC_PI_2
            }
        );
        assert!(matches!(world.statics[1], Shape::Circle { radius_m, .. } if radius_m == 0.3));
        assert!(matches!(&world.statics[2], Shape::Polygon { points } if points.len() == 3));
        assert!(matches!(world.statics[3], Shape::Wall { thickness_m, .. } if thickness_m == 0.0));
        let walker = &world.movers[0];
        assert_eq!(
            walker.shape,
            Shape::Circle {
                center: [0.0, 0.0],
                radius_m: PERSON_RADIUS_M
            }
        );
        assert!(walker.vanish_at_end && !walker.looped && walker.start_s == 2.0);
        let forklift = &world.movers[1];
        assert!(forklift.looped && !forklift.vanish_at_end && forklift.start_s == 0.0);
        assert_eq!(world.obstacles().shapes_at(0.0).len(), 6);
        assert!(world.tape().is_none());
    }

    #[test]
    fn a_tape_rounds_its_corners_with_tangent_arcs() {
        let world = parse_world_file(
            r#"
            [tape]
            points = [[0, 0], [20, 0], [20, 10]]
            arc_radius_m = 4
            "#,
        )
        .unwrap();
        let tape = world.tape().unwrap();
        // 16 m straight, a quarter circle of 4 m, 6 m straight.
        let expected_m = 16.0 + 4.0 * FRAC_PI_2 + 6.0;
        assert!((tape.length_m() - expected_m).abs() < 1e-9, "{}", tape.length_m());
        assert_eq!(tape.segments().len(), 3);
        assert!(tape.distance_m(20.0, 10.0) < 1e-9 && tape.distance_m(0.0, 0.0) < 1e-9);
        // The corner is cut: its point is (√2 − 1)·4 m from the arc.
        let cut_m = (2f64.sqrt() - 1.0) * 4.0;
        assert!((tape.distance_m(20.0, 0.0) - cut_m).abs() < 1e-9);
        assert_eq!(tape.width_m(), MagneticTape::DEFAULT_WIDTH_M);
        let sharp = parse_world_file("[tape]\npoints = [[0, 0], [20, 0], [20, 10]]\nwidth_m = 0.05\n").unwrap();
        let sharp = sharp.tape().unwrap();
        assert!(sharp.distance_m(20.0, 0.0) < 1e-12 && sharp.width_m() == 0.05);
    }

    #[test]
    fn bad_values_name_their_key_and_line() {
        let mover = |speed: &str| {
            format!(
                "[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = 1\n\n\
                 [[moving]]\nname = \"b\"\nkind = \"circle\"\npath = [[0, 0], [1, 1]]\nspeed_mps = {speed}\n"
            )
        };
        assert_error(&mover("-1"), "moving[1].speed_mps", 11, "≥ 0");
        assert_error(&mover("nan"), "moving[1].speed_mps", 11, "finite");
        assert_error(&mover("inf"), "moving[1].speed_mps", 11, "finite");
        assert_error(
            "[[static]]\nkind = \"circle\"\ncenter = [0, 0]\nradius_m = 0\n",
            "static[0].radius_m",
            4,
            "> 0",
        );
        assert_error(
            "[[static]]\nkind = \"circle\"\ncenter = [0, 0]\nradius_m = 1\n[[static]]\nkind = \"polygon\"\npoints = [[0, 0], [1, 1]]\n",
            "static[1].points",
            7,
            "at least 3",
        );
        assert_error(
            "[[static]]\nkind = \"box\"\ncenter = [0, inf]\nlength_m = 1\nwidth_m = 1\n",
            "static[0].center",
            3,
            "finite",
        );
        assert_error(
            "[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = []\nspeed_mps = 1\n",
            "moving[0].path",
            4,
            "at least 1",
        );
        assert_error(
            "[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = 1\nstart_s = -3\n",
            "moving[0].start_s",
            6,
            "≥ 0",
        );
        assert_error(
            "[[static]]\nkind = \"wall\"\nfrom = [0, 0]\nto = [0, 0]\nthickness_m = 0.2\n",
            "static[0].to",
            4,
            "different",
        );
        assert_error(
            "[[static]]\nkind = \"wall\"\nfrom = [0, 0]\nto = [0, 1]\nthickness_m = -0.2\n",
            "static[0].thickness_m",
            5,
            "≥ 0",
        );
    }

    #[test]
    fn keys_that_do_not_belong_are_refused() {
        assert_error(
            "[[static]]\nkind = \"box\"\ncenter = [0, 0]\nlength_m = 1\nwidth_m = 1\nradius_m = 2\n",
            "static[0].radius_m",
            6,
            "not a key of a box",
        );
        assert_error(
            "[[static]]\nkind = \"hexagon\"\ncenter = [0, 0]\n",
            "static[0].kind",
            2,
            "unknown kind",
        );
        assert_error(
            "[[moving]]\nname = \"a\"\nkind = \"polygon\"\npath = [[0, 0]]\nspeed_mps = 1\n",
            "moving[0].kind",
            3,
            "circle or box",
        );
        assert_error(
            "[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = 1\n\n[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = 1\n",
            "moving[1].name",
            8,
            "already",
        );
        // Misspelt and missing keys: toml's own errors, placed by line.
        assert_error(
            "[[static]]\nkind = \"circle\"\ncenter = [0, 0]\nradius_m = 1\n\n[[static]]\nkind = \"circle\"\ncenter = [0, 0]\nradus_m = 1\n",
            "static[1].radus_m",
            9,
            "unknown key",
        );
        let e = error("[[static]]\nkind = \"box\"\ncenter = [0, 0]\nwidth_m = 1\n");
        assert_eq!(e.key.as_deref(), Some("static[0].length_m"), "{e}");
        assert!(e.message.contains("needs `length_m`"), "{e}");
        let e = error("[[moving]]\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = 1\n");
        assert!(e.key.as_deref().is_some_and(|k| k.starts_with("moving[0]")), "{e}");
        assert!(e.message.contains("name") && e.line.is_some(), "{e}");
        assert_error(
            "[[moving]]\nname = \"a\"\nkind = \"circle\"\npath = [[0, 0]]\nspeed_mps = \"fast\"\n",
            "moving[0].speed_mps",
            5,
            "invalid type",
        );
        assert_error("[yard]\nsize = 3\n", "yard", 1, "unknown key");
    }

    #[test]
    fn a_tape_that_cannot_be_laid_is_refused() {
        assert_error(
            "[tape]\npoints = [[0, 0], [3, 0], [3, 10]]\narc_radius_m = 4\n",
            "tape.arc_radius_m",
            3,
            "do not fit",
        );
        assert_error(
            "[tape]\npoints = [[0, 0], [10, 0], [0, 0]]\narc_radius_m = 1\n",
            "tape.arc_radius_m",
            3,
            "doubles back",
        );
        assert_error("[tape]\npoints = [[0, 0], [0, 0]]\n", "tape.points", 2, "same");
        assert_error("[tape]\npoints = [[0, 0]]\n", "tape.points", 2, "at least 2");
    }

    #[test]
    fn a_missing_file_names_the_path() {
        let e = load_world_file("/nonexistent/world.toml").unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/world.toml: cannot read"), "{e}");
    }
}
