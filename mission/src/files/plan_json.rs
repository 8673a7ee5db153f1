//! QGroundControl's `.plan` file (JSON), holding all three plans:
//!
//! - `mission.items`: `SimpleItem`s (`command`, `frame`, `params` — seven
//!   numbers, `null` for NaN, 5 and 6 latitude/longitude in degrees —,
//!   `autoContinue`, `doJumpId`); `mission.plannedHomePosition`
//!   `[lat, lon, alt]` is Furrow's mission item 0 (home). DO_JUMP's param 1
//!   names the target's `doJumpId` in the file and becomes its seq.
//!   `ComplexItem`s (surveys, corridor scans, landing patterns) are refused:
//!   QGroundControl expands them when it uploads the plan.
//! - `geoFence.polygons` (`inclusion`, `polygon` vertex list) become
//!   NAV_FENCE_POLYGON_VERTEX_INCLUSION/EXCLUSION items carrying the vertex
//!   count, `geoFence.circles` NAV_FENCE_CIRCLE_INCLUSION/EXCLUSION,
//!   `geoFence.breachReturn` NAV_FENCE_RETURN_POINT — in that order, framed
//!   as QGroundControl uploads them.
//! - `rallyPoints.points` (`[lat, lon, alt]`) become NAV_RALLY_POINT items.
//!
//! The format cannot carry everything an item can: fence/rally frames,
//! polygon inclusion groups, `current` flags. Rendering then parsing gives
//! back the same items for plans in the shape this module produces.

use serde::de::{self, Deserializer};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use super::FileError;
use crate::command::{cmd, frame};
use crate::item::MissionItem;
use crate::protocol::{HomeItem, Plans};
use crate::validate::{xy_from_float, xy_to_float};

/// The three plans a `.plan` file holds, as items with seq 0..n-1 (the
/// mission's item 0 being home), ready for
/// [`crate::validate::validate_plan`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlanFile {
    pub mission: Vec<MissionItem>,
    pub fence: Vec<MissionItem>,
    pub rally: Vec<MissionItem>,
}

/// `MAV_AUTOPILOT_ARDUPILOTMEGA`, `MAV_TYPE_GROUND_ROVER`.
const FIRMWARE_TYPE: u8 = 3;
const VEHICLE_TYPE: u8 = 10;

/// An `f32` as a JSON number with its shortest decimal text (`0.1`, not
/// `0.10000000149011612`); NaN and infinities as `null`.
fn number_f32(v: f32) -> Value {
    if v.is_finite() {
        format!("{v}")
            .parse::<f64>()
            .ok()
            .and_then(serde_json::Number::from_f64)
            .map_or(Value::Null, Value::Number)
    } else {
        Value::Null
    }
}

fn number_f64(v: f64) -> Value {
    serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number)
}

fn degrees(v: i32) -> Value {
    number_f64(xy_to_float(frame::GLOBAL, v))
}

fn coordinate(x: i32, y: i32, z: Option<f32>) -> Value {
    let mut c = vec![degrees(x), degrees(y)];
    if let Some(z) = z {
        c.push(number_f32(z));
    }
    Value::Array(c)
}

/// The `.plan` file for three plans. `home` (the vehicle's current home)
/// becomes `plannedHomePosition`; without it, mission item 0.
pub fn render(plans: &Plans, home: Option<HomeItem>) -> String {
    let mission_items = plans.mission.items();
    let home = home.or_else(|| {
        mission_items.first().map(|h| HomeItem {
            lat_e7: h.x,
            lon_e7: h.y,
            alt_m: h.z,
        })
    });
    let planned_home = home.map_or_else(|| json!([0, 0, 0]), |h| coordinate(h.lat_e7, h.lon_e7, Some(h.alt_m)));
    let items = mission_json(mission_items);
    let geo_fence = fence_json(plans.fence.items());
    let points: Vec<Value> = plans
        .rally
        .items()
        .iter()
        .map(|it| coordinate(it.x, it.y, Some(it.z)))
        .collect();

    let file = json!({
        "fileType": "Plan",
        "version": 1,
        "groundStation": "Furrow",
        "mission": {
            "version": 2,
            "firmwareType": FIRMWARE_TYPE,
            "vehicleType": VEHICLE_TYPE,
            "plannedHomePosition": planned_home,
            "items": items,
        },
        "geoFence": geo_fence,
        "rallyPoints": { "version": 2, "points": points },
    });
    let mut text = pretty(&file);
    text.push('\n');
    text
}

/// The mission's items after home, as QGroundControl's `SimpleItem`s.
fn mission_json(mission_items: &[MissionItem]) -> Vec<Value> {
    mission_items
        .iter()
        .skip(1)
        .map(|it| {
            let mut params: Vec<Value> = it.params.iter().map(|p| number_f32(*p)).collect();
            params.push(number_f64(xy_to_float(it.frame, it.x)));
            params.push(number_f64(xy_to_float(it.frame, it.y)));
            params.push(number_f32(it.z));
            json!({
                "type": "SimpleItem",
                "command": it.command,
                "frame": it.frame,
                "params": params,
                "autoContinue": it.autocontinue,
                "doJumpId": it.seq,
            })
        })
        .collect()
}

/// The fence items as QGroundControl's `geoFence`: polygons (a run of
/// vertices of one kind), circles and the breach return point.
fn fence_json(fence: &[MissionItem]) -> Value {
    let mut polygons = Vec::new();
    let mut circles = Vec::new();
    let mut breach_return = None;
    let mut i = 0;
    while i < fence.len() {
        let it = &fence[i];
        match it.command {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
                let n = (it.params[0].max(1.0) as usize).min(fence.len() - i);
                let run: Vec<Value> = fence[i..i + n]
                    .iter()
                    .take_while(|v| v.command == it.command)
                    .map(|v| coordinate(v.x, v.y, None))
                    .collect();
                i += run.len();
                polygons.push(json!({
                    "version": 1,
                    "inclusion": it.command == cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                    "polygon": run,
                }));
                continue;
            }
            cmd::NAV_FENCE_CIRCLE_INCLUSION | cmd::NAV_FENCE_CIRCLE_EXCLUSION => circles.push(json!({
                "version": 1,
                "inclusion": it.command == cmd::NAV_FENCE_CIRCLE_INCLUSION,
                "circle": { "center": coordinate(it.x, it.y, None), "radius": number_f32(it.params[0]) },
            })),
            cmd::NAV_FENCE_RETURN_POINT => breach_return = Some(coordinate(it.x, it.y, Some(it.z))),
            _ => {}
        }
        i += 1;
    }
    let mut geo_fence = json!({ "version": 2, "polygons": polygons, "circles": circles });
    if let Some(b) = breach_return {
        geo_fence["breachReturn"] = b;
    }
    geo_fence
}

/// Four-space indentation, as QGroundControl writes.
fn pretty(v: &Value) -> String {
    let mut buf = Vec::new();
    let fmt = serde_json::ser::PrettyFormatter::with_indent(b"    ");
    let mut ser = serde_json::Serializer::with_formatter(&mut buf, fmt);
    // Serialising a Value into memory cannot fail.
    let _ = v.serialize(&mut ser);
    String::from_utf8(buf).unwrap_or_default()
}

// ---- Reading -------------------------------------------------------------
//
// Typed with serde so that serde_json reports the line of every error,
// including the refusals raised while an item is read.

#[derive(Deserialize)]
struct FileJson {
    #[serde(rename = "fileType")]
    file_type: String,
    #[serde(default)]
    mission: Option<MissionJson>,
    #[serde(rename = "geoFence", default)]
    geo_fence: Option<GeoFenceJson>,
    #[serde(rename = "rallyPoints", default)]
    rally_points: Option<RallyJson>,
}

#[derive(Deserialize)]
struct MissionJson {
    #[serde(default)]
    items: Vec<ItemJson>,
    #[serde(rename = "plannedHomePosition", default)]
    planned_home: Option<Coord>,
}

/// A mission item. Read through a visitor that checks it before serde_json
/// leaves the object, so an error carries the line of its closing brace.
enum ItemJson {
    Simple(SimpleItemJson),
}

#[derive(Deserialize)]
struct SimpleItemJson {
    #[serde(deserialize_with = "de_u16")]
    command: u16,
    #[serde(deserialize_with = "de_u8")]
    frame: u8,
    params: [Option<f64>; 7],
    #[serde(rename = "autoContinue")]
    auto_continue: bool,
    #[serde(rename = "doJumpId", default)]
    do_jump_id: Option<f64>,
}

impl<'de> Deserialize<'de> for ItemJson {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> de::Visitor<'de> for Visit {
            type Value = ItemJson;

            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a mission item object")
            }

            fn visit_map<A: de::MapAccess<'de>>(self, mut map: A) -> Result<ItemJson, A::Error> {
                let mut object = serde_json::Map::new();
                while let Some((key, value)) = map.next_entry::<String, Value>()? {
                    object.insert(key, value);
                }
                item_from_object(object).map_err(de::Error::custom)
            }
        }
        d.deserialize_map(Visit)
    }
}

fn item_from_object(object: serde_json::Map<String, Value>) -> Result<ItemJson, String> {
    match object.get("type").and_then(Value::as_str) {
        Some("SimpleItem") => serde_json::from_value(Value::Object(object))
            .map(ItemJson::Simple)
            .map_err(|e| format!("SimpleItem: {e}")),
        Some("ComplexItem") => {
            let kind = object
                .get("complexItemType")
                .and_then(Value::as_str)
                .unwrap_or("unnamed");
            Err(format!(
                "complex item {kind:?} is not supported: only simple items can be imported \
                 (upload the plan from QGroundControl instead: it turns a {kind} into simple items)"
            ))
        }
        Some(other) => Err(format!("unknown item type {other:?} (expected SimpleItem)")),
        None => Err("mission item without a \"type\"".to_string()),
    }
}

#[derive(Deserialize, Default)]
struct GeoFenceJson {
    #[serde(default)]
    polygons: Vec<PolygonJson>,
    #[serde(default)]
    circles: Vec<CircleJson>,
    #[serde(rename = "breachReturn", default)]
    breach_return: Option<Coord>,
}

#[derive(Deserialize)]
struct PolygonJson {
    inclusion: bool,
    polygon: Vec<Coord>,
}

#[derive(Deserialize)]
struct CircleJson {
    inclusion: bool,
    circle: CircleInnerJson,
}

#[derive(Deserialize)]
struct CircleInnerJson {
    center: Coord,
    #[serde(deserialize_with = "radius_f32")]
    radius: f64,
}

/// An `f64` from the file as the `f32` an item stores, if it fits. A number
/// beyond `f32` became infinite, was written back as `null`, and the file
/// then did not read again (found by fuzzing).
fn to_f32(v: f64) -> Option<f32> {
    let x = v as f32;
    (x.is_finite() || !v.is_finite()).then_some(x)
}

fn radius_f32<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    match to_f32(v) {
        Some(_) => Ok(v),
        None => Err(de::Error::custom(format!("radius {v} is too large"))),
    }
}

#[derive(Deserialize, Default)]
struct RallyJson {
    #[serde(default)]
    points: Vec<Coord>,
}

/// `[lat, lon]` or `[lat, lon, alt]` in degrees and metres (`null`
/// altitude: NaN).
struct Coord {
    lat_e7: i32,
    lon_e7: i32,
    alt: f32,
}

impl<'de> Deserialize<'de> for Coord {
    /// Checked inside its own array, so an error has the coordinate's line.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> de::Visitor<'de> for Visit {
            type Value = Coord;

            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a coordinate [latitude, longitude] or [latitude, longitude, altitude]")
            }

            fn visit_seq<A: de::SeqAccess<'de>>(self, mut seq: A) -> Result<Coord, A::Error> {
                let mut v: Vec<Option<f64>> = Vec::new();
                while let Some(x) = seq.next_element::<Option<f64>>()? {
                    v.push(x);
                }
                coord(&v).map_err(de::Error::custom)
            }
        }
        d.deserialize_seq(Visit)
    }
}

fn coord(v: &[Option<f64>]) -> Result<Coord, String> {
    if !(2..=3).contains(&v.len()) {
        return Err(format!(
            "a coordinate is [latitude, longitude] or [latitude, longitude, altitude], not {} numbers",
            v.len()
        ));
    }
    let angle = |i: usize, what: &str, limit: f64| {
        v[i].filter(|a| a.abs() <= limit)
            .and_then(|a| xy_from_float(frame::GLOBAL, a))
            .ok_or_else(|| match v[i] {
                Some(a) => format!("{what} {a} is not within ±{limit}"),
                None => format!("{what} is null"),
            })
    };
    let alt = match v.get(2).copied().flatten() {
        None => f32::NAN,
        Some(a) => to_f32(a).ok_or_else(|| format!("altitude {a} is too large"))?,
    };
    Ok(Coord {
        lat_e7: angle(0, "latitude", 90.0)?,
        lon_e7: angle(1, "longitude", 180.0)?,
        alt,
    })
}

fn whole<'de, D: Deserializer<'de>>(d: D, max: f64, what: &str) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.fract() == 0.0 && (0.0..=max).contains(&v) {
        Ok(v)
    } else {
        Err(de::Error::custom(format!(
            "{what} {v} is not a whole number from 0 to {max}"
        )))
    }
}

fn de_u16<'de, D: Deserializer<'de>>(d: D) -> Result<u16, D::Error> {
    whole(d, f64::from(u16::MAX), "command").map(|v| v as u16)
}

fn de_u8<'de, D: Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    whole(d, f64::from(u8::MAX), "frame").map(|v| v as u8)
}

/// A serde_json error as a [`FileError`] with its line.
fn json_error(e: &serde_json::Error) -> FileError {
    let text = e.to_string();
    let message = match text.rfind(" at line ") {
        Some(i) if e.line() > 0 => text[..i].to_string(),
        _ => text,
    };
    FileError::new(e.line(), message)
}

/// Reads a `.plan` file into three item lists (their meaning is checked by
/// [`crate::validate::validate_plan`]). A file without a `mission`,
/// `geoFence` or `rallyPoints` section leaves that list empty.
pub fn parse(text: &str) -> Result<PlanFile, FileError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let file: FileJson = serde_json::from_str(text).map_err(|e| json_error(&e))?;
    if file.file_type != "Plan" {
        return Err(FileError::new(
            0,
            format!(
                "fileType is {:?}: only QGroundControl \"Plan\" files are read",
                file.file_type
            ),
        ));
    }
    Ok(PlanFile {
        mission: file.mission.map(mission_items).transpose()?.unwrap_or_default(),
        fence: fence_items(file.geo_fence.unwrap_or_default()),
        rally: rally_items(file.rally_points.unwrap_or_default()),
    })
}

fn mission_items(m: MissionJson) -> Result<Vec<MissionItem>, FileError> {
    if m.items.is_empty() {
        return Ok(Vec::new());
    }
    let home = m.planned_home.ok_or_else(|| {
        FileError::new(
            0,
            "mission.plannedHomePosition is missing: it becomes mission item 0 (home)",
        )
    })?;
    let mut items = vec![
        HomeItem {
            lat_e7: home.lat_e7,
            lon_e7: home.lon_e7,
            alt_m: if home.alt.is_nan() { 0.0 } else { home.alt },
        }
        .to_item(),
    ];
    let mut jump_ids: Vec<(f64, u16)> = Vec::new();
    for (i, entry) in m.items.into_iter().enumerate() {
        let ItemJson::Simple(s) = entry;
        let seq = u16::try_from(i + 1)
            .map_err(|_| FileError::new(0, format!("mission.items holds {} items: too many", i + 1)))?;
        let param = |n: usize| match s.params[n] {
            None => Ok(f32::NAN),
            Some(v) => to_f32(v).ok_or_else(|| {
                FileError::new(
                    0,
                    format!("mission.items[{i}] (item {seq}): params[{n}] {v} is too large"),
                )
            }),
        };
        let xy = |n: usize, what: &str| {
            xy_from_float(s.frame, s.params[n].unwrap_or(f64::NAN)).ok_or_else(|| {
                FileError::new(
                    0,
                    format!(
                        "mission.items[{i}] (item {seq}): params[{n}] ({what}) {:?} does not fit frame {}",
                        s.params[n], s.frame
                    ),
                )
            })
        };
        if let Some(id) = s.do_jump_id {
            jump_ids.push((id, seq));
        }
        items.push(MissionItem {
            seq,
            frame: s.frame,
            command: s.command,
            current: false,
            autocontinue: s.auto_continue,
            params: [param(0)?, param(1)?, param(2)?, param(3)?],
            x: xy(4, "latitude/x")?,
            y: xy(5, "longitude/y")?,
            z: param(6)?,
        });
    }
    // DO_JUMP names its target by doJumpId in the file.
    for item in items.iter_mut().filter(|it| it.command == cmd::DO_JUMP) {
        let id = f64::from(item.params[0]);
        match jump_ids.iter().find(|(j, _)| *j == id) {
            Some((_, target)) => item.params[0] = f32::from(*target),
            None => {
                return Err(FileError::new(
                    0,
                    format!(
                        "mission.items[{}] (item {}): DO_JUMP to doJumpId {id}, which no item has",
                        item.seq - 1,
                        item.seq
                    ),
                ));
            }
        }
    }
    Ok(items)
}

fn fence_item(seq: usize, command: u16, f: u8, p1: f32, lat_e7: i32, lon_e7: i32, z: f32) -> MissionItem {
    MissionItem {
        seq: seq as u16,
        frame: f,
        command,
        current: false,
        autocontinue: false,
        params: [p1, 0.0, 0.0, 0.0],
        x: lat_e7,
        y: lon_e7,
        z,
    }
}

fn fence_items(g: GeoFenceJson) -> Vec<MissionItem> {
    let mut items = Vec::new();
    for p in &g.polygons {
        let command = if p.inclusion {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION
        } else {
            cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION
        };
        let n = p.polygon.len() as f32;
        for v in &p.polygon {
            items.push(fence_item(
                items.len(),
                command,
                frame::GLOBAL,
                n,
                v.lat_e7,
                v.lon_e7,
                0.0,
            ));
        }
    }
    for c in &g.circles {
        let command = if c.inclusion {
            cmd::NAV_FENCE_CIRCLE_INCLUSION
        } else {
            cmd::NAV_FENCE_CIRCLE_EXCLUSION
        };
        let center = &c.circle.center;
        items.push(fence_item(
            items.len(),
            command,
            frame::GLOBAL,
            c.circle.radius as f32,
            center.lat_e7,
            center.lon_e7,
            0.0,
        ));
    }
    if let Some(b) = &g.breach_return {
        items.push(fence_item(
            items.len(),
            cmd::NAV_FENCE_RETURN_POINT,
            frame::GLOBAL_RELATIVE_ALT,
            0.0,
            b.lat_e7,
            b.lon_e7,
            b.alt,
        ));
    }
    items
}

fn rally_items(r: RallyJson) -> Vec<MissionItem> {
    r.points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            fence_item(
                i,
                cmd::NAV_RALLY_POINT,
                frame::GLOBAL_RELATIVE_ALT,
                0.0,
                p.lat_e7,
                p.lon_e7,
                p.alt,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const QGC_PLAN: &str = r#"{
    "fileType": "Plan",
    "geoFence": {
        "circles": [
            { "circle": { "center": [47.39, 8.54], "radius": 25.5 }, "inclusion": false, "version": 1 }
        ],
        "polygons": [
            { "inclusion": true, "polygon": [[47.1, 8.1], [47.2, 8.1], [47.2, 8.2]], "version": 1 }
        ],
        "version": 2
    },
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 15,
        "firmwareType": 3,
        "globalPlanAltitudeMode": 1,
        "hoverSpeed": 5,
        "items": [
            { "AMSLAltAboveTerrain": null, "Altitude": 50, "AltitudeMode": 1, "autoContinue": true,
              "command": 22, "doJumpId": 1, "frame": 3, "params": [0, 0, 0, null, 47.3977419, 8.5455938, 50],
              "type": "SimpleItem" },
            { "autoContinue": true, "command": 16, "doJumpId": 2, "frame": 3,
              "params": [0, 0, 0, null, 47.3980, 8.5460, 50], "type": "SimpleItem" },
            { "autoContinue": true, "command": 177, "doJumpId": 3, "frame": 2,
              "params": [2, 3, 0, 0, 0, 0, 0], "type": "SimpleItem" }
        ],
        "plannedHomePosition": [47.3975, 8.5450, 488.5],
        "vehicleType": 10,
        "version": 2
    },
    "rallyPoints": { "points": [[47.3, 8.5, 20]], "version": 2 },
    "version": 1
}"#;

    #[test]
    fn numbers_beyond_f32_are_refused() {
        // Found by fuzzing: a radius of 1.3e80 was stored as an infinite
        // f32, written back as `null`, and the written file did not parse.
        for (from, to) in [
            ("\"radius\": 25.5", "\"radius\": 1.3e80"),
            (
                "[0, 0, 0, null, 47.3980, 8.5460, 50]",
                "[0, 0, 0, null, 47.3980, 8.5460, -4e38]",
            ),
            ("[2, 3, 0, 0, 0, 0, 0]", "[2, 3e39, 0, 0, 0, 0, 0]"),
            ("[47.3, 8.5, 20]", "[47.3, 8.5, 1e300]"),
        ] {
            assert!(QGC_PLAN.contains(from), "{from}");
            let e = parse(&QGC_PLAN.replacen(from, to, 1)).unwrap_err();
            assert!(e.message.contains("too large"), "{to}: {e}");
        }
        // The largest f32 itself still reads, and round-trips.
        let max = QGC_PLAN.replacen("\"radius\": 25.5", "\"radius\": 3.4028235e38", 1);
        assert_eq!(parse(&max).unwrap().fence[3].params[0], f32::MAX);
    }

    #[test]
    fn reads_a_qgroundcontrol_plan() {
        let p = parse(QGC_PLAN).unwrap();
        assert_eq!(p.mission.len(), 4);
        assert_eq!(p.mission[0].x, 473_975_000);
        assert_eq!(p.mission[0].z, 488.5);
        assert_eq!(p.mission[1].command, 22);
        assert_eq!(p.mission[1].x, 473_977_419);
        assert!(p.mission[1].params[3].is_nan());
        assert_eq!(p.mission[3].params[0], 2.0, "doJumpId 2 is item 2");
        assert_eq!(p.fence.len(), 4);
        assert_eq!(p.fence[0].command, cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION);
        assert_eq!(p.fence[0].params[0], 3.0);
        assert_eq!(p.fence[3].command, cmd::NAV_FENCE_CIRCLE_EXCLUSION);
        assert_eq!(p.fence[3].params[0], 25.5);
        assert_eq!(p.rally.len(), 1);
        assert_eq!((p.rally[0].x, p.rally[0].z), (473_000_000, 20.0));
        for (t, items) in [
            (crate::MissionType::Mission, &p.mission),
            (crate::MissionType::Fence, &p.fence),
            (crate::MissionType::Rally, &p.rally),
        ] {
            crate::validate_plan(t, items.clone()).unwrap();
        }
    }

    #[test]
    fn complex_items_are_refused_with_their_line() {
        let text = QGC_PLAN.replace(
            r#"{ "autoContinue": true, "command": 16, "doJumpId": 2, "frame": 3,"#,
            r#"{ "type": "ComplexItem", "complexItemType": "survey", "polygon": [] },
            { "autoContinue": true, "command": 16, "doJumpId": 2, "frame": 3,"#,
        );
        let e = parse(&text).unwrap_err();
        assert!(e.message.contains("\"survey\""), "{e}");
        assert_eq!(e.line, 22, "the survey's line: {e}");
    }

    #[test]
    fn errors_name_the_line() {
        let e =
            parse("{\n\"fileType\": \"Plan\",\n\"mission\": {\"items\": [\n{\"type\": \"SimpleItem\"}]}}").unwrap_err();
        assert_eq!(e.line, 4, "{e}");
        assert!(e.message.contains("command"), "{e}");
        let e = parse("{\"fileType\": \"Plan\",\n \"rallyPoints\": {\"points\": [[95, 1, 2]]}}").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        assert!(e.message.contains("latitude"), "{e}");
        let e = parse("{\"fileType\": \"GeoFence\"}").unwrap_err();
        assert!(e.message.contains("fileType"), "{e}");
        let e = parse(&QGC_PLAN.replace("[2, 3, 0, 0, 0, 0, 0]", "[7, 3, 0, 0, 0, 0, 0]")).unwrap_err();
        assert!(e.message.contains("doJumpId 7"), "{e}");
        assert!(parse("").is_err());
    }
}
