"""MISSION_CURRENT as ground stations read it: never past the last item, and
the mission state fields (mavlink.io: "on last item, sequence == total")."""

import pathlib
import time

from gcs import command, load_waypoints, mavlink, recv, upload_mission
from mavproxy import MavProxy

BENCH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bench"


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
    mavproxy = MavProxy(sitl.tcp_port, tmp_path, ["--cmd", "set param_ftp 0"])
    try:
        mavproxy.wait_for(r"Received \d+ parameters")
        # Until the vehicle acknowledges the plan, the old one is in force.
        mavproxy.wait_for(r"MISSION_ACK: TYPE_MISSION: ACCEPTED", start=mavproxy.send(f"wp load {course}"))
        mavproxy.wait_for(r"\bARMED", start=mavproxy.send("arm throttle"))
        mavproxy.send("mode auto")
        mavproxy.wait_for("Mission Complete", timeout=60)
        # MAVProxy says "waypoint N" when MISSION_CURRENT's seq changes: the
        # change at the end, then three of the 1 Hz stream's, are watched.
        time.sleep(3)
    finally:
        out = mavproxy.close()
    assert "waypoint 5" in out, out
    assert "waypoint 6" not in out, out
