"""The onboard DataFlash log end to end: a short AUTO mission driven in
`furrow sitl`, its `.BIN` listed and downloaded over MAVLink
(LOG_REQUEST_LIST / LOG_REQUEST_DATA) as MAVProxy and Mission Planner do,
read back with pymavlink's DFReader, and plotted with `furrow-bench logs plot`."""

import subprocess

from pymavlink import DFReader
from pymavlink.dialects.v20 import ardupilotmega as mavlink

import mavexplorer_graphs
from conftest import FURROW, FURROW_BENCH
from gcs import command, distance, mission_item, offset, position, recv, upload_mission


def north_m(lat0, lat):
    return distance(lat0, 0, lat, 0) * (1 if lat >= lat0 else -1)


def east_m(lat0, lon0, lon):
    return distance(lat0, lon0, lat0, lon) * (1 if lon >= lon0 else -1)


def drive_short_mission(m):
    """Home, 20 m north, then 15 m east; returns the waypoints (lat, lon)."""
    lat0, lon0 = position(m)
    wps = [(lat0, lon0), offset(lat0, lon0, 20, 0), offset(lat0, lon0, 20, 15)]
    items = [mission_item(i, mavlink.MAV_CMD_NAV_WAYPOINT, int(round(la * 1e7)), int(round(lo * 1e7)))
             for i, (la, lo) in enumerate(wps)]
    assert upload_mission(m, items).type == mavlink.MAV_MISSION_ACCEPTED
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    m.set_mode("AUTO")
    done = recv(m, "STATUSTEXT", timeout=120, cond=lambda t: "Mission Complete" in t.text)
    assert done is not None, "no Mission Complete"
    assert command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == mavlink.MAV_RESULT_ACCEPTED
    # The file closes on the tick that sees the vehicle disarmed: a
    # heartbeat saying so comes from that tick or a later one.
    disarmed = lambda h: h.get_srcSystem() == m.target_system and not h.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert recv(m, "HEARTBEAT", timeout=5, cond=disarmed) is not None
    return wps


def list_logs(m):
    m.mav.log_request_list_send(m.target_system, m.target_component, 0, 0xFFFF)
    entries = {}
    while True:
        e = recv(m, "LOG_ENTRY", timeout=5)
        assert e is not None, f"LOG_ENTRY missing; have {sorted(entries)}"
        if e.num_logs == 0:
            return entries
        entries[e.id] = e
        if len(entries) == e.num_logs:
            return entries


def download(m, log_id, size):
    """The whole log, as MAVProxy's `log download` asks for it."""
    m.mav.log_request_data_send(m.target_system, m.target_component, log_id, 0, 0xFFFFFFFF)
    data = bytearray()
    while True:
        d = recv(m, "LOG_DATA", timeout=10, cond=lambda d: d.id == log_id)
        assert d is not None, f"LOG_DATA stopped at {len(data)} of {size}"
        assert d.ofs == len(data), f"chunk at {d.ofs}, expected {len(data)}"
        data += bytes(d.data[:d.count])
        if d.count < 90:
            m.mav.log_request_end_send(m.target_system, m.target_component)
            return bytes(data)


def test_an_auto_drive_is_downloaded_over_mavlink_and_read_by_dfreader(start_sitl, tmp_path):
    sitl = start_sitl(speedup="20")
    m = sitl.tcp()
    wps = drive_short_mission(m)

    entries = list_logs(m)
    assert len(entries) == 1, entries
    (log_id, entry), = entries.items()
    assert entry.size > 10_000
    data = download(m, log_id, entry.size)
    assert len(data) == entry.size
    on_disk = sitl.data_dir / "logs" / f"{log_id:08d}.BIN"
    assert data == on_disk.read_bytes(), "the download is the file in the data directory's logs/"

    path = tmp_path / "drive.BIN"
    path.write_bytes(data)
    log = DFReader.DFReader_binary(str(path), zero_time_base=True)
    counts = {}
    course, xtrack, cmds, modes = [], [], [], []
    while True:
        msg = log.recv_msg()
        if msg is None:
            break
        t = msg.get_type()
        counts[t] = counts.get(t, 0) + 1
        if t == "POS":
            course.append((msg.Lat, msg.Lng))
        elif t == "NTUN":
            xtrack.append(msg.XTrack)
        elif t == "CMD":
            cmds.append((msg.CNum, msg.CId, msg.Lat, msg.Lng))
        elif t == "MODE":
            modes.append(msg.Mode)
    print(f"{len(data)} bytes; {counts}")

    assert counts.get("PARM", 0) > 100
    assert [c[:2] for c in cmds] == [(0, 16), (1, 16), (2, 16)]
    assert distance(cmds[2][2], cmds[2][3], *wps[2]) < 0.01
    assert 10 in modes, f"AUTO (10) in MODE: {modes}"
    # The course follows both legs (the corner is an arc) and ends at the
    # last waypoint.
    assert len(course) > 500
    lat0, lon0 = wps[0]
    local = [(north_m(lat0, la), east_m(lat0, lon0, lo)) for la, lo in course]
    first_leg = [e for n, e in local if 2 < n < 15]
    second_leg = [n for n, e in local if 5 < e < 13]
    assert len(first_leg) > 100 and max(abs(e) for e in first_leg) < 0.3
    assert len(second_leg) > 50 and max(abs(n - 20) for n in second_leg) < 0.3
    assert distance(*course[-1], *wps[2]) < 0.5, course[-1]
    # NTUN's cross-track all along the drive, within the navigation tests' bound.
    assert len(xtrack) > 500
    assert max(abs(x) for x in xtrack) < 0.3
    assert any(x != 0 for x in xtrack)
    # The units the file declares (FMTU/UNIT/MULT) reach DFReader.
    assert log.formats[log.name_to_id["NTUN"]].units[-1] == "m"
    # MAVExplorer offers the Rover graphs and plots them with ArduPilot's units.
    offered = mavexplorer_graphs.check(path)
    print(f"MAVExplorer graphs offered: {offered}")

    svg = tmp_path / "xtrack.svg"
    out = subprocess.run([FURROW_BENCH, "logs", "plot", str(path), "--xtrack", "--out", str(svg)],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert svg.read_text().lstrip().startswith("<svg") and "cross-track" in svg.read_text()
    summary = subprocess.run([FURROW, "logs", "summary", str(path)], capture_output=True, text=True, timeout=60)
    assert summary.returncode == 0 and "cross-track (NTUN" in summary.stdout, summary.stderr
    listing = subprocess.run([FURROW, "logs", "list", "--data-dir", str(sitl.data_dir)],
                             capture_output=True, text=True, timeout=60)
    assert f"{log_id:08d}.BIN" in listing.stdout, listing.stdout
