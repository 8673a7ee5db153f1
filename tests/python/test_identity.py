"""Furrow presents itself as ArduPilot Rover, so ground stations decode it."""

from conftest import udp_port
from gcs import command, mavlink, recv


def test_heartbeat_identifies_an_ardupilot_rover(start_sitl):
    m = start_sitl().tcp()
    hb = recv(m, "HEARTBEAT")
    assert hb.type == mavlink.MAV_TYPE_GROUND_ROVER
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.system_status == mavlink.MAV_STATE_STANDBY
    # pymavlink's own Rover mode table names the mode.
    assert m.flightmode == "HOLD"
    assert "GUIDED" in m.mode_mapping() and m.mode_mapping()["GUIDED"] == 15


def test_autopilot_version_and_protocol_version_on_request(start_sitl):
    m = start_sitl().tcp()
    ack = command(m, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    v = recv(m, "AUTOPILOT_VERSION")
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    # PROTOCOL_VERSION (300) is missing from pymavlink's default dialect module.
    ack = command(m, mavlink.MAV_CMD_REQUEST_MESSAGE, 300)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    # pymavlink 2.4.50 dropped the (deprecated) definition: it arrives as an
    # unknown message with id 300.
    p = recv(m, ["PROTOCOL_VERSION", "UNKNOWN_300"])
    assert p is not None


def test_unknown_and_unsupported_commands_get_an_ack(start_sitl):
    m = start_sitl().tcp()
    # Known to the dialect, not something a rover does.
    ack = command(m, mavlink.MAV_CMD_DO_PARACHUTE, 1)
    assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED
    # An id the dialect does not define at all.
    ack = command(m, 31999, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_UNSUPPORTED


def test_telemetry_set_is_streamed(start_sitl, udp_gcs):
    start_sitl(udp_port=udp_port(udp_gcs))
    assert udp_gcs.wait_heartbeat(timeout=10)
    wanted = {
        "SYS_STATUS", "SYSTEM_TIME", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "ATTITUDE", "VFR_HUD",
        "EKF_STATUS_REPORT", "SERVO_OUTPUT_RAW", "BATTERY_STATUS", "EXTENDED_SYS_STATE",
    }
    seen = set()
    for _ in range(2000):
        msg = udp_gcs.recv_match(blocking=True, timeout=1)
        if msg is not None:
            seen.add(msg.get_type())
        if wanted <= seen:
            break
    assert wanted <= seen, f"missing {wanted - seen}"
    gps = recv(udp_gcs, "GPS_RAW_INT")
    assert gps.fix_type == mavlink.GPS_FIX_TYPE_RTK_FIXED
    assert 0 < gps.h_acc < 30, "RTK accuracy in mm"
    assert gps.satellites_visible > 0
