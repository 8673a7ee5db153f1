"""Drive the rover in GUIDED like a ground station does: by mode name, arm,
go to a point 40 m away, hold there, return home. Over TCP and over UDP."""

import time

import pytest
from conftest import udp_port
from gcs import command, distance, goto, home, mavlink, offset, position, recv, reposition, wait_mode

WP_RADIUS_M = 2.0


def drive_guided_and_rtl(m):
    lat0, lon0 = position(m)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    m.arducopter_arm()
    ack = recv(m, "COMMAND_ACK", 5, lambda a: a.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert m.motors_armed() or recv(m, "HEARTBEAT") and m.motors_armed()

    target = offset(lat0, lon0, 40 * 0.6, 40 * 0.8)
    goto(m, *target)
    # 40 m at 2 m/s is about 25 s of simulated time: a few seconds at 20x.
    deadline = time.time() + 30
    reached = False
    while time.time() < deadline:
        p = recv(m, "GLOBAL_POSITION_INT", 2)
        if p is None:
            continue
        here = (p.lat * 1e-7, p.lon * 1e-7)
        if distance(*here, *target) < WP_RADIUS_M and abs(p.vx) + abs(p.vy) < 5:
            reached = True
            break
    assert reached, f"did not reach the target: {distance(*position(m), *target):.2f} m away"

    # It holds there: five simulated seconds later it has not moved.
    held = position(m)
    t0 = recv(m, "SYSTEM_TIME").time_boot_ms
    recv(m, "SYSTEM_TIME", 10, lambda s: s.time_boot_ms > t0 + 5000)
    assert distance(*held, *position(m)) < 0.05
    assert distance(*position(m), *target) < WP_RADIUS_M
    nav = recv(m, "NAV_CONTROLLER_OUTPUT")
    assert nav is not None and nav.wp_dist <= WP_RADIUS_M

    # RTL brings it home.
    home_lat, home_lon = home(m)
    m.set_mode("RTL")
    assert wait_mode(m, "RTL")
    deadline = time.time() + 30
    while time.time() < deadline:
        if distance(*position(m), home_lat, home_lon) < WP_RADIUS_M:
            break
    assert distance(*position(m), home_lat, home_lon) < WP_RADIUS_M


def test_guided_goto_and_rtl_over_tcp(start_sitl):
    drive_guided_and_rtl(start_sitl().tcp())


def test_guided_goto_and_rtl_over_udp(start_sitl, udp_gcs):
    start_sitl(udp_port=udp_port(udp_gcs))
    assert udp_gcs.wait_heartbeat(timeout=10)
    drive_guided_and_rtl(udp_gcs)


def test_do_reposition_switches_to_guided_and_drives(start_sitl):
    m = start_sitl().tcp()
    lat0, lon0 = position(m)
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    target = offset(lat0, lon0, 25, 0)
    ack = reposition(m, *target)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert wait_mode(m, "GUIDED")
    deadline = time.time() + 30
    while time.time() < deadline and distance(*position(m), *target) > WP_RADIUS_M:
        pass
    assert distance(*position(m), *target) < WP_RADIUS_M
    # Positional commands belong in COMMAND_INT.
    ack = command(m, mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, 0, target[0], target[1], 0)
    assert ack.result == mavlink.MAV_RESULT_COMMAND_INT_ONLY


@pytest.mark.parametrize("mode", ["MANUAL", "HOLD"])
def test_manual_control_drives_only_in_manual(start_sitl, mode):
    m = start_sitl().tcp()
    m.set_mode(mode)
    assert wait_mode(m, mode)
    command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    start = position(m)
    t_end = time.time() + 2
    while time.time() < t_end:
        m.mav.manual_control_send(m.target_system, 0, 0, 500, 0, 0)  # half throttle forward
        time.sleep(0.05)
    moved = distance(*start, *position(m))
    if mode == "MANUAL":
        assert moved > 5, f"MANUAL moved only {moved:.2f} m"
        servo = recv(m, "SERVO_OUTPUT_RAW")
        assert servo.servo3_raw > 1600
    else:
        assert moved < 0.05


def test_arming_refused_without_a_fix(start_sitl):
    m = start_sitl().tcp()
    # Turn the simulated receiver off (SIM_GPS_DISABLE, as in ArduPilot's
    # SITL) and wait until the position is stale.
    m.mav.param_set_send(m.target_system, m.target_component, b"SIM_GPS_DISABLE", 1, mavlink.MAV_PARAM_TYPE_INT8)
    assert recv(m, "GPS_RAW_INT", 20, lambda g: g.fix_type <= mavlink.GPS_FIX_TYPE_NO_FIX) is not None
    m.mav.command_long_send(m.target_system, m.target_component, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    ack, texts = None, []
    deadline = time.time() + 5
    while time.time() < deadline and ack is None:
        msg = m.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            ack = msg
    assert ack is not None and ack.result == mavlink.MAV_RESULT_FAILED
    assert any("PreArm" in t and "position" in t.lower() for t in texts), texts
