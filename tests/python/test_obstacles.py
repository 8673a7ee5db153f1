"""Obstacles end to end: `furrow sitl --world FILE` with simulated laser
scanners (CoLa-A telegrams read by the real parser), watched by pymavlink.

A person walks slowly across the path of an AUTO leg: the vehicle must stop
for them (STATUSTEXT "Obstacle stop: …"), drive on once they have crossed
("Obstacle clear: resuming …") and complete the mission, while
OBSTACLE_DISTANCE shows the scene in the body frame. The person is put in
the world by rewriting the world file while the vehicle drives (the file is
reloaded when it changes), so the crossing happens ahead of the vehicle
whatever the start-up time was.
"""

import math
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs import command, home, mission_item, offset, radii, recv, upload_mission

# A box well off the path: the world as loaded at start.
BOX_WORLD = """
[[static]]
kind = "box"
center = [12.0, 8.0]
length_m = 1.0
width_m = 1.0
yaw_deg = 0.0
"""

# The same box and a person crossing 25 m north of home, slowly, from the
# vehicle's left, starting when the world is reloaded.
CROSSING_WORLD = BOX_WORLD + """
[[moving]]
name = "person"
kind = "circle"
radius_m = 0.25
path = [[25.0, -3.5], [25.0, 9.0]]
speed_mps = 0.35
start_s = {start_s:.1f}
"""

PROXIMITY = 0x4000000
OBSTACLE_AVOIDANCE = 0x20000000


def boot_s(m):
    msg = recv(m, "SYSTEM_TIME", 5)
    assert msg is not None, "no SYSTEM_TIME"
    return msg.time_boot_ms / 1000.0


def test_crossing_person_stops_the_vehicle_which_resumes_and_completes(start_sitl, tmp_path):
    world = tmp_path / "world.toml"
    world.write_text(BOX_WORLD)
    sitl = start_sitl(speedup="2", extra_args=["--world", str(world)])
    m = sitl.tcp()
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
    ack = command(m, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE, 200_000)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED

    # The box is seen by the front scanner, ahead and to the right.
    od = recv(m, "OBSTACLE_DISTANCE", 10, lambda o: min(o.distances) <= o.max_distance)
    assert od is not None, "no OBSTACLE_DISTANCE showing the box"
    assert od.frame == mavlink.MAV_FRAME_BODY_FRD and od.increment == 5 and len(od.distances) == 72
    near = min(range(72), key=lambda i: od.distances[i])
    assert 20 <= near * 5 <= 50, f"nearest return at {near * 5}° (the box is ~34° right)"
    assert 1000 <= od.distances[near] <= 1400, od.distances[near]
    status = recv(m, "SYS_STATUS", 5)
    assert status.onboard_control_sensors_present & PROXIMITY
    assert status.onboard_control_sensors_present & OBSTACLE_AVOIDANCE
    assert status.onboard_control_sensors_health & PROXIMITY

    lat0, lon0 = home(m)
    wp = offset(lat0, lon0, 40.0, 0.0)
    items = [
        mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, int(lat0 * 1e7), int(lon0 * 1e7), frame=0),
        mission_item(1, mavlink.MAV_CMD_NAV_WAYPOINT, int(round(wp[0] * 1e7)), int(round(wp[1] * 1e7))),
    ]
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")

    # Once the vehicle drives, the person steps out 25 m ahead.
    moving = recv(m, "VFR_HUD", 30, lambda v: v.groundspeed > 0.5)
    assert moving is not None, "the vehicle did not start"
    world.write_text(CROSSING_WORLD.format(start_s=boot_s(m)))

    texts = []
    deadline = time.time() + 120
    while time.time() < deadline:
        msg = m.recv_match(type=["STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        texts.append(msg.text)
        if "Mission Complete" in msg.text:
            break
    else:
        raise AssertionError(f"no Mission Complete; texts: {texts}")
    assert any("world reloaded" in t for t in texts), texts
    stops = [t for t in texts if t.startswith("Obstacle stop")]
    resumes = [t for t in texts if t.startswith("Obstacle clear: resuming")]
    assert len(stops) >= 1 and len(resumes) == len(stops), texts
    assert texts.index(stops[0]) < texts.index(resumes[0]) < texts.index("Mission Complete"), texts
    assert sitl.alive()


def test_a_bad_world_file_is_a_clear_error_at_start_and_kept_out_on_reload(start_sitl, tmp_path):
    import subprocess

    from conftest import FURROW

    bad = tmp_path / "bad.toml"
    bad.write_text('[[static]]\nkind = "circle"\ncenter = [1.0, 2.0]\nradius_m = -1.0\n')
    proc = subprocess.run(
        [FURROW, "sitl", "--data-dir", str(tmp_path / "d1"), "--tcp-port", "0", "--world", str(bad)],
        capture_output=True, text=True, timeout=30)
    assert proc.returncode != 0
    assert "--world" in proc.stderr and "radius" in proc.stderr, proc.stderr

    world = tmp_path / "world.toml"
    world.write_text(BOX_WORLD)
    sitl = start_sitl(speedup="1", extra_args=["--world", str(world)])
    m = sitl.tcp()
    world.write_text("[[static]]\nkind = \"box\"\nsize = oops\n")
    text = recv(m, "STATUSTEXT", 10, lambda t: "world" in t.text)
    assert text is not None and "invalid" in text.text, text
    assert sitl.alive()
    # The old world is still there: the box is still seen.
    ack = command(m, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE, 200_000)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    od = recv(m, "OBSTACLE_DISTANCE", 10, lambda o: min(o.distances) <= o.max_distance)
    assert od is not None


# The corner scene: north 30 m, then east, round the 6 m corner arc
# (centre 24 m north, 6 m east of home) at 1.1 m/s. A person stands inside
# the arc, 5.5 m from its centre half-way round: in the band the outline
# sweeps through the turn (5 m to 7.9 m from the centre), 1.1 m outside the
# straight lane, where a field looking along the heading does not reach.
PERSON_SPOT = (24.0 + 5.5 * math.sqrt(0.5), 6.0 - 5.5 * math.sqrt(0.5))
PERSON_RADIUS_M = 0.25
STANDING_WORLD = """
[[static]]
kind = "circle"
center = [{n:.3f}, {e:.3f}]
radius_m = {r}
""".format(n=PERSON_SPOT[0], e=PERSON_SPOT[1], r=PERSON_RADIUS_M)
# The person walks away west (out of the turn) and is gone.
WALKING_AWAY_WORLD = """
[[moving]]
name = "person"
kind = "circle"
radius_m = {r}
path = [[{n:.3f}, {e:.3f}], [{n:.3f}, -12.0]]
speed_mps = 1.2
start_s = {{start_s:.1f}}
vanish_at_end = true
""".format(n=PERSON_SPOT[0], e=PERSON_SPOT[1], r=PERSON_RADIUS_M)

# The simulated AGV's outline about the rear axle (VEH_LEN_FRONT, VEH_LEN_REAR, VEH_WIDTH / 2).
FRONT_M, REAR_M, HALF_WIDTH_M = 3.6, 0.8, 1.0


def clearance_m(lat0, lon0, pos, yaw_rad):
    """Gap between the vehicle's outline (from its reported position and
    heading) and the person's circle, from the world file's numbers."""
    m, n = radii(lat0)
    north = math.radians(pos.lat * 1e-7 - lat0) * m
    east = math.radians(pos.lon * 1e-7 - lon0) * n * math.cos(math.radians(lat0))
    dn, de = PERSON_SPOT[0] - north, PERSON_SPOT[1] - east
    x = dn * math.cos(yaw_rad) + de * math.sin(yaw_rad)
    y = -dn * math.sin(yaw_rad) + de * math.cos(yaw_rad)
    dx = max(x - FRONT_M, -REAR_M - x, 0.0)
    dy = max(abs(y) - HALF_WIDTH_M, 0.0)
    return math.hypot(dx, dy) - PERSON_RADIUS_M


def test_a_person_inside_a_turn_is_stopped_for_and_passed_once_gone(start_sitl, tmp_path):
    world = tmp_path / "world.toml"
    world.write_text(STANDING_WORLD)
    sitl = start_sitl(speedup="4", extra_args=["--world", str(world)])
    m = sitl.tcp()
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
    lat0, lon0 = home(m)
    corner = offset(lat0, lon0, 30.0, 0.0)
    end = offset(lat0, lon0, 30.0, 30.0)
    as_e7 = lambda p: (int(round(p[0] * 1e7)), int(round(p[1] * 1e7)))  # noqa: E731
    items = [
        mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, int(lat0 * 1e7), int(lon0 * 1e7), frame=0),
        mission_item(1, mavlink.MAV_CMD_DO_CHANGE_SPEED, params=(1, 1.1, -1, 0)),
        mission_item(2, mavlink.MAV_CMD_NAV_WAYPOINT, *as_e7(corner)),
        mission_item(3, mavlink.MAV_CMD_NAV_WAYPOINT, *as_e7(end)),
    ]
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")

    texts, yaw, speed = [], 0.0, 0.0
    min_moving_m = math.inf
    at_rest_m = None
    rest_since = None
    texts_while_there = None
    deadline = time.time() + 120
    while time.time() < deadline:
        msg = m.recv_match(type=["STATUSTEXT", "ATTITUDE", "VFR_HUD", "GLOBAL_POSITION_INT"], blocking=True, timeout=1)
        if msg is None:
            continue
        kind = msg.get_type()
        if kind == "ATTITUDE":
            yaw = msg.yaw
        elif kind == "VFR_HUD":
            speed = msg.groundspeed
        elif kind == "GLOBAL_POSITION_INT" and texts_while_there is None:
            gap = clearance_m(lat0, lon0, msg, yaw)
            if speed > 0.05:
                min_moving_m = min(min_moving_m, gap)
            elif any(t.startswith("Obstacle stop") for t in texts):
                at_rest_m = gap if at_rest_m is None else min(at_rest_m, gap)
                rest_since = rest_since or time.time()
                # The person stays 3 s of wall time (12 s simulated) after the
                # vehicle first stands still for them, then walks away.
                if time.time() - rest_since >= 3.0:
                    texts_while_there = list(texts)
                    world.write_text(WALKING_AWAY_WORLD.format(start_s=boot_s(m)))
        elif kind == "STATUSTEXT":
            texts.append(msg.text)
            if "Mission Complete" in msg.text:
                break
    else:
        raise AssertionError(f"no Mission Complete; texts: {texts}")
    print(f"stood {at_rest_m} m from the person, least gap moving {min_moving_m:.2f} m; {texts}")
    assert texts_while_there is not None, f"never stood still for the person: {texts}"
    assert any(t.startswith("Obstacle stop") for t in texts_while_there), texts
    assert not any(t.startswith("Obstacle clear") for t in texts_while_there), f"resumed towards the person: {texts}"
    assert min_moving_m > 0.0, f"the outline touched the person (gap {min_moving_m:.2f} m): {texts}"
    assert at_rest_m >= 0.3, f"stopped {at_rest_m:.2f} m from the person"
    later = texts[len(texts_while_there):]
    assert any(t.startswith("Obstacle clear: resuming") for t in later), texts
    assert sitl.alive()
