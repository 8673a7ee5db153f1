"""A pose goal beside the rover and RTL with home behind it, as a ground
station drives them: DO_REPOSITION with a heading (param 4), then RTL; the
final pose is checked from the telemetry (GLOBAL_POSITION_INT, ATTITUDE),
and every verdict against it: "Reached destination" when the estimate can
confirm the tolerance, "Stopped at … unconfirmed" when its σ cannot (the
simulator's GNSS wanders 5 mm per axis against a 10 mm tolerance)."""

import math
import time

from gcs import (command, distance, mavlink, mission_item, offset, param_set, position, recv, reposition,
                 upload_mission, wait_mode)


def wait_verdict(m, seconds):
    """STATUSTEXTs until GUIDED/RTL says whether it got there."""
    texts = []
    deadline = time.time() + seconds
    while time.time() < deadline:
        msg = recv(m, "STATUSTEXT", 2)
        if msg is None:
            continue
        texts.append(msg.text)
        if msg.text.startswith(("Reached destination", "Destination NOT reached", "Stopped at")):
            return msg.text, texts
    raise AssertionError(f"no verdict: {texts}")


def yaw_deg(m):
    return math.degrees(recv(m, "ATTITUDE").yaw)


def test_rtl_with_home_behind_ends_on_home_facing_the_start_heading(start_sitl):
    m = start_sitl().tcp()
    lat0, lon0 = position(m)
    start_yaw = yaw_deg(m)
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED

    # 4 m ahead and 5 m to the right, facing east: beside the rover.
    target = offset(lat0, lon0, 4, 5)
    ack = reposition(m, *target, yaw_deg=90)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert wait_mode(m, "GUIDED")
    verdict, texts = wait_verdict(m, 120)
    assert verdict.startswith(("Reached destination", "Stopped at destination")), texts
    assert distance(*position(m), *target) < 0.03
    assert abs((yaw_deg(m) - 90 + 180) % 360 - 180) < 0.2

    # Home is now behind-left of a rover facing east: RTL manoeuvres back
    # onto it, facing north as it started.
    m.set_mode("RTL")
    assert wait_mode(m, "RTL")
    verdict, texts = wait_verdict(m, 120)
    assert verdict == "Reached destination: home" or verdict.startswith("Stopped at home"), texts
    assert not any("ailsafe" in t for t in texts), texts
    # GLOBAL_POSITION_INT's 1e-7° steps are about 1 cm.
    assert distance(*position(m), lat0, lon0) < 0.03
    assert abs((yaw_deg(m) - start_yaw + 180) % 360 - 180) < 0.2


def test_a_mission_stop_with_a_heading_ends_facing_it(start_sitl):
    """MNV_WP_YAW 1: NAV_WAYPOINT param 4 is the stop's heading. A stop 8 m
    ahead of a rover facing north, to be reached facing east, is a
    manoeuvre (one stroke or more). The stop ends on that heading, and its
    verdict is as honest as GUIDED's: MISSION_ITEM_REACHED when the estimate
    confirms the tolerance, "Waypoint #1 not claimed: stop unconfirmed" (and
    the mission goes on) when its σ cannot."""
    m = start_sitl().tcp()
    lat0, lon0 = position(m)
    assert param_set(m, "MNV_WP_YAW", 1).param_value == 1
    stop = offset(lat0, lon0, 8, 0)
    items = [
        mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, int(lat0 * 1e7), int(lon0 * 1e7)),
        mission_item(1, mavlink.MAV_CMD_NAV_WAYPOINT, int(round(stop[0] * 1e7)), int(round(stop[1] * 1e7)),
                     params=(0, 0, 0, 90)),
    ]
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")
    assert wait_mode(m, "AUTO")
    texts = []
    verdict = None
    deadline = time.time() + 120
    while verdict is None and time.time() < deadline:
        msg = m.recv_match(type=["STATUSTEXT", "MISSION_ITEM_REACHED"], blocking=True, timeout=2)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
            if msg.text.startswith("Waypoint #1 not claimed"):
                verdict = msg.text
        elif msg.seq == 1:
            verdict = "MISSION_ITEM_REACHED"
    assert verdict is not None, texts
    # GLOBAL_POSITION_INT's 1e-7° steps are about 1 cm.
    assert distance(*position(m), *stop) < 0.03
    assert abs((yaw_deg(m) - 90 + 180) % 360 - 180) < 0.2
