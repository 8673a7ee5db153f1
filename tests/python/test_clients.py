"""Several ground stations at once, and a recording they can read back."""

import os
import subprocess
import sys
import time

from conftest import udp_port
from gcs import command, mavlink, message_rate, recv


def test_three_clients_all_get_telemetry(start_sitl, udp_gcs):
    sitl = start_sitl(udp_port=udp_port(udp_gcs))
    a, b = sitl.tcp(), sitl.tcp(source_system=254)
    assert udp_gcs.wait_heartbeat(timeout=10)
    for m in (a, b, udp_gcs):
        assert message_rate(m, "GLOBAL_POSITION_INT", 2) >= 3
    # A command from one gets its ACK on that link only.
    ack = command(a, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert recv(b, "COMMAND_ACK", 2) is None
    # A GCS's heartbeat is routed to the other GCSs that have spoken on
    # their link, as ArduPilot routes it.
    b.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    time.sleep(0.5)
    a.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    hb = recv(b, "HEARTBEAT", 5, lambda h: h.get_srcSystem() == 255)
    assert hb is not None and hb.type == mavlink.MAV_TYPE_GCS


def test_tlog_is_readable_by_mavlogdump(start_sitl, tmp_path):
    tlog = tmp_path / "flight.tlog"
    sitl = start_sitl(extra_args=["--tlog", str(tlog)])
    m = sitl.tcp()
    command(m, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    recv(m, "AUTOPILOT_VERSION")
    time.sleep(1.5)
    assert sitl.stop() == 0
    assert tlog.stat().st_size > 1000
    dump = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    out = subprocess.run([sys.executable, dump, "--types", "HEARTBEAT,COMMAND_LONG,COMMAND_ACK,AUTOPILOT_VERSION,GLOBAL_POSITION_INT", str(tlog)],
                         capture_output=True, text=True, timeout=60, env=dict(os.environ, MAVLINK20="1"))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    for t in ("HEARTBEAT", "COMMAND_LONG", "COMMAND_ACK", "AUTOPILOT_VERSION", "GLOBAL_POSITION_INT"):
        assert any(f" {t} " in line for line in lines), f"{t} not in the tlog"
