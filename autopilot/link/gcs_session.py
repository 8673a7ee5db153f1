"""The ground-station session the symbol order is taken from and the RSS is
measured over: start `furrow sitl` (speedup 1, its own data directory, TCP on
a free port), connect pymavlink on TCP, fetch every parameter, upload a
four-waypoint mission and read it back, set a parameter, arm, drive the
mission in AUTO, reading telemetry. `session(exe, wrap, on_done)` calls `on_done(pid)` before the
vehicle is stopped.

Every step is checked: a step that does not complete (no parameters, a
mission refused or not read back whole, no arming, not in AUTO) raises
`SessionIncomplete`, so no symbol order or RSS is taken from a session that
did not run what it says."""

import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("MAVLINK20", "1")  # before pymavlink is imported: MISSION_ITEM_INT's mission_type
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "tests" / "python"))
from gcs import (command, download_mission, fetch_all_params, mavlink, mission_item, param_set,  # noqa: E402
                 recv, upload_mission)
from pymavlink import mavutil  # noqa: E402

HOME_E7 = (291330000, 1196400000)
ROVER_MODE_AUTO = 10  # HEARTBEAT.custom_mode of ArduPilot Rover's AUTO


class SessionIncomplete(RuntimeError):
    """A step of the session did not complete."""


def require(done, step, got):
    if not done:
        raise SessionIncomplete(f"{step} did not complete (got {got})")


def square_mission():
    """Home and a 10 m square of waypoints around it."""
    items = [mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, *HOME_E7, 40.0)]
    for seq, (north, east) in enumerate([(900, 0), (900, 1030), (0, 1030), (0, 0)], start=1):
        items.append(mission_item(seq, mavlink.MAV_CMD_NAV_WAYPOINT, HOME_E7[0] + north, HOME_E7[1] + east, 0.0))
    return items


def wait_port(proc, timeout_s):
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        line = proc.stdout.readline()
        found = re.search(r"tcp [0-9.]+:(\d+)", line)
        if found:
            return int(found.group(1))
    raise RuntimeError("furrow sitl did not print its TCP port")


def session(exe, wrap=(), on_done=None, slow=1.0, telemetry_s=5.0, log=print, sitl_args=()):
    """One session; `slow` stretches every timeout (under valgrind);
    `sitl_args` are added to `furrow sitl`'s (e.g. `--speedup max`)."""
    data_dir = tempfile.mkdtemp(prefix="furrow-session-")
    stderr = open(os.path.join(data_dir, "stderr"), "w")
    proc = subprocess.Popen(list(wrap) + [exe, "sitl", "--tcp-port", "0", "--udp-port", "9", "--data-dir", data_dir,
                             *sitl_args],
                            stdout=subprocess.PIPE, stderr=stderr, text=True)
    try:
        m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{wait_port(proc, 60 * slow)}", source_system=255)
        m.wait_heartbeat(timeout=10 * slow)
        started = time.time()
        params, count, _ = fetch_all_params(m, timeout=20 * slow)
        require(count and len(params) == count, "parameter download", f"{len(params)} of {count}")
        items = square_mission()
        ack = upload_mission(m, items, timeout=30 * slow)
        require(ack and ack.type == mavlink.MAV_MISSION_ACCEPTED, "mission upload", ack)
        back, _ = download_mission(m, timeout=30 * slow)  # what a ground station does on connecting
        require(len(back) == len(items), "mission download", f"{len(back)} of {len(items)} items")
        echo = param_set(m, "WP_SPEED", 2.0, timeout=5 * slow)
        require(echo, "parameter set", echo)
        armed = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=5 * slow)
        require(armed and armed.result == mavlink.MAV_RESULT_ACCEPTED, "arming", armed)
        m.set_mode("AUTO")
        beat = recv(m, "HEARTBEAT", 5 * slow, lambda b: b.get_srcSystem() == m.target_system
                    and b.custom_mode == ROVER_MODE_AUTO)
        require(beat, "mode change to AUTO", None)
        log(f"params {len(params)}, mission {ack.type}, read back {len(back)}, arm {armed.result}, AUTO "
            f"({time.time() - started:.1f} s)")
        end = time.time() + telemetry_s * slow
        while time.time() < end:
            m.recv_match(blocking=True, timeout=0.5)
        result = on_done(proc.pid) if on_done else None
        m.close()
        return result
    finally:
        proc.send_signal(2)
        proc.wait(60 * slow)
