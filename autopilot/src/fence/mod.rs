//! The geofence: inclusion and exclusion polygons and circles from the fence
//! plan, in the local frame, and whether a point breaches them.
//!
//! MAVLink's rules (MAV_CMD_NAV_FENCE_*): the vehicle must be inside every
//! inclusion zone of at least one inclusion group (zones of one group
//! intersect; groups are alternatives), and outside every exclusion zone.

use mission::command::Position;
use mission::{FenceItem, MissionItem, interpret_fence};

use crate::geo::{LocalFrame, Ned};

#[derive(Clone, Debug, PartialEq)]
enum Zone {
    Polygon(Vec<Ned>),
    Circle { centre: Ned, radius_m: f64 },
}

impl Zone {
    fn contains(&self, p: &Ned) -> bool {
        match self {
            Zone::Circle { centre, radius_m } => centre.distance_to(p) <= *radius_m,
            Zone::Polygon(vertices) => point_in_polygon(p, vertices),
        }
    }
}

/// Even-odd ray casting (east-going ray).
pub fn point_in_polygon(p: &Ned, vertices: &[Ned]) -> bool {
    let mut inside = false;
    let n = vertices.len();
    for i in 0..n {
        let (a, b) = (vertices[i], vertices[(i + n - 1) % n]);
        if (a.north_m > p.north_m) != (b.north_m > p.north_m) {
            let east_at = a.east_m + (p.north_m - a.north_m) / (b.north_m - a.north_m) * (b.east_m - a.east_m);
            if p.east_m < east_at {
                inside = !inside;
            }
        }
    }
    inside
}

/// Why a point breaches the fence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Breach {
    OutsideInclusion,
    InsideExclusion,
}

impl Breach {
    pub fn describe(self) -> &'static str {
        match self {
            Breach::OutsideInclusion => "outside the inclusion fence",
            Breach::InsideExclusion => "inside an exclusion zone",
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fence {
    /// Inclusion zones by group.
    inclusion: Vec<(u8, Zone)>,
    exclusion: Vec<Zone>,
}

impl Fence {
    /// Builds the fence from a validated fence plan. Local-frame items are
    /// metres about the local origin; `Current` cannot occur (validation
    /// refuses it).
    pub fn from_items(items: &[MissionItem], frame: &LocalFrame) -> Fence {
        let to_local = |p: &Position| match *p {
            Position::Global { lat_e7, lon_e7 } => frame.to_local(&crate::geo::GeoPoint::from_e7(lat_e7, lon_e7, 0.0)),
            Position::Local { north_m, east_m } => Ned::new(north_m, east_m),
            Position::Current => Ned::default(),
        };
        let typed: Vec<FenceItem> = items.iter().filter_map(|i| interpret_fence(i).ok()).collect();
        let mut fence = Fence::default();
        let mut i = 0;
        while i < typed.len() {
            let polygon = match typed[i] {
                FenceItem::PolygonInclusion {
                    vertex_count, group, ..
                } => Some((vertex_count, Some(group))),
                FenceItem::PolygonExclusion { vertex_count, .. } => Some((vertex_count, None)),
                _ => None,
            };
            match typed[i] {
                _ if polygon.is_some_and(|(n, _)| usize::from(n) + i <= typed.len()) => {
                    let (vertex_count, group) = polygon.unwrap_or((0, None));
                    let vertices: Vec<Ned> = typed[i..i + usize::from(vertex_count)]
                        .iter()
                        .map(|v| match v {
                            FenceItem::PolygonInclusion { position, .. }
                            | FenceItem::PolygonExclusion { position, .. } => to_local(position),
                            _ => Ned::default(),
                        })
                        .collect();
                    match group {
                        Some(group) => fence.inclusion.push((group, Zone::Polygon(vertices))),
                        None => fence.exclusion.push(Zone::Polygon(vertices)),
                    }
                    i += usize::from(vertex_count);
                }
                FenceItem::CircleInclusion {
                    radius_m,
                    group,
                    position,
                } => {
                    fence.inclusion.push((
                        group,
                        Zone::Circle {
                            centre: to_local(&position),
                            radius_m: f64::from(radius_m),
                        },
                    ));
                    i += 1;
                }
                FenceItem::CircleExclusion { radius_m, position } => {
                    fence.exclusion.push(Zone::Circle {
                        centre: to_local(&position),
                        radius_m: f64::from(radius_m),
                    });
                    i += 1;
                }
                _ => i += 1,
            }
        }
        fence
    }

    pub fn is_empty(&self) -> bool {
        self.inclusion.is_empty() && self.exclusion.is_empty()
    }

    pub fn breach(&self, p: &Ned) -> Option<Breach> {
        if self.exclusion.iter().any(|z| z.contains(p)) {
            return Some(Breach::InsideExclusion);
        }
        if self.inclusion.is_empty() {
            return None;
        }
        let mut groups: Vec<u8> = self.inclusion.iter().map(|(g, _)| *g).collect();
        groups.sort_unstable();
        groups.dedup();
        let inside_a_group = groups.iter().any(|g| {
            self.inclusion
                .iter()
                .filter(|(zg, _)| zg == g)
                .all(|(_, z)| z.contains(p))
        });
        if inside_a_group {
            None
        } else {
            Some(Breach::OutsideInclusion)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(size: f64) -> Vec<Ned> {
        vec![
            Ned::new(0.0, 0.0),
            Ned::new(size, 0.0),
            Ned::new(size, size),
            Ned::new(0.0, size),
        ]
    }

    #[test]
    fn a_fence_around_the_south_pole_holds_the_pole_in() {
        use crate::geo::GeoPoint;
        use mission::command::{cmd, frame};
        // A square of vertices 222 m from the pole on four meridians, seen
        // from an origin 111 m away: in latitude/longitude it is a line.
        let vertex = |seq: u16, lon_deg: f64| MissionItem {
            seq,
            frame: frame::GLOBAL_INT,
            command: cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            current: false,
            autocontinue: true,
            params: [4.0, 0.0, 0.0, 0.0],
            x: -899_980_000,
            y: (lon_deg * 1e7) as i32,
            z: 0.0,
        };
        let items: Vec<MissionItem> = [0.0, 90.0, 180.0, -90.0]
            .iter()
            .zip(0..)
            .map(|(&lon, seq)| vertex(seq, lon))
            .collect();
        let local = LocalFrame::new(GeoPoint::new(-89.999, 30.0, 2800.0));
        let fence = Fence::from_items(&items, &local);
        let at = |lat: f64, lon: f64| local.to_local(&GeoPoint::new(lat, lon, 2800.0));
        assert_eq!(fence.breach(&at(-90.0, 0.0)), None, "the pole");
        assert_eq!(fence.breach(&at(-89.999, 135.0)), None, "across the pole");
        assert_eq!(fence.breach(&at(-89.999, -170.0)), None, "across ±180°");
        assert_eq!(
            fence.breach(&at(-89.997, 45.0)),
            Some(Breach::OutsideInclusion),
            "333 m out"
        );
    }

    #[test]
    fn polygon_containment() {
        //  (0,10)-----(10,10)
        //    |    . (5,5) in
        //  (0,0)------(10,0)     . (12,5) out
        let sq = square(10.0);
        assert!(point_in_polygon(&Ned::new(5.0, 5.0), &sq));
        assert!(!point_in_polygon(&Ned::new(12.0, 5.0), &sq));
        assert!(!point_in_polygon(&Ned::new(5.0, -0.1), &sq));
        // A concave "L": the notch is outside.
        let l = vec![
            Ned::new(0.0, 0.0),
            Ned::new(10.0, 0.0),
            Ned::new(10.0, 4.0),
            Ned::new(4.0, 4.0),
            Ned::new(4.0, 10.0),
            Ned::new(0.0, 10.0),
        ];
        assert!(point_in_polygon(&Ned::new(2.0, 8.0), &l));
        assert!(!point_in_polygon(&Ned::new(8.0, 8.0), &l));
    }

    #[test]
    fn inclusion_groups_and_exclusion() {
        let fence = Fence {
            inclusion: vec![
                (0, Zone::Polygon(square(10.0))),
                (
                    1,
                    Zone::Circle {
                        centre: Ned::new(50.0, 50.0),
                        radius_m: 5.0,
                    },
                ),
            ],
            exclusion: vec![Zone::Circle {
                centre: Ned::new(5.0, 5.0),
                radius_m: 1.0,
            }],
        };
        assert_eq!(fence.breach(&Ned::new(2.0, 2.0)), None);
        assert_eq!(fence.breach(&Ned::new(52.0, 50.0)), None, "inside another group");
        assert_eq!(fence.breach(&Ned::new(30.0, 30.0)), Some(Breach::OutsideInclusion));
        assert_eq!(fence.breach(&Ned::new(5.5, 5.0)), Some(Breach::InsideExclusion));
        // Two zones in one group: inside both is needed.
        let both = Fence {
            inclusion: vec![
                (0, Zone::Polygon(square(10.0))),
                (
                    0,
                    Zone::Circle {
                        centre: Ned::new(0.0, 0.0),
                        radius_m: 5.0,
                    },
                ),
            ],
            exclusion: vec![],
        };
        assert_eq!(both.breach(&Ned::new(1.0, 1.0)), None);
        assert_eq!(both.breach(&Ned::new(8.0, 8.0)), Some(Breach::OutsideInclusion));
    }
}
