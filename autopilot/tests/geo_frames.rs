//! Local frames against PROJ (tests/data/geo, written by
//! tests/tools/geo_fixtures.py), their round trips, the haversine frame's
//! derived error, the plane transform, and degenerate inputs.
//!
//! `cargo test -p autopilot --test geo_frames error_table -- --nocapture`
//! prints the error table quoted in `autopilot/src/geo/mod.rs`.
//!
//! Sources: docs/references.md §Seed 000.

use autopilot::geo::{
    Ellipsoid, FrameKind, GeoPoint, LocalFrame, Ned, PlaneTransform, ZoneWidth, wrap_pi, zone_meridian_deg,
};
use proptest::prelude::*;

/// A CSV fixture: `#` comment lines, a header, rows.
struct Fixture {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Fixture {
    fn load(name: &str) -> Fixture {
        let path = format!("{}/../tests/data/geo/{name}", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.is_empty());
        let header = lines.next().expect("header").split(',').map(str::to_owned).collect();
        let rows = lines.map(|l| l.split(',').map(str::to_owned).collect()).collect();
        Fixture { header, rows }
    }

    fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    }

    fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        self.rows.iter().map(move |cells| Row { fixture: self, cells })
    }
}

struct Row<'a> {
    fixture: &'a Fixture,
    cells: &'a [String],
}

impl Row<'_> {
    fn text(&self, name: &str) -> &str {
        &self.cells[self.fixture.column(name)]
    }

    fn num(&self, name: &str) -> f64 {
        self.text(name).parse().unwrap_or_else(|e| panic!("{name}: {e}"))
    }

    fn origin(&self) -> GeoPoint {
        let h0 = if self.fixture.header.iter().any(|h| h == "h0_m") {
            self.num("h0_m")
        } else {
            0.0
        };
        GeoPoint::new(self.num("lat0_deg"), self.num("lon0_deg"), h0)
    }

    fn point(&self) -> GeoPoint {
        GeoPoint::new(self.num("lat_deg"), self.num("lon_deg"), self.origin().alt_m)
    }

    fn enu(&self) -> Ned {
        Ned::new(self.num("north_m"), self.num("east_m"))
    }
}

/// Gauss–Krüger frames of tmerc.csv: column prefix, ellipsoid, zone meridian?
const GK_COLUMNS: [(&str, Ellipsoid, bool); 4] = [
    ("wgs84", Ellipsoid::Wgs84, false),
    ("iag75", Ellipsoid::Iag75, false),
    ("krassovsky", Ellipsoid::Krassovsky, false),
    ("wgs84_zone3", Ellipsoid::Wgs84, true),
];

fn gk_frame(row: &Row<'_>, ellipsoid: Ellipsoid, zone3: bool) -> LocalFrame {
    if zone3 {
        LocalFrame::gauss_kruger(ellipsoid, row.num("zone3_cm_deg"), row.origin(), None)
    } else {
        LocalFrame::with_kind(FrameKind::GaussKruger(ellipsoid), row.origin(), None)
    }
}

#[test]
fn tangent_plane_matches_proj_to_nanometres() {
    let enu = Fixture::load("enu.csv");
    let mut worst_m = 0.0f64;
    for row in enu.rows() {
        let got = LocalFrame::new(row.origin()).to_local(&row.point());
        let err = got.distance_to(&row.enu());
        // The fixture's 1e-7 m rounding dominates.
        assert!(
            err < 1e-6,
            "{} {} m {}°: {err}",
            row.text("origin"),
            row.num("dist_m"),
            row.num("bearing_deg")
        );
        worst_m = worst_m.max(err);
    }
    println!("tangent plane vs PROJ, all origins, out to 50 km: {:.1e} m", worst_m);
}

#[test]
fn gauss_kruger_matches_proj_to_nanometres() {
    let tm = Fixture::load("tmerc.csv");
    let mut worst_m = 0.0f64;
    for row in tm.rows() {
        for (prefix, ellipsoid, zone3) in GK_COLUMNS {
            let got = gk_frame(&row, ellipsoid, zone3).to_local(&row.point());
            let want = Ned::new(
                row.num(&format!("{prefix}_north_m")),
                row.num(&format!("{prefix}_east_m")),
            );
            let err = got.distance_to(&want);
            assert!(
                err < 1e-6,
                "{prefix} {} {} m {}°: {err}",
                row.text("origin"),
                row.num("dist_m"),
                row.num("bearing_deg")
            );
            worst_m = worst_m.max(err);
        }
    }
    println!(
        "Gauss-Krüger frames vs PROJ, all origins, out to 50 km: {:.1e} m",
        worst_m
    );
}

#[test]
fn gauss_kruger_projection_matches_proj_across_a_zone() {
    let wide = Fixture::load("tmerc_wide.csv");
    let mut worst_m = 0.0f64;
    for row in wide.rows() {
        let ellipsoid = match row.text("ellipsoid") {
            "wgs84" => Ellipsoid::Wgs84,
            "iag75" => Ellipsoid::Iag75,
            "krassovsky" => Ellipsoid::Krassovsky,
            other => panic!("{other}"),
        };
        let tm = autopilot::geo::TransverseMercator::new(ellipsoid, row.num("cm_deg"));
        let (north, east) = tm.forward(row.num("lat_deg"), row.num("lon_deg"));
        let err = (north - row.num("north_m")).hypot(east - row.num("east_m"));
        assert!(
            err < 1e-6,
            "{ellipsoid:?} {} {}: {err}",
            row.num("lat_deg"),
            row.num("lon_deg")
        );
        worst_m = worst_m.max(err);
        let (lat, lon) = tm.inverse(row.num("north_m"), row.num("east_m"));
        assert!((lat - row.num("lat_deg")).abs() < 1e-11 && (lon - row.num("lon_deg")).abs() < 1e-11);
    }
    println!(
        "Gauss-Krüger grid vs PROJ, 80° S to 80° N, ±3.5° of the meridian: {:.1e} m",
        worst_m
    );
}

/// The haversine frame's error vector about an origin, to second order in
/// distance (derivation in `geo::haversine`'s docs): the sphere's axis scales
/// against the ellipsoid's radii at the origin's height, the meridian radius's
/// change along the way (M′ = 3Me²sinφcosφ/(1 − e²sin²φ)), the prime
/// vertical's (N′ = Ne²sinφcosφ/(1 − e²sin²φ)), and the parallel's
/// curvature that the frame leaves out.
fn predicted_haversine_error(origin: &GeoPoint, exact: &Ned) -> Ned {
    const R: f64 = 6_371_000.0;
    let phi = origin.lat_deg.to_radians();
    let e2 = Ellipsoid::Wgs84.eccentricity_sq();
    let (m, n) = Ellipsoid::Wgs84.radii_of_curvature_m(phi);
    let (m, n) = (m + origin.alt_m, n + origin.alt_m);
    let k = e2 * phi.sin() * phi.cos() / (1.0 - e2 * (phi.sin()).powi(2));
    let (north, east) = (exact.north_m, exact.east_m);
    let parallel_m = east * east * phi.tan() / (2.0 * n);
    let meridian_m = north - parallel_m;
    let dlat = meridian_m / m - 1.5 * k * meridian_m * meridian_m / (m * m);
    Ned::new(R * dlat - north, east * R / n * (1.0 - k * dlat) - east)
}

#[test]
fn haversine_error_is_what_the_maths_says() {
    let enu = Fixture::load("enu.csv");
    for row in enu.rows() {
        let d = row.num("dist_m");
        if d == 0.0 {
            continue;
        }
        let origin = row.origin();
        let got = LocalFrame::with_kind(FrameKind::Haversine, origin, None).to_local(&row.point());
        let exact = row.enu();
        let error = Ned::new(got.north_m - exact.north_m, got.east_m - exact.east_m);
        let predicted = predicted_haversine_error(&origin, &exact);
        // What the second-order model leaves out is third order: d³/R².
        let bound_m = d.powi(3) / 6.0e6f64.powi(2) + 1e-7; // + the fixture's rounding
        let residual = error.distance_to(&predicted);
        let size = error.distance_to(&Ned::default());
        assert!(
            residual <= bound_m,
            "{} {d} m {}°: error {error:?}, predicted {predicted:?}, residual {residual} > {bound_m}",
            row.text("origin"),
            row.num("bearing_deg"),
        );
        // And it is an error, never zero: at least the smallest axis-scale
        // error the sphere has anywhere (east at the equator, R/N − 1 = −0.11 %).
        assert!(size > 0.9e-3 * d, "{} {d}: {size}", row.text("origin"));
    }
}

/// Seed 000 eq. 2 (the origin's latitude for east), for the table only.
fn haversine_eq2(origin: &GeoPoint, p: &GeoPoint) -> Ned {
    let two_r = 2.0 * 6_371_000.0;
    let dlat = (p.lat_deg - origin.lat_deg).to_radians();
    let dlon = wrap_pi((p.lon_deg - origin.lon_deg).to_radians());
    Ned::new(
        two_r * (dlat / 2.0).sin(),
        two_r * origin.lat_deg.to_radians().cos() * (dlon / 2.0).sin(),
    )
}

#[test]
fn eq3_beats_eq2_by_the_meridian_convergence() {
    // 10 km north-east of the bench origin: eq. 2 takes the origin's
    // parallel for east, so it misses the meridians' convergence,
    // ≈ north·east·tan φ₀ / R (about 4.3 m); eq. 3 does not.
    let enu = Fixture::load("enu.csv");
    let row = enu
        .rows()
        .find(|r| r.text("origin") == "bench" && r.num("dist_m") == 10_000.0 && r.num("bearing_deg") == 45.0)
        .expect("fixture row");
    let (origin, p, exact) = (row.origin(), row.point(), row.enu());
    let eq3 = LocalFrame::with_kind(FrameKind::Haversine, origin, None).to_local(&p);
    let eq2 = haversine_eq2(&origin, &p);
    let convergence_m = exact.north_m * exact.east_m * origin.lat_deg.to_radians().tan() / 6_371_000.0;
    assert!(
        ((eq2.east_m - eq3.east_m) - convergence_m).abs() < 0.01 * convergence_m,
        "{eq2:?} {eq3:?}"
    );
    let scale_only = predicted_haversine_error(&origin, &exact);
    assert!((eq3.east_m - exact.east_m - scale_only.east_m).abs() < 0.05);
    assert!((eq2.east_m - exact.east_m - scale_only.east_m).abs() > 4.0);
}

/// Local position of a point about an origin, one frame's way.
type Projector<'a> = dyn Fn(&GeoPoint, &GeoPoint) -> Ned + 'a;

/// Worst position error (mm) and signed distance error (mm, ppm) over the
/// bench rows at one distance.
fn worst(enu: &Fixture, dist_m: f64, local: &Projector<'_>) -> (f64, f64, f64) {
    let (mut pos_mm, mut dist_mm) = (0.0f64, 0.0f64);
    for row in enu
        .rows()
        .filter(|r| r.text("origin") == "bench" && r.num("dist_m") == dist_m)
    {
        let got = local(&row.origin(), &row.point());
        pos_mm = pos_mm.max(got.distance_to(&row.enu()) * 1e3);
        let err_mm = (got.distance_to(&Ned::default()) - row.num("ground_m")) * 1e3;
        if err_mm.abs() > dist_mm.abs() {
            dist_mm = err_mm;
        }
    }
    (pos_mm, dist_mm, dist_mm / dist_m * 1e3)
}

#[test]
fn error_table() {
    let enu = Fixture::load("enu.csv");
    let kind = |kind: FrameKind| move |o: &GeoPoint, p: &GeoPoint| LocalFrame::with_kind(kind, *o, None).to_local(p);
    let zone = |o: &GeoPoint, p: &GeoPoint| {
        let cm = zone_meridian_deg(o.lon_deg, ZoneWidth::Three);
        LocalFrame::gauss_kruger(Ellipsoid::Wgs84, cm, *o, None).to_local(p)
    };
    let frames: [(&str, &Projector<'_>); 6] = [
        ("tangent plane (`GEO_FRAME=0`)", &kind(FrameKind::TangentPlane)),
        ("haversine, eq. 3 (`GEO_FRAME=1`)", &kind(FrameKind::Haversine)),
        (
            "Gauss–Krüger WGS-84 (`=2`)",
            &kind(FrameKind::GaussKruger(Ellipsoid::Wgs84)),
        ),
        ("Gauss–Krüger IAG-75", &kind(FrameKind::GaussKruger(Ellipsoid::Iag75))),
        (
            "Gauss–Krüger Krassovsky",
            &kind(FrameKind::GaussKruger(Ellipsoid::Krassovsky)),
        ),
        ("Gauss–Krüger WGS-84, 120° E zone meridian", &zone),
    ];
    println!(
        "| frame | 100 m: position | 100 m: distance | 1 km: position | 1 km: distance | 10 km: position | 10 km: distance |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let mut measured = Vec::new();
    for (name, local) in frames {
        let mut line = format!("| {name} |");
        for dist in [100.0, 1000.0, 10_000.0] {
            let (pos_mm, dist_mm, ppm) = worst(&enu, dist, local);
            line += &format!(
                " {} | {} ({} ppm) |",
                fmt_mm(pos_mm),
                fmt_signed(dist_mm, 1e-3, " mm"),
                fmt_signed(ppm, 1e-3, "")
            );
            measured.push((name, dist, pos_mm, ppm));
        }
        println!("{line}");
    }
    // The table's claims, so it cannot silently go stale.
    for (name, dist, pos_mm, ppm) in measured {
        match name {
            n if n.starts_with("tangent") => assert!(pos_mm < 1e-3 && ppm.abs() < 0.5, "{n} {dist}"),
            n if n.starts_with("haversine") => assert!(ppm.abs() > 1800.0 && ppm.abs() < 3300.0, "{n} {dist}"),
            // The grid ignores the 40 m height: −h/R = −6.3 ppm.
            "Gauss–Krüger WGS-84 (`=2`)" => {
                assert!(pos_mm < 7e-3 * dist && (ppm + 6.3).abs() < 0.5, "{name} {dist}")
            }
            _ => {}
        }
    }
}

fn fmt_mm(mm: f64) -> String {
    if mm < 1e-3 {
        "< 0.001 mm".to_owned()
    } else {
        format!("{} mm", sig3(mm))
    }
}

/// Signed, three significant digits, "< floor" below the floor.
fn fmt_signed(x: f64, floor: f64, unit: &str) -> String {
    if x.abs() < floor {
        format!("< {floor}{unit}")
    } else {
        format!("{}{}{unit}", if x < 0.0 { "-" } else { "+" }, sig3(x.abs()))
    }
}

/// Three significant digits, no exponent.
fn sig3(x: f64) -> String {
    let decimals = (2 - x.log10().floor() as i32).max(0) as usize;
    format!("{x:.decimals$}")
}

#[test]
fn plane_transform_from_two_points_reproduces_a_known_transform() {
    let truth = PlaneTransform {
        shift_north_m: 2150.25,
        shift_east_m: -730.5,
        rotation_rad: -0.61,
        scale: 0.999_85,
    };
    let (a, b, c) = (Ned::new(12.0, -40.0), Ned::new(830.0, 515.5), Ned::new(-260.0, 1200.0));
    let fitted = PlaneTransform::from_two_points((a, truth.apply(&a)), (b, truth.apply(&b))).expect("two points");
    assert!((fitted.rotation_rad - truth.rotation_rad).abs() < 1e-12);
    assert!((fitted.scale - truth.scale).abs() < 1e-12);
    assert!((fitted.shift_north_m - truth.shift_north_m).abs() < 1e-9);
    assert!((fitted.shift_east_m - truth.shift_east_m).abs() < 1e-9);
    assert!(fitted.apply(&c).distance_to(&truth.apply(&c)) < 1e-9, "a third point");
}

#[test]
fn a_plant_grid_fitted_from_two_surveyed_points_maps_a_third() {
    // The site was surveyed in a plant grid; two of its marks were also
    // measured with RTK. Fit GK(origin) → plant grid and check the third.
    let origin = GeoPoint::new(29.133, 119.64, 40.0);
    let plant = PlaneTransform {
        shift_north_m: 500.0,
        shift_east_m: 800.0,
        rotation_rad: 0.3,
        scale: 1.0,
    };
    let gk = LocalFrame::with_kind(FrameKind::GaussKruger(Ellipsoid::Wgs84), origin, None);
    let marks = [
        GeoPoint::new(29.1345, 119.641, 40.0),
        GeoPoint::new(29.1322, 119.6455, 40.0),
    ];
    let pairs = marks.map(|m| (gk.to_local(&m), plant.apply(&gk.to_local(&m))));
    let fitted = PlaneTransform::from_two_points(pairs[0], pairs[1]).unwrap();
    let site = LocalFrame::with_kind(FrameKind::GaussKruger(Ellipsoid::Wgs84), origin, Some(fitted));
    let third = GeoPoint::new(29.1301, 119.6389, 40.0);
    let want = plant.apply(&gk.to_local(&third));
    assert!(site.to_local(&third).distance_to(&want) < 1e-9);
    let back = site.to_geodetic(&want);
    assert!((back.lat_deg - third.lat_deg).abs() < 1e-12 && (back.lon_deg - third.lon_deg).abs() < 1e-12);
    assert_eq!(site.map(), Some(fitted));
}

#[test]
fn headings_turn_by_the_meridian_convergence() {
    let origin = GeoPoint::new(29.133, 119.64, 40.0);
    let frame = LocalFrame::new(origin);
    assert!((frame.heading_to_local(&origin, 0.7) - 0.7).abs() < 1e-9);
    // 10 km east of the origin true north is turned by ≈ e·tan φ / N.
    let east = frame.to_geodetic(&Ned::new(0.0, 10_000.0));
    let convergence = frame.heading_to_local(&east, 0.0);
    let expected = -10_000.0 * 29.133f64.to_radians().tan() / 6_383_000.0;
    assert!((convergence - expected).abs() < 2e-6, "{convergence} vs {expected}");
    for h in [-3.0, -1.0, 0.0, 0.4, 2.5] {
        let local = frame.heading_to_local(&east, h);
        assert!(wrap_pi(frame.heading_to_true(&east, local) - h).abs() < 1e-9);
    }
    // A map rotation adds to every heading.
    let rotated = PlaneTransform {
        rotation_rad: 0.5,
        ..PlaneTransform::IDENTITY
    };
    let mapped = LocalFrame::with_kind(FrameKind::TangentPlane, origin, Some(rotated));
    let h = mapped.heading_to_local(&origin, 0.2);
    assert!((h - 0.7).abs() < 1e-9, "{h}");
}

#[test]
fn degenerate_inputs_do_not_panic() {
    let kinds = [
        FrameKind::TangentPlane,
        FrameKind::Haversine,
        FrameKind::GaussKruger(Ellipsoid::Wgs84),
        FrameKind::GaussKruger(Ellipsoid::Krassovsky),
    ];
    let odd = [
        GeoPoint::new(90.0, 0.0, 0.0),
        GeoPoint::new(-90.0, 123.0, 0.0),
        GeoPoint::new(89.999_999, -180.0, 0.0),
        GeoPoint::new(f64::NAN, 0.0, 0.0),
        GeoPoint::new(0.0, f64::INFINITY, 0.0),
        GeoPoint::new(0.0, 0.0, f64::NAN),
        GeoPoint::new(1e300, -1e300, 0.0),
    ];
    let zero_scale = PlaneTransform {
        scale: 0.0,
        ..PlaneTransform::IDENTITY
    };
    for kind in kinds {
        for origin in odd {
            for map in [None, Some(zero_scale), Some(PlaneTransform::IDENTITY)] {
                let frame = LocalFrame::with_kind(kind, origin, map);
                for p in odd {
                    let local = frame.to_local(&p);
                    let _ = frame.to_geodetic(&local);
                    let _ = frame.heading_to_local(&p, 1.0);
                    let _ = frame.heading_to_true(&p, 1.0);
                }
                let _ = frame.to_geodetic(&Ned::new(f64::NAN, 1e9));
                let _ = frame.to_geodetic(&Ned::new(2e7, -2e7));
            }
        }
    }
    // An uninvertible map reports NaN rather than a wrong position.
    let frame = LocalFrame::with_kind(
        FrameKind::TangentPlane,
        GeoPoint::new(29.0, 119.0, 0.0),
        Some(zero_scale),
    );
    assert!(!frame.to_geodetic(&Ned::new(1.0, 1.0)).is_valid());
    let p = Ned::new(3.0, 4.0);
    assert!(PlaneTransform::from_two_points((p, p), (p, Ned::new(9.0, 9.0))).is_none());
}

#[test]
fn frames_at_a_pole_still_round_trip() {
    // Longitude means nothing at the pole, but positions around it do.
    for origin in [GeoPoint::new(90.0, 0.0, 0.0), GeoPoint::new(-89.95, 45.0, 10.0)] {
        for kind in [FrameKind::TangentPlane, FrameKind::GaussKruger(Ellipsoid::Wgs84)] {
            let frame = LocalFrame::with_kind(kind, origin, None);
            for (n, e) in [(1000.0, 0.0), (-3000.0, 2500.0), (0.0, -20_000.0)] {
                let back = frame.to_local(&frame.to_geodetic(&Ned::new(n, e)));
                assert!(
                    back.distance_to(&Ned::new(n, e)) < 1e-6,
                    "{kind:?} {origin:?} {n} {e}: {back:?}"
                );
            }
        }
    }
}

#[test]
fn round_trip_sweep() {
    // Deterministic companion of the property test: the worst round trip
    // per kind over origins from the equator to 85°, both sides of ±180°,
    // and points out to 50 km.
    let kinds = [
        (FrameKind::TangentPlane, false),
        (FrameKind::Haversine, false),
        (FrameKind::GaussKruger(Ellipsoid::Wgs84), false),
        (FrameKind::GaussKruger(Ellipsoid::Krassovsky), false),
        (FrameKind::GaussKruger(Ellipsoid::Wgs84), true),
    ];
    let map = PlaneTransform {
        shift_north_m: 4000.0,
        shift_east_m: -9000.0,
        rotation_rad: 2.0,
        scale: 1.05,
    };
    for (kind, zone) in kinds {
        let mut worst_m = 0.0f64;
        for lat0 in [-85.0, -33.9, 0.0, 29.133, 60.0, 85.0] {
            for lon0 in [-179.99, 0.0, 119.64, 179.99] {
                for map in [None, Some(map)] {
                    let frame = frame_of(kind, zone, GeoPoint::new(lat0, lon0, 40.0), map);
                    for range_m in [1.0, 100.0, 1000.0, 10_000.0, 50_000.0] {
                        for i in 0..16 {
                            let bearing = f64::from(i) * std::f64::consts::TAU / 16.0;
                            let local = Ned::new(range_m * bearing.cos(), range_m * bearing.sin());
                            let back = frame.to_local(&frame.to_geodetic(&local));
                            worst_m = worst_m.max(back.distance_to(&local));
                        }
                    }
                }
            }
        }
        println!("{kind:?} (zone meridian: {zone}): worst round trip {worst_m:.1e} m");
        assert!(worst_m < 1e-6, "{kind:?}: {worst_m}");
    }
}

fn any_kind() -> impl Strategy<Value = (FrameKind, bool)> {
    prop_oneof![
        Just((FrameKind::TangentPlane, false)),
        Just((FrameKind::Haversine, false)),
        Just((FrameKind::GaussKruger(Ellipsoid::Wgs84), false)),
        Just((FrameKind::GaussKruger(Ellipsoid::Iag75), false)),
        Just((FrameKind::GaussKruger(Ellipsoid::Krassovsky), false)),
        // Gauss–Krüger with the 6° zone's meridian: up to 3° plus 50 km off it.
        Just((FrameKind::GaussKruger(Ellipsoid::Wgs84), true)),
    ]
}

fn any_map() -> impl Strategy<Value = Option<PlaneTransform>> {
    prop_oneof![
        Just(None),
        (
            -1e4..1e4f64,
            -1e4..1e4f64,
            -std::f64::consts::PI..std::f64::consts::PI,
            0.9..1.1f64
        )
            .prop_map(|(n, e, r, s)| Some(PlaneTransform {
                shift_north_m: n,
                shift_east_m: e,
                rotation_rad: r,
                scale: s
            })),
    ]
}

fn frame_of(kind: FrameKind, zone: bool, origin: GeoPoint, map: Option<PlaneTransform>) -> LocalFrame {
    match (kind, zone) {
        (FrameKind::GaussKruger(ellipsoid), true) => LocalFrame::gauss_kruger(
            ellipsoid,
            zone_meridian_deg(origin.lon_deg, ZoneWidth::Six),
            origin,
            map,
        ),
        _ => LocalFrame::with_kind(kind, origin, map),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn every_kind_round_trips_within_50_km(
        (kind, zone) in any_kind(),
        map in any_map(),
        lat0 in -85.0..85.0f64,
        lon0 in -180.0..180.0f64,
        h0 in -100.0..3000.0f64,
        range_m in 0.0..50_000.0f64,
        bearing in 0.0..std::f64::consts::TAU,
    ) {
        let origin = GeoPoint::new(lat0, lon0, h0);
        let frame = frame_of(kind, zone, origin, map);
        // A local point within 50 km (of the origin, before the map).
        let unmapped = Ned::new(range_m * bearing.cos(), range_m * bearing.sin());
        let local = map.map_or(unmapped, |m| m.apply(&unmapped));
        let geo = frame.to_geodetic(&local);
        prop_assert!(geo.is_valid(), "{geo:?}");
        let back = frame.to_local(&geo);
        prop_assert!(back.distance_to(&local) < 1e-6, "local → geo → local: {} m", back.distance_to(&local));
        // And from the geodetic side: the position found again, in metres.
        let again = frame.to_geodetic(&back);
        let lat_m = (again.lat_deg - geo.lat_deg).to_radians() * 6.4e6;
        let lon_m = wrap_pi((again.lon_deg - geo.lon_deg).to_radians()) * 6.4e6 * geo.lat_deg.to_radians().cos();
        prop_assert!(lat_m.hypot(lon_m) < 1e-6, "geo → local → geo: {} m", lat_m.hypot(lon_m));
    }
}

/// The worst error per origin of polar.csv, printed for the README's table.
fn report(what: &str, worst: &std::collections::BTreeMap<String, f64>, unit: &str) {
    for (origin, err) in worst {
        println!("{what} {origin}: {err:.1e} {unit}");
    }
}

fn note_worst(worst: &mut std::collections::BTreeMap<String, f64>, origin: &str, err: f64) {
    let entry = worst.entry(origin.to_owned()).or_insert(0.0);
    *entry = entry.max(err);
}

/// polar.csv: 1 µm for positions (the fixture is rounded to 0.1 µm).
const POLAR_POSITION_TOL_M: f64 = 1e-6;

#[test]
fn tangent_plane_holds_at_the_poles_the_antimeridian_and_0_0() {
    let polar = Fixture::load("polar.csv");
    let (mut forward, mut inverse) = (Default::default(), Default::default());
    for row in polar.rows() {
        let frame = LocalFrame::new(row.origin());
        let err = frame.to_local(&row.point()).distance_to(&row.enu());
        let label = format!(
            "{} {} m {}°",
            row.text("origin"),
            row.num("dist_m"),
            row.num("bearing_deg")
        );
        assert!(err < POLAR_POSITION_TOL_M, "to_local {label}: {err} m");
        note_worst(&mut forward, row.text("origin"), err);
        // The inverse lands on the fixture's point: measured as a distance
        // in the point's own tangent plane (longitude means little there).
        let back = frame.to_geodetic(&row.enu());
        let err = LocalFrame::new(row.point())
            .to_local(&back)
            .distance_to(&Ned::default());
        assert!(err < POLAR_POSITION_TOL_M, "to_geodetic {label}: {err} m");
        note_worst(&mut inverse, row.text("origin"), err);
    }
    report("tangent plane to_local vs PROJ", &forward, "m");
    report("tangent plane to_geodetic vs PROJ", &inverse, "m");
}

#[test]
fn gauss_kruger_holds_at_the_poles_the_antimeridian_and_0_0() {
    let polar = Fixture::load("polar.csv");
    let mut worst = Default::default();
    for row in polar.rows() {
        let frame = LocalFrame::with_kind(FrameKind::GaussKruger(Ellipsoid::Wgs84), row.origin(), None);
        let want = Ned::new(row.num("wgs84_north_m"), row.num("wgs84_east_m"));
        let err = frame.to_local(&row.point()).distance_to(&want);
        let label = format!(
            "{} {} m {}°",
            row.text("origin"),
            row.num("dist_m"),
            row.num("bearing_deg")
        );
        assert!(err < POLAR_POSITION_TOL_M, "{label}: {err} m");
        let back = frame.to_local(&frame.to_geodetic(&want)).distance_to(&want);
        assert!(back < POLAR_POSITION_TOL_M, "round trip {label}: {back} m");
        note_worst(&mut worst, row.text("origin"), err);
    }
    report("Gauss-Krüger vs PROJ", &worst, "m");
}

/// Headings in polar.csv are GeographicLib azimuths turned into the frame
/// by central differences along the geodesic: good to ~1e-8°.
const POLAR_HEADING_TOL_DEG: f64 = 1e-6;

#[test]
fn headings_hold_at_the_poles_the_antimeridian_and_0_0() {
    let polar = Fixture::load("polar.csv");
    let mut worst = std::collections::BTreeMap::new();
    for row in polar.rows() {
        let azimuth = row.num("azimuth_deg").to_radians();
        let label = format!(
            "{} {} m {}°",
            row.text("origin"),
            row.num("dist_m"),
            row.num("bearing_deg")
        );
        for (kind, column) in [
            (FrameKind::TangentPlane, "local_heading_deg"),
            (FrameKind::GaussKruger(Ellipsoid::Wgs84), "gk_heading_deg"),
        ] {
            let frame = LocalFrame::with_kind(kind, row.origin(), None);
            let local = frame.heading_to_local(&row.point(), azimuth);
            let err_deg = wrap_pi(local - row.num(column).to_radians()).to_degrees().abs();
            assert!(err_deg < POLAR_HEADING_TOL_DEG, "{kind:?} {label}: {err_deg}°");
            let back_deg = wrap_pi(frame.heading_to_true(&row.point(), local) - azimuth)
                .to_degrees()
                .abs();
            assert!(back_deg < POLAR_HEADING_TOL_DEG, "{kind:?} back {label}: {back_deg}°");
            note_worst(&mut worst, &format!("{column} {}", row.text("origin")), err_deg);
        }
    }
    report("heading vs GeographicLib", &worst, "deg");
}
