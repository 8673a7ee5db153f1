#!/usr/bin/env python3
"""Reference data for Furrow's local frames (autopilot/src/geo), from PROJ.

The Rust frames are checked against an implementation they share no code
with: PROJ through pyproj. This script writes the committed CSVs under
tests/data/geo/; CI reads those and never needs pyproj.

How it was run (pyproj 3.7.2, PROJ 9.5.1, Python 3.11.7):

    target/venv/bin/pip install pyproj        # generation only, not CI
    target/venv/bin/python tests/tools/geo_fixtures.py

Files (every row is one point; angles in degrees, lengths in metres):

- enu.csv: for each origin, points at 0, 10, 100, 1000, 10000 and 50000 m
  along eight bearings (geodesic direct problem, pyproj.Geod), at the
  origin's height. Columns: the exact east/north/up about the origin
  (geodetic -> ECEF -> topocentric PROJ pipeline), the geodesic length on
  the ellipsoid, and `ground_m`: that length at the origin's height,
  geodesic * (1 + h0 / R_alpha) with R_alpha Euler's radius of curvature
  along the line (the first-order height reduction: what it leaves out is
  of order (h0/R)**2 and h0/R times R_alpha's change along the line, below
  1e-8 relative for these heights and lengths, 1e-10 at the bench).
- tmerc.csv: the same points, Gauss-Krüger (transverse Mercator, k0 = 1,
  PROJ's exact Poder/Engsager algorithm) relative to the origin's grid
  position, for WGS-84, IAG-75 and Krassovsky with the central meridian
  at the origin, and for WGS-84 with the 3-degree zone's meridian.
- tmerc_wide.csv: absolute grid coordinates from the equator to 80 degrees
  and up to 3.5 degrees from the central meridian, per ellipsoid: checks
  the projection itself across a whole 6-degree zone.
- polar.csv: "any latitude": origins at and within 1 km of both
  poles, on and beside the antimeridian and at 0, 0, with points at 0, 1,
  10, 100, 500 and 1000 m along eight bearings (crossing the pole from the
  origins beside it). Columns: the topocentric east/north/up as enu.csv,
  the WGS-84 Gauss-Krüger grid relative to the origin's (central meridian
  at the origin), and a heading: `azimuth_deg`, a true azimuth at the point
  (the bearing + 37 degrees), with `local_heading_deg` / `gk_heading_deg`
  the heading of that direction in the topocentric / Gauss-Krüger frame:
  the direction from the point 1 m back to 1 m ahead along the geodesic
  with that azimuth (pyproj.Geod, GeographicLib), projected. A geodesic is
  straight to second order, so this central difference is exact to
  ~1e-13 rad; coordinate rounding in the projections (~1e-9 m over 2 m)
  leaves ~1e-9 rad. At a pole an azimuth is GeographicLib's: from the
  limit of north along the point's meridian.
"""

import csv
import math
import os

import pyproj
from pyproj import Geod, Transformer

OUT_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "geo")

# (name, lat, lon, height) — the bench site first; the others stress the
# equator, high latitude, the southern hemisphere and the antimeridian.
ORIGINS = [
    ("bench", 29.133, 119.64, 40.0),
    ("equator", 0.0, 10.0, 0.0),
    ("north60", 60.0, 25.0, 100.0),
    ("south34", -33.9, 151.2, 50.0),
    ("antimeridian_e", -17.8, 179.9, 0.0),
    ("antimeridian_w", 65.0, -179.95, 250.0),
]
DISTANCES_M = [0.0, 10.0, 100.0, 1000.0, 10000.0, 50000.0]
BEARINGS_DEG = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]

# (name, PROJ ellipsoid parameters). Custom a/rf for the two Chinese datums'
# ellipsoids so the test uses exactly the constants in geo/ellipsoid.rs.
ELLIPSOIDS = [
    ("wgs84", "+a=6378137 +rf=298.257223563"),
    ("iag75", "+a=6378140 +rf=298.257"),
    ("krassovsky", "+a=6378245 +rf=298.3"),
]

# "Any latitude": (name, lat, lon, height). 0.001 degree of latitude is
# 111.7 m; 89.99 degrees is 1.1 km from the pole.
POLAR_ORIGINS = [
    ("south_pole", -90.0, 0.0, 2835.0),
    ("south_111m", -89.999, 30.0, 2800.0),
    ("south_1km", -89.991, -150.0, 2800.0),
    ("north_pole", 90.0, 0.0, 0.0),
    ("north_5m", 89.999955, 179.9, 0.0),
    ("north_1100m", 89.99, 45.0, 10.0),
    ("antimeridian_180", 0.0, 180.0, 0.0),
    ("antimeridian_s", -17.8, 179.99985, 5.0),
    ("antimeridian_n", 65.0, -179.9999, 250.0),
    ("null_island", 0.0, 0.0, 0.0),
]
POLAR_DISTANCES_M = [0.0, 1.0, 10.0, 100.0, 500.0, 1000.0]
# Half the baseline of the central difference giving a heading.
HEADING_STEP_M = 1.0

WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563


def zone3_meridian(lon):
    """Central meridian of the 3-degree Gauss-Krüger zone holding `lon`."""
    return 3.0 * round(lon / 3.0)


def tmerc(lon_0, ellps):
    return Transformer.from_pipeline(f"+proj=tmerc +lat_0=0 +lon_0={lon_0!r} +k=1 +x_0=0 +y_0=0 {ellps}")


def euler_radius(lat_deg, azimuth_deg):
    """Radius of curvature of the WGS-84 ellipsoid along an azimuth."""
    e2 = WGS84_F * (2.0 - WGS84_F)
    s = math.sin(math.radians(lat_deg))
    w2 = 1.0 - e2 * s * s
    meridian = WGS84_A * (1.0 - e2) / (w2 * math.sqrt(w2))
    normal = WGS84_A / math.sqrt(w2)
    a = math.radians(azimuth_deg)
    return 1.0 / (math.cos(a) ** 2 / meridian + math.sin(a) ** 2 / normal)


def points(origins=ORIGINS, distances=DISTANCES_M):
    """Every (origin, distance, bearing, point) of enu.csv and tmerc.csv."""
    geod = Geod(ellps="WGS84")
    for name, lat0, lon0, h0 in origins:
        for dist in distances:
            for bearing in BEARINGS_DEG if dist > 0.0 else [0.0]:
                if dist > 0.0:
                    lon, lat, _ = geod.fwd(lon0, lat0, bearing, dist)
                    _, _, geodesic = geod.inv(lon0, lat0, lon, lat)
                else:
                    lon, lat, geodesic = lon0, lat0, 0.0
                if lon > 180.0:
                    lon -= 360.0
                if lon < -180.0:
                    lon += 360.0
                yield (name, lat0, lon0, h0, dist, bearing, lat, lon, geodesic)


def write_enu(rows):
    path = os.path.join(OUT_DIR, "enu.csv")
    with open(path, "w", newline="") as f:
        f.write(f"# Generated by tests/tools/geo_fixtures.py with pyproj {pyproj.__version__} "
                f"(PROJ {pyproj.proj_version_str}). Do not edit.\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["origin", "lat0_deg", "lon0_deg", "h0_m", "dist_m", "bearing_deg", "lat_deg", "lon_deg",
                    "east_m", "north_m", "up_m", "geodesic_m", "ground_m"])
        for name, lat0, lon0, h0, dist, bearing, lat, lon, geodesic in rows:
            enu = Transformer.from_pipeline(
                "+proj=pipeline +step +proj=cart +ellps=WGS84 "
                f"+step +proj=topocentric +ellps=WGS84 +lat_0={lat0!r} +lon_0={lon0!r} +h_0={h0!r}")
            east, north, up = enu.transform(lon, lat, h0)
            ground = geodesic * (1.0 + h0 / euler_radius(lat0, bearing))
            w.writerow([name, repr(lat0), repr(lon0), repr(h0), repr(dist), repr(bearing), repr(lat),
                        repr(lon), f"{east:.7f}", f"{north:.7f}", f"{up:.7f}", f"{geodesic:.7f}",
                        f"{ground:.7f}"])


def write_tmerc(rows):
    path = os.path.join(OUT_DIR, "tmerc.csv")
    with open(path, "w", newline="") as f:
        f.write(f"# Generated by tests/tools/geo_fixtures.py with pyproj {pyproj.__version__} "
                f"(PROJ {pyproj.proj_version_str}). Do not edit.\n")
        f.write("# Grid position of the point minus that of the origin; k0 = 1; *_zone3: WGS-84 with the\n"
                "# central meridian of the 3-degree zone (zone3_cm_deg).\n")
        w = csv.writer(f, lineterminator="\n")
        header = ["origin", "lat0_deg", "lon0_deg", "dist_m", "bearing_deg", "lat_deg", "lon_deg"]
        for ell, _ in ELLIPSOIDS:
            header += [f"{ell}_north_m", f"{ell}_east_m"]
        header += ["zone3_cm_deg", "wgs84_zone3_north_m", "wgs84_zone3_east_m"]
        w.writerow(header)
        for name, lat0, lon0, _h0, dist, bearing, lat, lon, _geodesic in rows:
            row = [name, repr(lat0), repr(lon0), repr(dist), repr(bearing), repr(lat), repr(lon)]
            projections = [(tmerc(lon0, ellps), None) for _, ellps in ELLIPSOIDS]
            cm = zone3_meridian(lon0)
            projections.append((tmerc(cm, ELLIPSOIDS[0][1]), cm))
            for t, zone_cm in projections:
                e0, n0 = t.transform(lon0, lat0)
                e, n = t.transform(lon, lat)
                if zone_cm is not None:
                    row.append(repr(zone_cm))
                row += [f"{n - n0:.7f}", f"{e - e0:.7f}"]
            w.writerow(row)


def write_tmerc_wide():
    path = os.path.join(OUT_DIR, "tmerc_wide.csv")
    with open(path, "w", newline="") as f:
        f.write(f"# Generated by tests/tools/geo_fixtures.py with pyproj {pyproj.__version__} "
                f"(PROJ {pyproj.proj_version_str}). Do not edit.\n")
        f.write("# Absolute Gauss-Krüger grid coordinates, k0 = 1, no false easting/northing.\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["ellipsoid", "cm_deg", "lat_deg", "lon_deg", "north_m", "east_m"])
        cm = 117.0
        for ell, ellps in ELLIPSOIDS:
            t = tmerc(cm, ellps)
            for lat in [-80.0, -45.5, -10.0, 0.0, 0.5, 15.0, 29.133, 45.0, 60.0, 80.0]:
                for dlon in [-3.5, -3.0, -1.5, -0.25, 0.0, 0.75, 2.0, 3.0, 3.5]:
                    lon = cm + dlon
                    e, n = t.transform(lon, lat)
                    w.writerow([ell, repr(cm), repr(lat), repr(lon), f"{n:.7f}", f"{e:.7f}"])


def topocentric(lat0, lon0, h0):
    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={lat0!r} +lon_0={lon0!r} +h_0={h0!r}")


def heading_in(project, lat, lon, azimuth):
    """Heading (degrees from the frame's north axis) of the true azimuth at
    (lat, lon): `project(lon, lat) -> (north, east)` applied to the points
    HEADING_STEP_M behind and ahead along the geodesic."""
    geod = Geod(ellps="WGS84")
    ahead_lon, ahead_lat, _ = geod.fwd(lon, lat, azimuth, HEADING_STEP_M)
    behind_lon, behind_lat, _ = geod.fwd(lon, lat, azimuth + 180.0, HEADING_STEP_M)
    n1, e1 = project(ahead_lon, ahead_lat)
    n0, e0 = project(behind_lon, behind_lat)
    return math.degrees(math.atan2(e1 - e0, n1 - n0))


def write_polar():
    path = os.path.join(OUT_DIR, "polar.csv")
    with open(path, "w", newline="") as f:
        f.write(f"# Generated by tests/tools/geo_fixtures.py with pyproj {pyproj.__version__} "
                f"(PROJ {pyproj.proj_version_str}). Do not edit.\n")
        f.write("# Within 1 km of the poles, across the antimeridian, at 0,0: topocentric ENU, WGS-84\n"
                "# Gauss-Kruger relative to the origin (central meridian at the origin), and the heading of\n"
                "# the true azimuth azimuth_deg at the point in either frame.\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["origin", "lat0_deg", "lon0_deg", "h0_m", "dist_m", "bearing_deg", "lat_deg", "lon_deg",
                    "east_m", "north_m", "up_m", "wgs84_north_m", "wgs84_east_m", "azimuth_deg",
                    "local_heading_deg", "gk_heading_deg"])
        for name, lat0, lon0, h0, dist, bearing, lat, lon, _geodesic in points(POLAR_ORIGINS, POLAR_DISTANCES_M):
            enu = topocentric(lat0, lon0, h0)
            east, north, up = enu.transform(lon, lat, h0)
            tm = tmerc(lon0, ELLIPSOIDS[0][1])
            e0, n0 = tm.transform(lon0, lat0)
            e, n = tm.transform(lon, lat)
            azimuth = (bearing + 37.0) % 360.0

            def local_ne(plon, plat):
                # On the ellipsoid: a heading is a direction in the
                # horizontal plane, while the geodesic raised along the
                # normals to h0 turns by h0 (1/M - 1/N) sin(2 az) / 2
                # (1.3e-6 degrees at 250 m).
                pe, pn, _ = enu.transform(plon, plat, 0.0)
                return pn, pe

            def grid_ne(plon, plat):
                ge, gn = tm.transform(plon, plat)
                return gn, ge

            w.writerow([name, repr(lat0), repr(lon0), repr(h0), repr(dist), repr(bearing), repr(lat), repr(lon),
                        f"{east:.7f}", f"{north:.7f}", f"{up:.7f}", f"{n - n0:.7f}", f"{e - e0:.7f}",
                        repr(azimuth), f"{heading_in(local_ne, lat, lon, azimuth):.10f}",
                        f"{heading_in(grid_ne, lat, lon, azimuth):.10f}"])


def main():
    os.makedirs(OUT_DIR, exist_ok=True)
    rows = list(points())
    write_enu(rows)
    write_tmerc(rows)
    write_tmerc_wide()
    write_polar()
    print(f"{len(rows)} points per file in {os.path.normpath(OUT_DIR)}")


if __name__ == "__main__":
    main()
