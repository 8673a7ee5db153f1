"""MISSION_CURRENT as ground stations read it: never past the last item, and
the mission state fields (mavlink.io: "on last item, sequence == total")."""

import os
import pathlib
import subprocess
import sys
import time

from gcs import command, load_waypoints, mavlink, recv, upload_mission

BENCH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bench"
MAVPROXY = os.path.join(os.path.dirname(sys.executable), "mavproxy.py")


def test_completion_keeps_the_last_item_and_reports_complete(start_sitl):
    m = start_sitl(speedup="25").tcp()
    items = load_waypoints(BENCH / "square_40m.waypoints")
    total = len(items) - 1
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    cur = recv(m, "MISSION_CURRENT", 5)
    assert cur is not None
    assert (cur.total, cur.mission_state, cur.mission_mode) == (total, mavlink.MISSION_STATE_NOT_STARTED, 2)
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")
    seen, complete_at = [], None
    deadline = time.time() + 60
    while time.time() < deadline:
        msg = m.recv_match(type=["MISSION_CURRENT", "STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            if "Mission Complete" in msg.text:
                complete_at = time.time()
            continue
        seen.append((msg.seq, msg.total, msg.mission_state, msg.mission_mode))
        if complete_at is not None and time.time() > complete_at + 1.5:
            break
    assert complete_at is not None, seen[-5:]
    assert all(seq <= tot for seq, tot, _, _ in seen), seen
    assert (total, total, mavlink.MISSION_STATE_ACTIVE, 1) in seen, "the last item while driving it"
    assert seen[-1] == (total, total, mavlink.MISSION_STATE_COMPLETE, 1), seen[-5:]


def test_mavproxy_never_announces_a_waypoint_past_the_last(start_sitl, tmp_path):
    sitl = start_sitl(speedup="25")
    course = BENCH / "square_40m.waypoints"
    proc = subprocess.Popen(
        [MAVPROXY, "--master", f"tcp:127.0.0.1:{sitl.tcp_port}", "--cmd", "set param_ftp 0"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=tmp_path)
    time.sleep(8)
    for line, wait_s in [(f"wp load {course}", 4), ("arm throttle", 2), ("mode auto", 15), ("exit", 0)]:
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
        time.sleep(wait_s)
    try:
        out, _ = proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    assert "Mission Complete" in out, out
    assert "waypoint 5" in out, out
    assert "waypoint 6" not in out, out
