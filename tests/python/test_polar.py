"""GUIDED at the poles over MAVLink: `furrow sitl --home` beside the South
Pole (driving across it) and at the North Pole itself. The geometry here goes
through ECEF, so it holds where latitude/longitude differences do not."""

import math
import time

import pytest
from gcs import mavlink, position, recv, wait_mode, goto

A_M = 6378137.0
F = 1.0 / 298.257223563
E2 = F * (2.0 - F)
B_M = A_M * (1.0 - F)


def ecef(lat_deg, lon_deg, h_m):
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
    return ((n + h_m) * math.cos(lat) * math.cos(lon), (n + h_m) * math.cos(lat) * math.sin(lon),
            (n * (1.0 - E2) + h_m) * math.sin(lat))


def geodetic(x, y, z):
    """Latitude/longitude (degrees) of an ECEF point (Bowring, iterated):
    atan2 keeps it sound on the polar axis."""
    p = math.hypot(x, y)
    lat = math.atan2(z, p * (1.0 - E2))
    for _ in range(5):
        n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
        h = p * math.cos(lat) + z * math.sin(lat) - A_M * A_M / n
        lat = math.atan2(z, p * (1.0 - E2 * n / (n + h)))
    return math.degrees(lat), math.degrees(math.atan2(y, x))


def in_plane(home, north_m, east_m):
    """The point north_m/east_m of home in home's tangent plane."""
    lat, lon = math.radians(home[0]), math.radians(home[1])
    north = (-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon), math.cos(lat))
    east = (-math.sin(lon), math.cos(lon), 0.0)
    origin = ecef(*home)
    return geodetic(*(o + north_m * n + east_m * e for o, n, e in zip(origin, north, east)))


def apart_m(a, b, h_m):
    return math.dist(ecef(a[0], a[1], h_m), ecef(b[0], b[1], h_m))


@pytest.mark.parametrize("home,target_ne", [
    ((-89.999, 30.0, 2800.0, 180.0), (-200.0, 5.0)),  # the pole is 111.7 m south of home
    ((90.0, 0.0, 10.0, 45.0), (20.0, 20.0)),
])
def test_guided_at_a_pole(start_sitl, home, target_ne):
    sitl = start_sitl(extra_args=["--home=" + ",".join(str(v) for v in home)])
    m = sitl.tcp()
    position(m)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    m.arducopter_arm()
    ack = recv(m, "COMMAND_ACK", 5, lambda a: a.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    target = in_plane(home[:3], *target_ne)
    goto(m, *target)
    texts = []
    error_m = None
    deadline = time.time() + 60
    while time.time() < deadline:
        msg = m.recv_match(type=["GLOBAL_POSITION_INT", "STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
            if msg.text.startswith("Stop"):
                break
        else:
            error_m = apart_m((msg.lat * 1e-7, msg.lon * 1e-7), target, home[2])
    # A stop the estimate cannot confirm adds ", unconfirmed (…)".
    assert any(t.startswith("Stop") and "in tolerance" in t for t in texts), texts
    bad = [t for t in texts if any(w in t for w in ("rejected", "reset", "Failsafe", "unhealthy"))]
    assert not bad, texts
    p = recv(m, "GLOBAL_POSITION_INT", 5)
    error_m = apart_m((p.lat * 1e-7, p.lon * 1e-7), target, home[2])
    assert error_m < 0.05, f"{error_m:.3f} m from the target; {texts}"
