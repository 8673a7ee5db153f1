"""Bad input from outside is counted, dropped and survived; the other links
keep their telemetry."""

import os
import random
import socket
import threading
import time

from gcs import command, mavlink, message_rate, mission_item, recv, upload_mission
from pymavlink.dialects.v10 import ardupilotmega as mavlink1


def raw_tcp(port, rcvbuf=None):
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf is not None:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.connect(("127.0.0.1", port))
    return s


def encode(msg, system=255, component=190, seq=0):
    mav = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
    mav.seq = seq
    return msg.pack(mav)


def test_garbage_truncation_and_bad_crcs_are_survived(start_sitl):
    sitl = start_sitl()
    watcher = sitl.tcp()
    bad = raw_tcp(sitl.tcp_port)
    rng = random.Random(1)
    cmd = mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    frame = encode(cmd)
    for _ in range(200):
        bad.sendall(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300))))
        bad.sendall(frame[: rng.randint(1, len(frame) - 1)])          # truncated
        corrupt = bytearray(frame)
        corrupt[-1] ^= 0xFF                                           # bad CRC
        bad.sendall(bytes(corrupt))
    time.sleep(1)
    assert sitl.alive()
    assert message_rate(watcher, "GLOBAL_POSITION_INT", 2) >= 3
    # None of those frames was acted on: still disarmed.
    hb = recv(watcher, "HEARTBEAT")
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    # The garbage is counted in the log.
    deadline = time.time() + 5
    while time.time() < deadline and "bytes unframed" not in sitl.log():
        time.sleep(0.2)
    assert "bytes unframed" in sitl.log()
    bad.close()


def test_mavlink1_frames_are_accepted(start_sitl):
    sitl = start_sitl()
    s = raw_tcp(sitl.tcp_port)
    mav1 = mavlink1.MAVLink(None, srcSystem=255, srcComponent=190)
    s.sendall(mav1.heartbeat_encode(mavlink1.MAV_TYPE_GCS, mavlink1.MAV_AUTOPILOT_INVALID, 0, 0, 0).pack(mav1))
    req = mav1.command_long_encode(1, 1, mavlink1.MAV_CMD_REQUEST_MESSAGE, 0, mavlink1.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
    s.sendall(req.pack(mav1))
    # Furrow answers in MAVLink 2.
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    deadline = time.time() + 5
    acked = False
    s.settimeout(0.5)
    while time.time() < deadline and not acked:
        try:
            data = s.recv(65536)
        except socket.timeout:
            continue
        for msg in parser.parse_buffer(data) or []:
            if msg.get_type() == "COMMAND_ACK" and msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
                acked = msg.result == mavlink.MAV_RESULT_ACCEPTED
    assert acked
    s.close()


def test_messages_for_another_system_are_not_acted_on(start_sitl):
    m = start_sitl().tcp()
    m.mav.command_long_send(42, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 21196, 0, 0, 0, 0, 0)
    assert recv(m, "COMMAND_ACK", 2) is None
    hb = recv(m, "HEARTBEAT")
    assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def test_a_client_that_never_reads_does_not_stall_anyone(start_sitl):
    sitl = start_sitl(speedup="10")
    watcher = sitl.tcp()
    # The sleeper never reads, asks for every stream at the highest rate and
    # keeps requesting AUTOPILOT_VERSION: its replies overflow the kernel
    # buffers and its queue within seconds.
    sleeper = raw_tcp(sitl.tcp_port, rcvbuf=4096)
    mav = mavlink.MAVLink(None, srcSystem=200, srcComponent=1)
    for msg_id in (1, 2, 24, 30, 33, 36, 62, 74, 147, 193, 245):
        sleeper.sendall(mav.command_long_encode(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 2000, 0, 0, 0, 0, 0).pack(mav))
    request = mav.command_long_encode(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0).pack(mav)
    stop = threading.Event()

    def flood():
        while not stop.is_set():
            sleeper.sendall(request * 30)
            time.sleep(0.1)

    flooder = threading.Thread(target=flood, daemon=True)
    flooder.start()
    try:
        time.sleep(4)
        t0 = recv(watcher, "SYSTEM_TIME").time_boot_ms
        rate = message_rate(watcher, "GLOBAL_POSITION_INT", 4)
        t1 = recv(watcher, "SYSTEM_TIME").time_boot_ms
        assert rate >= 3, f"watcher starved: {rate:.1f} Hz"
        # Simulated time still runs at ~10x: the core did not wait.
        assert t1 - t0 >= 35_000, f"simulated {t1 - t0} ms in >4 s wall at 10x"
        deadline = time.time() + 10
        while time.time() < deadline and "dropping messages" not in sitl.log():
            time.sleep(0.2)
        assert "dropping messages" in sitl.log()
        assert sitl.alive()
    finally:
        stop.set()
        flooder.join()
        sleeper.close()


def test_random_valid_frames_from_fuzzed_fields_are_survived(start_sitl):
    """Well-formed frames with arbitrary field values (NaN, huge, negative)."""
    sitl = start_sitl()
    m = sitl.tcp()
    rng = random.Random(5)
    weird = [float("nan"), float("inf"), -1e30, 0.0, -1.0, 1e9, 21196.0]
    for _ in range(300):
        cmd = rng.choice([400, 176, 192, 179, 178, 512, 511, 410, 20, 300, 0, 65535])
        p = [rng.choice(weird) for _ in range(7)]
        m.mav.command_long_send(1, 1, cmd, 0, *p)
        m.mav.command_int_send(1, 1, rng.choice([0, 3, 5, 6, 1, 200]), cmd, 0, 0, *p[:4],
                               rng.randint(-2**31, 2**31 - 1), rng.randint(-2**31, 2**31 - 1), p[6])
        m.mav.set_position_target_global_int_send(0, 1, 1, rng.choice([0, 5, 6, 1]), rng.randint(0, 65535),
                                                  rng.randint(-2**31, 2**31 - 1), rng.randint(-2**31, 2**31 - 1), p[0], *p[:6], 0, 0, 0)
        m.mav.manual_control_send(1, rng.randint(-32768, 32767), rng.randint(-32768, 32767),
                                  rng.randint(-32768, 32767), rng.randint(-32768, 32767), 0)
    time.sleep(1)
    assert sitl.alive()
    assert message_rate(m, "HEARTBEAT", 3) >= 0.6


def test_a_1e20_second_delay_is_refused_and_auto_survives(start_sitl):
    """A NAV_DELAY of 1e20 s (or a hold, a loiter, a condition delay, a servo
    repeat period) used to be accepted and kill the process in AUTO."""
    sitl = start_sitl()
    m = sitl.tcp()
    home = mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, 291330000, 1196400000, 40.0)
    near = mission_item(2, mavlink.MAV_CMD_NAV_WAYPOINT, 291331000, 1196400000, 0.0)
    cases = [
        (mavlink.MAV_CMD_NAV_DELAY, (1e20, 0, 0, 0), mavlink.MAV_MISSION_INVALID_PARAM1),
        (mavlink.MAV_CMD_NAV_DELAY, (float("nan"), 0, 0, 0), mavlink.MAV_MISSION_INVALID_PARAM1),
        (mavlink.MAV_CMD_CONDITION_DELAY, (float("inf"), 0, 0, 0), mavlink.MAV_MISSION_INVALID_PARAM1),
        (mavlink.MAV_CMD_CONDITION_DELAY, (-5.0, 0, 0, 0), mavlink.MAV_MISSION_INVALID_PARAM1),
        (mavlink.MAV_CMD_DO_REPEAT_SERVO, (9, 1500, 2, 1e20), mavlink.MAV_MISSION_INVALID_PARAM4),
    ]
    for cmd, params, result in cases:
        bad = mission_item(1, cmd, params=params)
        ack = upload_mission(m, [home, bad, near])
        assert ack is not None and ack.type == result, (cmd, params, ack)
    for cmd in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME):
        bad = mission_item(1, cmd, 291330500, 1196400000, 0.0, (1e20, 0, 0, 0))
        ack = upload_mission(m, [home, bad, near])
        assert ack is not None and ack.type == mavlink.MAV_MISSION_INVALID_PARAM1, (cmd, ack)
    # A day is a delay a rover may use: accepted, and AUTO runs it.
    day = mission_item(1, mavlink.MAV_CMD_NAV_DELAY, params=(86400.0, 0, 0, 0))
    ack = upload_mission(m, [home, day, near])
    assert ack is not None and ack.type == mavlink.MAV_MISSION_ACCEPTED
    m.mav.command_long_send(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 10, 0, 0, 0, 0, 0)
    time.sleep(2)
    assert sitl.alive()
    assert message_rate(m, "HEARTBEAT", 2) >= 0.5
