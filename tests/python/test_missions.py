"""The mission protocol against pymavlink and MAVProxy, and AUTO driving the
bench course."""

import math
import pathlib
import time

import pytest
from conftest import Sitl, udp_port
from mavproxy import MavProxy
from gcs import (ack_opaque_id, command, current_ids, download_mission, load_waypoints, mavlink, mission_item, recv,
                 same_item, upload_mission)

BENCH = pathlib.Path(__file__).resolve().parents[1] / "data" / "bench"
HOME_E7 = (291330000, 1196400000)


def square_items(n):
    """Home plus n-1 waypoints on a small grid, with varied params."""
    items = [mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, *HOME_E7, 40.0)]
    for i in range(1, n):
        items.append(mission_item(i, mavlink.MAV_CMD_NAV_WAYPOINT, HOME_E7[0] + (i % 50) * 9, HOME_E7[1] + (i // 50) * 11,
                                  1.5, (float(i % 3), 0.0, 0.0, float("nan"))))
    return items


@pytest.mark.parametrize("n", [10, 100, 1000])
def test_upload_and_download_round_trip(start_sitl, udp_gcs, n):
    start_sitl(udp_port=udp_port(udp_gcs))
    assert udp_gcs.wait_heartbeat(timeout=10)
    items = square_items(n)
    ack = upload_mission(udp_gcs, items)
    assert ack is not None and ack.type == mavlink.MAV_MISSION_ACCEPTED
    assert ack_opaque_id(ack) != 0
    back, opaque_id = download_mission(udp_gcs)
    assert opaque_id == ack_opaque_id(ack)
    assert len(back) == n
    # Item 0 is home (ArduPilot's convention): compare the rest field by field.
    for a, b in zip(items[1:], back[1:]):
        assert same_item(a, b), (a, b)


def test_failed_uploads_leave_the_old_mission_even_after_a_restart(tmp_path):
    data = tmp_path / "vehicle"
    s = Sitl(tmp_path, data_dir=data)
    m = s.tcp()
    good = square_items(5)
    assert upload_mission(m, good).type == mavlink.MAV_MISSION_ACCEPTED

    # 1. An unsupported item (NAV_LAND) is refused at once with its reason.
    bad = square_items(5)
    bad[3] = mission_item(3, mavlink.MAV_CMD_NAV_LAND, *HOME_E7)
    ack = upload_mission(m, bad)
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED

    # 2. A latitude out of range.
    bad = square_items(5)
    bad[2] = mission_item(2, mavlink.MAV_CMD_NAV_WAYPOINT, 950000000, HOME_E7[1])
    assert upload_mission(m, bad).type == mavlink.MAV_MISSION_INVALID_PARAM5_X

    # 3. An upload abandoned midway: the vehicle gives up (OPERATION_CANCELLED).
    m.mav.mission_count_send(m.target_system, m.target_component, 20, 0)
    req = recv(m, "MISSION_REQUEST_INT", 5)
    assert req is not None and req.seq == 0
    it = good[0]
    m.mav.mission_item_int_send(m.target_system, m.target_component, 0, it.frame, it.command, 0, 1, 0, 0, 0, 0, it.x, it.y, it.z, 0)
    ack = recv(m, "MISSION_ACK", 15)
    assert ack is not None and ack.type == mavlink.MAV_MISSION_OPERATION_CANCELLED

    # 4. A second GCS trying to upload during an upload is denied; the first completes.
    other = s.tcp(source_system=254)
    m.mav.mission_count_send(m.target_system, m.target_component, 3, 0)
    assert recv(m, "MISSION_REQUEST_INT", 5) is not None
    other.mav.mission_count_send(other.target_system, other.target_component, 2, 0)
    denied = recv(other, "MISSION_ACK", 5)
    assert denied is not None and denied.type == mavlink.MAV_MISSION_DENIED
    m.mav.mission_ack_send(m.target_system, m.target_component, mavlink.MAV_MISSION_OPERATION_CANCELLED, 0)

    for conn in (m,):
        back, _ = download_mission(conn)
        assert len(back) == 5 and all(same_item(a, b) for a, b in zip(good[1:], back[1:]))
    assert s.stop() == 0
    s = Sitl(tmp_path, data_dir=data)
    try:
        back, _ = download_mission(s.tcp())
        assert len(back) == 5 and all(same_item(a, b) for a, b in zip(good[1:], back[1:]))
    finally:
        s.stop()


def test_out_of_sequence_items_are_re_requested(start_sitl):
    m = start_sitl().tcp()
    items = square_items(4)
    m.mav.mission_count_send(m.target_system, m.target_component, 4, 0)
    assert recv(m, "MISSION_REQUEST_INT", 5, lambda r: r.seq == 0)
    it = items[2]
    m.mav.mission_item_int_send(m.target_system, m.target_component, 2, it.frame, it.command, 0, 1, it.param1, 0, 0, 0, it.x, it.y, it.z, 0)
    again = recv(m, "MISSION_REQUEST_INT", 5)
    assert again is not None and again.seq == 0
    m.mav.mission_ack_send(m.target_system, m.target_component, mavlink.MAV_MISSION_OPERATION_CANCELLED, 0)


def test_fence_and_rally_are_separate_plans(start_sitl):
    m = start_sitl().tcp()
    lat, lon = HOME_E7
    fence = [mission_item(i, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, lat + dx, lon + dy, 0, (4, 0, 0, 0),
                          mavlink.MAV_FRAME_GLOBAL, mission_type=1)
             for i, (dx, dy) in enumerate([(-2000, -2000), (2000, -2000), (2000, 2000), (-2000, 2000)])]
    rally = [mission_item(0, mavlink.MAV_CMD_NAV_RALLY_POINT, lat + 500, lon, 0, frame=mavlink.MAV_FRAME_GLOBAL, mission_type=2)]
    assert upload_mission(m, fence, 1).type == mavlink.MAV_MISSION_ACCEPTED
    assert upload_mission(m, rally, 2).type == mavlink.MAV_MISSION_ACCEPTED
    assert len(download_mission(m, 1)[0]) == 4
    assert len(download_mission(m, 2)[0]) == 1
    assert len(download_mission(m, 0)[0]) <= 1, "the mission plan is untouched"
    # An incomplete polygon is refused.
    assert upload_mission(m, fence[:3], 1).type != mavlink.MAV_MISSION_ACCEPTED
    cur = recv(m, "MISSION_CURRENT", 5)
    _, fence_id, rally_id = current_ids(cur)
    assert fence_id != 0 and rally_id != 0
    # MISSION_TYPE_ALL is refused, as ArduPilot refuses it: nothing cleared.
    m.mav.mission_clear_all_send(m.target_system, m.target_component, mavlink.MAV_MISSION_TYPE_ALL)
    assert recv(m, "MISSION_ACK", 5).type == mavlink.MAV_MISSION_UNSUPPORTED
    assert len(download_mission(m, 1)[0]) == 4
    m.mav.mission_clear_all_send(m.target_system, m.target_component, mavlink.MAV_MISSION_TYPE_FENCE)
    assert recv(m, "MISSION_ACK", 5).type == mavlink.MAV_MISSION_ACCEPTED
    assert len(download_mission(m, 1)[0]) == 0
    assert len(download_mission(m, 2)[0]) == 1


def heading_diff(a, b):
    return abs((a - b + 180) % 360 - 180)


def test_unknown_mission_types_are_answered_unsupported(start_sitl):
    """Types the vehicle has no plan for (7, 9…) cannot even be decoded by its
    dialect; they still get MISSION_ACK UNSUPPORTED with the type sent, as
    ArduPilot answers, instead of a silence the GCS must time out on."""
    sitl = start_sitl()
    m = sitl.tcp()
    requests = [
        (7, lambda t: m.mav.mission_count_send(m.target_system, m.target_component, 3, t, 0)),
        (9, lambda t: m.mav.mission_request_list_send(m.target_system, m.target_component, t)),
        (7, lambda t: m.mav.mission_clear_all_send(m.target_system, m.target_component, t)),
        (9, lambda t: m.mav.mission_request_int_send(m.target_system, m.target_component, 0, t)),
        (200, lambda t: m.mav.mission_count_send(m.target_system, m.target_component, 1, t, 0)),
    ]
    for mission_type, send in requests:
        send(mission_type)
        ack = recv(m, "MISSION_ACK", 3)
        assert ack is not None, f"type {mission_type}: no MISSION_ACK"
        assert (ack.type, ack.mission_type) == (mavlink.MAV_MISSION_UNSUPPORTED, mission_type)
        assert (ack.target_system, ack.target_component) == (255, 0)
    # Addressed to another vehicle: not answered.
    m.mav.mission_count_send(42, 1, 3, 7, 0)
    assert recv(m, "MISSION_ACK", 1) is None


def test_agv_course_runs_in_auto(start_sitl):
    sitl = start_sitl(speedup="25")
    m = sitl.tcp()
    items = load_waypoints(BENCH / "agv_course.waypoints")
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")
    nav_items = [it.seq for it in items[1:] if it.command == mavlink.MAV_CMD_NAV_WAYPOINT]
    reached, servo9, reverse_samples, texts = [], [], 0, []
    last_servo = None
    hdg, cog_speed = None, (None, 0.0)
    deadline = time.time() + 120
    complete = False
    while time.time() < deadline and not complete:
        msg = m.recv_match(blocking=True, timeout=1)
        if msg is None:
            continue
        t = msg.get_type()
        if t == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
        elif t == "STATUSTEXT":
            texts.append(msg.text)
            complete = complete or "Mission Complete" in msg.text
        elif t == "SERVO_OUTPUT_RAW" and msg.servo9_raw != last_servo:
            last_servo = msg.servo9_raw
            servo9.append(msg.servo9_raw)
        elif t == "ATTITUDE":
            hdg = math.degrees(msg.yaw) % 360
        elif t == "GPS_RAW_INT" and msg.vel > 30 and msg.cog != 65535 and hdg is not None:
            # Ground course opposite to heading: driving in reverse.
            if heading_diff(msg.cog / 100.0, hdg) > 150:
                reverse_samples += 1
    assert complete, f"no Mission Complete; reached {reached}; texts {texts[-5:]}"
    assert reached == nav_items, (reached, nav_items)
    assert [v for v in servo9 if v] == [1900, 1100], servo9
    assert reverse_samples > 10, "both reverse legs driven backwards"
    assert any("Reached waypoint #8" == x for x in texts)


def test_do_jump_loop_runs_the_right_number_of_times(start_sitl):
    m = start_sitl(speedup="25").tcp()
    lat, lon = HOME_E7
    items = [
        mission_item(0, 16, lat, lon),
        mission_item(1, 16, lat + 900, lon),          # ~10 m north
        mission_item(2, 16, lat + 900, lon + 1000),   # ~10 m east
        mission_item(3, mavlink.MAV_CMD_DO_JUMP, params=(1, 2, 0, 0)),
        mission_item(4, 16, lat, lon),
    ]
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    m.set_mode("AUTO")
    reached = []
    deadline = time.time() + 60
    while time.time() < deadline:
        msg = m.recv_match(type=["MISSION_ITEM_REACHED", "STATUSTEXT"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
        elif "Mission Complete" in msg.text:
            break
    assert reached == [1, 2, 1, 2, 1, 2, 4], reached


def test_mavproxy_wp_load_and_list(start_sitl, tmp_path):
    sitl = start_sitl()
    course = BENCH / "square_40m.waypoints"
    mavproxy = MavProxy(sitl.tcp_port, tmp_path, ["--cmd", "set param_ftp 0"])
    try:
        # Typed once MAVProxy has the parameters, as a user would.
        mavproxy.wait_for(r"Received \d+ parameters")
        # Until the vehicle acknowledges the plan, the old one is in force.
        mavproxy.wait_for(r"MISSION_ACK: TYPE_MISSION: ACCEPTED", start=mavproxy.send(f"wp load {course}"))
        mavproxy.wait_for(r"Saved 6 waypoints", start=mavproxy.send("wp list"))
    finally:
        mavproxy.close()
    back, _ = download_mission(sitl.tcp())
    assert len(back) == 6
