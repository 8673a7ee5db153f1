//! `GEO_*`: which local frame the core builds at its origin (docs/architecture.md §Frames).
//!
//! Every one is `reboot_required`: the frame is built once, when the origin
//! is set, and changing it under a running mission would move every local
//! position at once.

use params::{ParamTable, declare_params};

use super::{FrameKind, GeoPoint, LocalFrame, PlaneTransform};

const FRAME: &str = "GEO_FRAME";
const ELLIPSOID: &str = "GEO_ELLIPSOID";
const MAP_ENABLE: &str = "GEO_MAP_ENABLE";
const MAP_NORTH: &str = "GEO_MAP_N";
const MAP_EAST: &str = "GEO_MAP_E";
const MAP_ROTATION: &str = "GEO_MAP_ROT";
const MAP_SCALE: &str = "GEO_MAP_SCALE";

/// MAVLink carries parameters as f32: ±10 km keeps the plant-grid shift
/// within 1 mm (f32 spacing is 0.98 mm between 8192 and 16384).
const MAP_SHIFT_LIMIT_M: f32 = 10_000.0;

declare_params! {
    /// The local frame from WGS-84 and the site's plant grid.
    pub struct GeoParams {
        frame: i8 = FRAME => {
            default: 0, range: 0, 2, unit: "", flags: [reboot_required],
            desc: "Local frame: 0 ellipsoidal tangent plane (exact), 1 spherical (R 6371 km), 2 Gauss-Kruger grid",
        },
        ellipsoid: i8 = ELLIPSOID => {
            default: 0, range: 0, 2, unit: "", flags: [reboot_required],
            desc: "Gauss-Kruger ellipsoid: 0 WGS-84, 1 IAG-75 (Xi'an 80), 2 Krassovsky (Beijing 54)",
        },
        map_enable: bool = MAP_ENABLE => {
            default: false, range: 0, 1, unit: "", flags: [reboot_required],
            desc: "1: local positions are in the site's plant grid (GEO_MAP_N/E/ROT/SCALE applied to the frame)",
        },
        map_north_m: f32 = MAP_NORTH => {
            default: 0.0, range: -MAP_SHIFT_LIMIT_M, MAP_SHIFT_LIMIT_M, unit: "m", flags: [reboot_required],
            desc: "Plant-grid north coordinate of the origin",
        },
        map_east_m: f32 = MAP_EAST => {
            default: 0.0, range: -MAP_SHIFT_LIMIT_M, MAP_SHIFT_LIMIT_M, unit: "m", flags: [reboot_required],
            desc: "Plant-grid east coordinate of the origin",
        },
        map_rotation_deg: f32 = MAP_ROTATION => {
            default: 0.0, range: -180.0, 180.0, unit: "deg", flags: [reboot_required],
            desc: "Plant grid rotation, clockwise: a heading h in the frame is h + GEO_MAP_ROT in the grid",
        },
        map_scale: f32 = MAP_SCALE => {
            default: 1.0, range: 0.9, 1.1, unit: "", flags: [reboot_required],
            desc: "Plant-grid metres per frame metre",
        },
    }
}

impl GeoParams {
    /// The frame kind and plant-grid transform the values describe.
    pub fn settings(&self, table: &ParamTable) -> (FrameKind, Option<PlaneTransform>) {
        let kind = FrameKind::from_params(self.frame.get(table), self.ellipsoid.get(table));
        let map = self.map_enable.get(table).then(|| PlaneTransform {
            shift_north_m: f64::from(self.map_north_m.get(table)),
            shift_east_m: f64::from(self.map_east_m.get(table)),
            rotation_rad: f64::from(self.map_rotation_deg.get(table)).to_radians(),
            scale: f64::from(self.map_scale.get(table)),
        });
        (kind, map)
    }
}

/// The frame the `GEO_*` values in `table` describe, about `origin`. A
/// table without the group (or with out-of-range values, which the table
/// refuses anyway) gives the default tangent plane.
pub fn frame_from_params(table: &ParamTable, origin: GeoPoint) -> LocalFrame {
    let value = |name: &str, default: f64| table.value_of(name).unwrap_or(default);
    let kind = FrameKind::from_params(value(FRAME, 0.0) as i8, value(ELLIPSOID, 0.0) as i8);
    let map = (value(MAP_ENABLE, 0.0) != 0.0).then(|| PlaneTransform {
        shift_north_m: value(MAP_NORTH, 0.0),
        shift_east_m: value(MAP_EAST, 0.0),
        rotation_rad: value(MAP_ROTATION, 0.0).to_radians(),
        scale: value(MAP_SCALE, 1.0),
    });
    LocalFrame::with_kind(kind, origin, map)
}

#[cfg(test)]
mod tests {
    use params::ParamTableBuilder;

    use super::*;
    use crate::geo::{Ellipsoid, Ned};

    fn table() -> ParamTable {
        let mut builder = ParamTableBuilder::new();
        GeoParams::register(&mut builder);
        builder.build()
    }

    #[test]
    fn defaults_are_the_tangent_plane_without_a_map() {
        let origin = GeoPoint::new(29.133, 119.64, 40.0);
        assert_eq!(frame_from_params(&table(), origin), LocalFrame::new(origin));
        // A core that never registered the group gets the same.
        assert_eq!(
            frame_from_params(&ParamTableBuilder::new().build(), origin),
            LocalFrame::new(origin)
        );
    }

    #[test]
    fn every_setting_reaches_the_frame() {
        let mut table = table();
        table.set_by_name(FRAME, 2.0).unwrap();
        table.set_by_name(ELLIPSOID, 1.0).unwrap();
        table.set_by_name(MAP_ENABLE, 1.0).unwrap();
        table.set_by_name(MAP_NORTH, 1500.0).unwrap();
        table.set_by_name(MAP_EAST, -250.0).unwrap();
        table.set_by_name(MAP_ROTATION, 90.0).unwrap();
        table.set_by_name(MAP_SCALE, 1.0).unwrap();
        let origin = GeoPoint::new(29.133, 119.64, 40.0);
        let frame = frame_from_params(&table, origin);
        assert_eq!(frame.kind(), FrameKind::GaussKruger(Ellipsoid::Iag75));
        let at_origin = frame.to_local(&origin);
        assert!(at_origin.distance_to(&Ned::new(1500.0, -250.0)) < 1e-9);
        // 90° clockwise: a point north of the origin is east of it in the grid.
        let north = frame.to_local(&GeoPoint::new(29.134, 119.64, 40.0));
        assert!(
            (north.north_m - 1500.0).abs() < 1e-6 && (north.east_m - (-250.0 + 110.86)).abs() < 0.05,
            "{north:?}"
        );
    }

    #[test]
    fn the_table_refuses_a_shift_it_could_not_hold_to_a_millimetre() {
        let mut table = table();
        assert!(table.set_by_name(MAP_NORTH, 20_000.0).is_err());
        assert!(table.set_by_name(MAP_SCALE, 0.0).is_err());
    }
}
