"""Arming checks and failsafes as a ground station sees them: PreArm
STATUSTEXTs and the SYS_STATUS pre-arm bit, a forced arm, the GCS
heartbeat failsafe, and a fault injected through its SIM_* parameter."""

import time

from gcs import command, goto, mavlink, offset, param_set, position, recv, wait_mode

FORCE_ARM_MAGIC = 21196


def arm_collecting_texts(m, *params):
    """ARM_DISARM and its ACK, with every STATUSTEXT seen until a second
    after it (the PreArm reasons come before the ACK)."""
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, *p)
    ack, texts, deadline = None, [], time.time() + 5
    while time.time() < deadline:
        msg = m.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=0.2)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM and ack is None:
            ack, deadline = msg, time.time() + 1.0
    return ack, texts


def prearm_healthy(m):
    s = recv(m, "SYS_STATUS", 5)
    assert s is not None
    bit = mavlink.MAV_SYS_STATUS_PREARM_CHECK
    assert s.onboard_control_sensors_present & bit
    return bool(s.onboard_control_sensors_health & bit)


def test_prearm_reasons_force_arm_and_the_prearm_bit(start_sitl):
    sitl = start_sitl()
    m = sitl.tcp()
    assert param_set(m, "SIM_SCAN_DISABLE", 1) is not None
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    time.sleep(0.5)
    assert not prearm_healthy(m)
    ack, texts = arm_collecting_texts(m, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_FAILED
    assert "PreArm: Scanner 1 not sending" in texts, texts
    assert not m.motors_armed()

    ack, texts = arm_collecting_texts(m, 1, FORCE_ARM_MAGIC)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert "Arming checks skipped (forced)" in texts, texts
    assert "Skipped: Scanner 1 not sending" in texts, texts
    assert recv(m, "HEARTBEAT", 5, lambda h: h.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    assert "arming forced" in sitl.log()

    command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    assert param_set(m, "SIM_SCAN_DISABLE", 0) is not None
    assert recv(m, "SYS_STATUS", 10, lambda s: s.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_PREARM_CHECK)
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED


def test_gcs_heartbeat_loss_holds_and_says_so(start_sitl):
    sitl = start_sitl()
    m = sitl.tcp()
    assert param_set(m, "FS_GCS_ENABLE", 1) is not None
    assert param_set(m, "FS_GCS_TIMEOUT", 1.5) is not None
    lat, lon = position(m)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED, ack
    goto(m, *offset(lat, lon, 300, 0))
    # Heartbeats for a while (the failsafe only watches a GCS it has seen).
    for _ in range(4):
        time.sleep(0.4)
        m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    silent = time.time()
    assert recv(m, "HEARTBEAT", 2).system_status != mavlink.MAV_STATE_CRITICAL
    text = recv(m, "STATUSTEXT", 5, lambda t: t.text.startswith("Failsafe:"))
    assert text is not None and text.text == "Failsafe: GCS heartbeat lost: HOLD", text
    assert 1.3 < time.time() - silent < 3.0
    assert wait_mode(m, "HOLD")
    assert recv(m, "HEARTBEAT", 3, lambda h: h.system_status == mavlink.MAV_STATE_CRITICAL)
    m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    assert recv(m, "STATUSTEXT", 5, lambda t: t.text == "Failsafe cleared: GCS heartbeat lost")
    assert sitl.alive()


def test_an_injected_gnss_drop_stops_the_vehicle(start_sitl):
    sitl = start_sitl()
    m = sitl.tcp()
    lat, lon = position(m)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    goto(m, *offset(lat, lon, 300, 0))
    assert recv(m, "VFR_HUD", 10, lambda v: v.groundspeed > 1.0)
    assert param_set(m, "SIM_GPS_DISABLE", 1) is not None
    text = recv(m, "STATUSTEXT", 5, lambda t: t.text.startswith("Failsafe:"))
    assert text is not None and text.text.endswith(": HOLD"), text
    assert wait_mode(m, "HOLD")


def test_a_flight_termination_is_kept_across_a_restart_until_cleared(start_sitl, tmp_path):
    """DO_FLIGHTTERMINATION is acknowledged once saved: killed right after
    the ACK, the vehicle restarts terminated (arming refused, the reason
    said) until the command with param1 0 clears it."""
    data = tmp_path / "data"
    sitl = start_sitl(data_dir=data)
    m = sitl.tcp()
    ack = command(m, mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    sitl.proc.kill()
    sitl.proc.wait()

    sitl = start_sitl(data_dir=data)
    m = sitl.tcp()
    ack, texts = arm_collecting_texts(m, 1, FORCE_ARM_MAGIC)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_FAILED
    assert not m.motors_armed()
    ack, texts = arm_collecting_texts(m, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_FAILED
    assert "PreArm: Flight terminated" in texts, texts

    ack = command(m, mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 0)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    deadline = time.time() + 30
    while not prearm_healthy(m):
        assert time.time() < deadline, "never ready to arm after the clear"
    ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
