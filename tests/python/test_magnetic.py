"""MAGNETIC mode (20) getting back on a tape from a start off it,
over `furrow sitl --tape`, watched by pymavlink as a ground station would.

The tape is the issue's: 30 m straight north, a 90° right arc of 15 m, 20 m
east. The vehicle starts 2 m along it, 0.25 m right of it and heading 5°
towards it: its sensors (±1 m about the rear axle, ±75 mm reach) see
nothing, so it drives straight until the front one finds the tape, then
corrects, and follows the tape round the arc without ever switching to HOLD.
"""

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs import command, offset, radii, recv

HOME = (29.1330, 119.6400)
MAGNETIC = 20
RIGHT_OF_TAPE_M = 0.25


def write_tape(path):
    # Item 0 is where the tape starts; its corner is rounded by --tape-radius.
    points = [(-2.0, -RIGHT_OF_TAPE_M), (43.0, -RIGHT_OF_TAPE_M), (43.0, 35.0 - RIGHT_OF_TAPE_M)]
    lines = ["QGC WPL 110"]
    for seq, (north_m, east_m) in enumerate(points):
        lat, lon = offset(HOME[0], HOME[1], north_m, east_m)
        lines.append(f"{seq}\t{int(seq == 0)}\t0\t16\t0\t0\t0\t0\t{lat:.9f}\t{lon:.9f}\t0.000\t1")
    path.write_text("\n".join(lines) + "\n")


def local(msg):
    """(north, east) metres from HOME of a GLOBAL_POSITION_INT."""
    meridian_m, normal_m = radii(HOME[0])
    north_m = math.radians(msg.lat * 1e-7 - HOME[0]) * meridian_m
    east_m = math.radians(msg.lon * 1e-7 - HOME[1]) * normal_m * math.cos(math.radians(HOME[0]))
    return north_m, east_m


def test_magnetic_mode_finds_the_tape_from_a_start_off_it_and_follows_it(start_sitl, tmp_path):
    tape = tmp_path / "tape.waypoints"
    write_tape(tape)
    sitl = start_sitl(
        speedup="5",
        extra_args=["--tape", str(tape), "--tape-radius", "15", "--home", f"{HOME[0]},{HOME[1]},40,355"],
    )
    m = sitl.tcp()
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
    # 50 Hz of wall time is 10 Hz of simulated time at --speedup 5: a sample
    # every 0.15 m at 1.5 m/s. At the streams' 10 Hz (one every 0.7 m) the
    # guide's deviation, exactly 0 with both sensors centred, could read 0
    # at every sample of the short correction after the tape is found.
    for msg_id in (mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT):
        assert command(m, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 20_000).result == mavlink.MAV_RESULT_ACCEPTED
    assert command(m, mavlink.MAV_CMD_DO_SET_MODE, 1, MAGNETIC).result == mavlink.MAV_RESULT_ACCEPTED
    # Armed, it drives: from here every position counts (waiting for a
    # heartbeat first would skip the first seconds of the search).
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED

    texts, xtrack_on_straight, east_on_straight = [], [], []
    north_m = east_m = 0.0
    found_at_north_m = None
    positioned = heartbeats = False
    while not (north_m > 40.0 and east_m > 25.0):
        msg = m.recv_match(
            type=["NAV_CONTROLLER_OUTPUT", "GLOBAL_POSITION_INT", "HEARTBEAT", "STATUSTEXT"], blocking=True, timeout=5
        )
        assert msg is not None, f"telemetry stopped at {north_m:.1f} m N, {east_m:.1f} m E; {texts}"
        t = msg.get_type()
        if t == "STATUSTEXT":
            texts.append(msg.text)
        elif t == "HEARTBEAT" and msg.get_srcSystem() == m.target_system:
            assert msg.custom_mode == MAGNETIC, f"left MAGNETIC at {north_m:.1f} m N, {east_m:.1f} m E: {texts}"
            heartbeats = True
        elif t == "GLOBAL_POSITION_INT":
            north_m, east_m = local(msg)
            positioned = True
            assert north_m < 60.0 and abs(east_m) < 40.0, f"ran off at {north_m:.1f} m N, {east_m:.1f} m E"
            if 15.0 < north_m < 25.0:
                east_on_straight.append(east_m)
        elif t == "NAV_CONTROLLER_OUTPUT":
            # The guide's lateral deviation; 0 while no sensor reads the tape
            # (and with both centred). Where only once a position came.
            if found_at_north_m is None and positioned and msg.xtrack_error != 0.0:
                found_at_north_m = north_m
            if 15.0 < north_m < 25.0:
                xtrack_on_straight.append(msg.xtrack_error)

    assert heartbeats, "no heartbeat"
    assert not any("lost" in text for text in texts), texts
    # 0.25 m off at 5°: the front sensor, 1 m ahead, reaches the tape after
    # about (0.25 − 0.075)/tan 5° − 1 m = 1 m of driving.
    assert found_at_north_m is not None and found_at_north_m < 6.0, found_at_north_m
    # Well along the straight it is back on the tape: the guide sees the
    # sensors within a centimetre, and the estimated position (RTK noise
    # included) is on the tape's line.
    assert len(xtrack_on_straight) > 8, len(xtrack_on_straight)
    assert max(abs(x) for x in xtrack_on_straight) < 0.010, max(abs(x) for x in xtrack_on_straight)
    assert len(east_on_straight) > 8, len(east_on_straight)
    worst_m = max(abs(e + RIGHT_OF_TAPE_M) for e in east_on_straight)
    assert worst_m < 0.05, f"{worst_m:.3f} m off the tape's line"
