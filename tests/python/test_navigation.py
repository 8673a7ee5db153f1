"""The navigation core end to end: the reference AGV course driven in AUTO by
`furrow sitl`, watched by pymavlink as a ground station would.

Bounds (from `furrow-bench tracking`, which measures the true pose over 20
seeds; here the autopilot's own report is what a GCS sees):
- NAV_CONTROLLER_OUTPUT.xtrack_error: the bench's straight-leg p99 bound
  (20 mm) for 95 % of the samples, and never beyond 50 mm (corner arcs,
  where the steering gear's rate limit shows, included);
- each precision stop's STATUSTEXT reports an error within WP_STOP_TOL_MM
  and WP_STOP_TOL_DEG.
"""

import math
import pathlib
import re
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs import command, load_waypoints, recv, upload_mission

BENCH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bench"

STOP = re.compile(r"Stop #(\d+): ([\d.]+) mm, yaw (-?[\d.]+) deg, (in tolerance|OUT of tolerance)")


def drive_agv_course(sitl, m):
    items = load_waypoints(BENCH / "agv_course.waypoints")
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 50, 1)
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")
    xtrack, stops, texts = [], [], []
    deadline = time.time() + 180
    while time.time() < deadline:
        msg = m.recv_match(type=["NAV_CONTROLLER_OUTPUT", "STATUSTEXT", "HEARTBEAT"], blocking=True, timeout=1)
        if msg is None:
            continue
        t = msg.get_type()
        if t == "NAV_CONTROLLER_OUTPUT" and m.flightmode == "AUTO":
            xtrack.append(msg.xtrack_error)
        elif t == "STATUSTEXT":
            texts.append(msg.text)
            match = STOP.match(msg.text)
            if match:
                stops.append((int(match.group(1)), float(match.group(2)), float(match.group(3)), match.group(4)))
            if "Mission Complete" in msg.text:
                return xtrack, stops, texts
    raise AssertionError(f"no Mission Complete within 180 s; last texts {texts[-8:]}")


def test_agv_course_tracks_within_the_bench_bound_and_stops_within_tolerance(start_sitl):
    sitl = start_sitl(speedup="20")
    m = sitl.tcp()
    xtrack, stops, texts = drive_agv_course(sitl, m)

    assert len(xtrack) > 300, f"only {len(xtrack)} NAV_CONTROLLER_OUTPUT samples"
    magnitudes = sorted(abs(x) for x in xtrack)
    p95 = magnitudes[int(0.95 * (len(magnitudes) - 1))]
    worst = magnitudes[-1]
    print(f"xtrack p95 {p95 * 1000:.1f} mm, max {worst * 1000:.1f} mm over {len(xtrack)} samples; stops {stops}")
    assert p95 <= 0.020, f"xtrack p95 {p95 * 1000:.1f} mm"
    assert worst <= 0.050, f"xtrack max {worst * 1000:.1f} mm"

    # Direction changes (#4, #15), pickup (#8), release (#19), the end (#25).
    assert [s[0] for s in stops] == [4, 8, 15, 19, 25], (stops, texts[-10:])
    for seq, mm, yaw_deg, verdict in stops:
        assert mm <= 10.0 and abs(yaw_deg) <= 0.05, f"stop #{seq}: {mm} mm, {yaw_deg} deg"
        assert verdict == "in tolerance", (seq, verdict)
    assert math.isfinite(sum(s[1] for s in stops))


def test_magnetic_mode_follows_a_tape_laid_along_the_square(start_sitl):
    # The tape runs from home through the square's corners (15 m arcs); in
    # MAGNETIC (mode 20) the vehicle follows it with its two guide sensors.
    sitl = start_sitl(speedup="20", extra_args=["--tape", str(BENCH / "square_40m.waypoints")])
    m = sitl.tcp()
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 50, 1)
    start = recv(m, "GLOBAL_POSITION_INT")
    home = (start.lat, start.lon)
    assert command(m, mavlink.MAV_CMD_DO_SET_MODE, 1, 20).result == mavlink.MAV_RESULT_ACCEPTED
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    assert recv(m, "HEARTBEAT", cond=lambda h: h.custom_mode == 20), "no heartbeat in MAGNETIC"
    xtrack, north_max, east_max, texts = [], 0.0, 0.0, []
    # Until round the first corner and well along the second side (the tape
    # ends back at home, where the vehicle would lose it and hold).
    deadline = time.time() + 60
    while time.time() < deadline and not (north_max > 30.0 and east_max > 20.0):
        msg = m.recv_match(
            type=["NAV_CONTROLLER_OUTPUT", "GLOBAL_POSITION_INT", "HEARTBEAT", "STATUSTEXT"], blocking=True, timeout=1
        )
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == m.target_system:
            assert msg.custom_mode == 20, f"left MAGNETIC: mode {msg.custom_mode}; {texts}"
        elif msg.get_type() == "NAV_CONTROLLER_OUTPUT":
            xtrack.append(msg.xtrack_error)
        elif msg.get_type() == "GLOBAL_POSITION_INT":
            north_max = max(north_max, (msg.lat - home[0]) * 0.0111)
            east_max = max(east_max, (msg.lon - home[1]) * 0.0111 * math.cos(math.radians(msg.lat * 1e-7)))
    assert north_max > 30.0 and east_max > 20.0, f"drove {north_max:.1} m north, {east_max:.1} m east"
    assert len(xtrack) > 20, f"only {len(xtrack)} NAV_CONTROLLER_OUTPUT samples"
    assert max(abs(x) for x in xtrack) < 0.10, "the sensors' midpoint stays within 10 cm of the tape"


def test_magnetic_mode_is_refused_without_a_tape(start_sitl):
    m = start_sitl().tcp()
    assert command(m, mavlink.MAV_CMD_DO_SET_MODE, 1, 20).result == mavlink.MAV_RESULT_FAILED


def test_a_bad_tape_file_is_a_clear_error(tmp_path):
    import subprocess
    from conftest import FURROW

    bad = tmp_path / "tape.waypoints"
    bad.write_text("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnot-a-number\t119.64\t40\t1\n")
    for path in [tmp_path / "missing.waypoints", bad]:
        proc = subprocess.run(
            [FURROW, "sitl", "--data-dir", str(tmp_path / "data"), "--tcp-port", "0", "--tape", str(path)],
            capture_output=True, text=True, timeout=30,
        )
        assert proc.returncode != 0
        assert "--tape" in proc.stderr and str(path) in proc.stderr, proc.stderr
