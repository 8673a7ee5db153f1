"""A failsafe over `furrow run`: a vehicle driving GUIDED on a
pty GNSS that goes silent for 3 s. The failsafe must stay on, and say so,
for as long as the receiver is silent, whatever mode it chose, refuse
GUIDED meanwhile, and clear once, within 1 s of the NMEA resuming.
"""

import os

os.environ.setdefault("MAVLINK20", "1")

import time

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs import command, goto, param_set, recv, wait_mode
from test_vehicle_run import Player, Receiver, Vehicle, gga_position

# A Python thread feeds the vehicle's GNSS in real time (stale after 500 ms).
pytestmark = pytest.mark.serial

SILENT_S = 3.0
HOLD = 4
GUIDED = 15


def write_config(tmp_path, gnss_link):
    config = tmp_path / "vehicle.toml"
    config.write_text(f"""
[vehicle]
frame = "ackermann"
data_dir = "data"

[gnss]
serial = "{gnss_link}"
baud = 115200
stale_ms = 500

[heading]
source = "gnss"

[[mavlink]]
endpoint = "tcpin:127.0.0.1:0"
""")
    return config


def collect(m, seconds):
    """Every HEARTBEAT, STATUSTEXT and COMMAND_ACK for `seconds`, in order,
    each with the time it arrived."""
    seen = []
    deadline = time.time() + seconds
    while time.time() < deadline:
        msg = m.recv_match(type=["HEARTBEAT", "STATUSTEXT", "COMMAND_ACK"], blocking=True,
                           timeout=max(0.05, deadline - time.time()))
        if msg is not None and msg.get_srcSystem() == m.target_system:
            seen.append((time.time(), msg))
    return seen


def texts(seen):
    return [msg.text for _, msg in seen if msg.get_type() == "STATUSTEXT"]


def test_gnss_silent_in_guided_stays_a_failsafe_until_the_nmea_resumes(tmp_path):
    receiver = Receiver(tmp_path / "gnss0")
    player = Player(receiver)
    vehicle = Vehicle(write_config(tmp_path, tmp_path / "gnss0"), tmp_path)
    m = None
    try:
        m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{vehicle.tcp_port}", source_system=255)
        assert m.wait_heartbeat(timeout=10)
        # RTK fixed and a heading from the log before arming.
        assert recv(m, "GPS_RAW_INT", 10, lambda r: r.fix_type == mavlink.GPS_FIX_TYPE_RTK_FIXED)
        time.sleep(2)
        # No scanners on this vehicle: obstacle stopping off, to drive.
        param_set(m, "OA_ENABLE", 0)
        m.mav.set_mode_send(m.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
        assert wait_mode(m, "GUIDED")
        ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED, (ack, vehicle.log()[-2000:])
        lat, lon = gga_position(player.last_gga)
        goto(m, lat + 0.0003, lon + 0.0003)
        hb = recv(m, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == m.target_system)
        assert hb.custom_mode == GUIDED and hb.system_status != mavlink.MAV_STATE_CRITICAL, hb

        # The receiver goes silent: the failsafe starts within about 1 s.
        player.pause()
        silent_at = time.time()
        seen = collect(m, 1.8)
        assert "Failsafe: GNSS lost: HOLD" in texts(seen), texts(seen)
        started_at = next(t for t, msg in seen
                          if msg.get_type() == "STATUSTEXT" and msg.text == "Failsafe: GNSS lost: HOLD")
        # Still silent: GUIDED is refused, naming the failsafe.
        command(m, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED, timeout=0)
        seen += collect(m, silent_at + SILENT_S - time.time())
        assert not any(t.startswith("Failsafe cleared") for t in texts(seen)), texts(seen)
        acks = [msg for _, msg in seen if msg.get_type() == "COMMAND_ACK"
                and msg.command == mavlink.MAV_CMD_DO_SET_MODE]
        assert acks and acks[0].result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED, [a.result for a in acks]
        assert "Mode change to GUIDED failed: GNSS lost" in texts(seen), texts(seen)
        # Every HEARTBEAT from the failsafe's start to the end of the
        # silence: CRITICAL, in HOLD.
        during = [msg for t, msg in seen if msg.get_type() == "HEARTBEAT" and t > started_at]
        assert len(during) >= 1, seen
        assert all(h.system_status == mavlink.MAV_STATE_CRITICAL for h in during), \
            [h.system_status for h in during]
        assert all(h.custom_mode == HOLD for h in during), [h.custom_mode for h in during]

        # The NMEA resumes: cleared once, within 1 s.
        player.resume()
        resumed_at = time.time()
        seen = collect(m, 3.0)
        cleared = [t for t, msg in seen
                   if msg.get_type() == "STATUSTEXT" and msg.text == "Failsafe cleared: GNSS lost"]
        assert len(cleared) == 1, texts(seen)
        assert cleared[0] - resumed_at <= 1.0, f"cleared {cleared[0] - resumed_at:.2f} s after the NMEA resumed"
        # Once nothing is on, GUIDED is accepted again.
        assert recv(m, "HEARTBEAT", 5, lambda h: h.get_srcSystem() == m.target_system
                    and h.system_status != mavlink.MAV_STATE_CRITICAL), vehicle.log()[-2000:]
        ack = command(m, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED, ack
        ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    finally:
        player.stop()
        if m is not None:
            m.close()
        code = vehicle.stop()
    assert code == 0, vehicle.log()[-3000:]
