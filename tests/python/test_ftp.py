"""MAVLink FTP with the clients that use it: MAVProxy's default start (the
parameter table as @PARAM/param.pck) and pymavlink's MAVFTP client on the
data directory."""

import time
import zlib

import pytest
from gcs import mavlink
from mavproxy import MavProxy
from pymavlink import mavftp, mavutil


def param_count(m):
    m.mav.param_request_read_send(m.target_system, m.target_component, b"WP_SPEED", -1)
    msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=5)
    assert msg is not None
    return msg.param_count


# Timed on MAVProxy's output as it comes, and on its tlog's timestamps.
@pytest.mark.serial
def test_mavproxy_default_start_loads_every_parameter_over_ftp_within_a_second(start_sitl, tmp_path):
    sitl = start_sitl(speedup="1")
    expected = param_count(sitl.tcp())
    mavproxy = MavProxy(sitl.tcp_port, tmp_path, ["--non-interactive"])
    try:
        received = mavproxy.wait_for(r"Received \d+ parameters", timeout=30)
    finally:
        text = mavproxy.close(terminate=True)
    connected = mavproxy.find("online system|Detected vehicle")
    assert connected is not None, text
    elapsed_s = received[0] - connected[0]
    transfer_s = ftp_exchange_s(tmp_path / "mav.tlog")
    print(f"MAVProxy: {received[1]!r} {elapsed_s:.3f} s after the vehicle was seen; "
          f"FTP exchange {transfer_s:.3f} s (tlog)")
    assert f"Received {expected} parameters (ftp)" in received[1], text
    # The vehicle's part: from MAVProxy's open request to the last reply.
    assert transfer_s <= 0.25, transfer_s
    # MAVProxy starts its parameter fetch from a 1 Hz check, so up to a
    # second of this is its own wait before it asks.
    assert elapsed_s <= 1.5, text


def ftp_exchange_s(tlog):
    """Seconds from the first FILE_TRANSFER_PROTOCOL in MAVProxy's tlog (its
    request) to the last (a reply), at the tlog's timestamps."""
    log = mavutil.mavlink_connection(str(tlog))
    times = []
    while True:
        msg = log.recv_match(type="FILE_TRANSFER_PROTOCOL")
        if msg is None:
            break
        times.append(msg._timestamp)
    assert times, "no FTP in the tlog"
    return times[-1] - times[0]


def client(sitl):
    m = sitl.tcp()
    return m, mavftp.MAVFTP(m, target_system=m.target_system, target_component=m.target_component)


def ardupilot_crc(data):
    return zlib.crc32(data, 0xFFFFFFFF) ^ 0xFFFFFFFF


def test_pymavlink_lists_reads_writes_checks_and_removes_in_the_data_directory(start_sitl, tmp_path):
    sitl = start_sitl()
    m, ftp = client(sitl)
    listing = ftp.cmd_list(["/"])
    assert listing.error_code == mavftp.FtpError.Success
    names = {e.name for e in listing.directory_listing}
    assert {"@PARAM", "@LOGS"} <= names, names
    assert "signing.key" not in names

    body = bytes(range(256)) * 20 + b"tail"
    local = tmp_path / "upload.bin"
    local.write_bytes(body)
    ftp.cmd_put([str(local), "notes/upload.bin"])
    assert ftp.process_ftp_reply("CreateFile", timeout=10).error_code != mavftp.FtpError.Success, \
        "no such directory yet"
    assert ftp.cmd_mkdir(["notes"]).error_code == mavftp.FtpError.Success
    ftp.cmd_put([str(local), "notes/upload.bin"])
    assert ftp.process_ftp_reply("CreateFile", timeout=10).error_code == mavftp.FtpError.Success
    assert (sitl.data_dir / "notes" / "upload.bin").read_bytes() == body

    got = ftp.read("notes/upload.bin", len(body))
    assert got == body
    crc = ftp.cmd_crc(["notes/upload.bin"])
    assert crc.error_code == mavftp.FtpError.Success
    assert ardupilot_crc(body) == ardupilot_crc((sitl.data_dir / "notes" / "upload.bin").read_bytes())

    assert ftp.cmd_rm(["notes/upload.bin"]).error_code == mavftp.FtpError.Success
    assert not (sitl.data_dir / "notes" / "upload.bin").exists()
    assert ftp.cmd_rmdir(["notes"]).error_code == mavftp.FtpError.Success


def test_paths_out_of_the_data_directory_and_vehicle_files_are_refused(start_sitl, tmp_path):
    sitl = start_sitl()
    (tmp_path / "outside.txt").write_text("not yours")
    m, ftp = client(sitl)
    for path in ["../outside.txt", "/../outside.txt", "a/../../outside.txt"]:
        assert ftp.read(path, 100) is None, path
    ret = ftp.cmd_rm(["../outside.txt"])
    assert ret.error_code == mavftp.FtpError.FileProtected
    assert (tmp_path / "outside.txt").exists()
    ret = ftp.cmd_rm(["params.parm"])
    assert ret.error_code in (mavftp.FtpError.FileProtected, mavftp.FtpError.FileNotFound)
    # The vehicle keeps answering everything else.
    assert m.wait_heartbeat(timeout=5)


def test_parameter_file_decodes_to_the_table_with_defaults(start_sitl):
    sitl = start_sitl()
    m, ftp = client(sitl)
    m.mav.param_set_send(m.target_system, m.target_component, b"WP_SPEED", 2.7, mavlink.MAV_PARAM_TYPE_REAL32)
    assert m.recv_match(type="PARAM_VALUE", blocking=True, timeout=5) is not None
    data = ftp.read("@PARAM/param.pck?withdefaults=1", 1 << 20)
    assert data is not None
    pdata = mavftp.MAVFTP.ftp_param_decode(data)
    assert pdata is not None
    values = {name.decode(): v for name, v, _ in pdata.params}
    defaults = {name.decode(): v for name, v, _ in pdata.defaults}
    assert len(values) == param_count(m)
    assert abs(values["WP_SPEED"] - 2.7) < 1e-6 and defaults["WP_SPEED"] == 2.0


def test_malformed_ftp_frames_are_survived(start_sitl):
    sitl = start_sitl()
    m = sitl.tcp()
    # A size past the payload, an unknown opcode, garbage.
    bad = [bytes([1, 0, 0, 4, 250]) + bytes(246), bytes([2, 0, 0, 200, 0]) + bytes(246), bytes(range(251))]
    for payload in bad:
        m.mav.file_transfer_protocol_send(0, m.target_system, m.target_component, payload)
    naks = []
    deadline = time.time() + 5
    while time.time() < deadline and len(naks) < 2:
        r = m.recv_match(type="FILE_TRANSFER_PROTOCOL", blocking=True, timeout=1)
        if r is not None:
            naks.append(bytes(r.payload))
    assert [p[3] for p in naks[:2]] == [129, 129], naks
    assert naks[0][12] == 3 and naks[1][12] == 7, "InvalidDataSize, UnknownCommand"
    assert m.wait_heartbeat(timeout=5)
