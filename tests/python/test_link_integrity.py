"""No stranger steals a UDP link; notices reach a ground station that
connects late."""

import os
import re
import select
import socket
import threading
import time
import tty

import pytest
from pymavlink import mavutil

from conftest import Sitl, udp_port
from gcs import recv

mavlink = mavutil.mavlink

# The largest pause allowed between the vehicle's 1 Hz HEARTBEATs.
MAX_HEARTBEAT_GAP_S = 1.1


def discard_pending(sock):
    """Throws away every datagram already queued on a non-blocking socket."""
    while True:
        try:
            sock.recv(65535)
        except BlockingIOError:
            return


def sitl_udp_address(m):
    """The address the SITL's UDP link sends from, learnt from its datagrams."""
    assert m.wait_heartbeat(timeout=10), "no heartbeat over UDP"
    clients = getattr(m, "clients", None) or {m.last_address}
    return next(iter(clients))


class Stranger(threading.Thread):
    """Sends empty, 1-byte and random datagrams at `rate_hz` from its own
    socket, as a port scanner or a misdirected sensor would."""

    def __init__(self, to, rate_hz):
        super().__init__(daemon=True)
        self.to = to
        self.period = 1.0 / rate_hz
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.stop = threading.Event()
        self.sent = 0
        self.received = 0

    def run(self):
        datagrams = [b"", b"\x00", b"\xfd", b"\xfe", os.urandom(40), b"\xfd" + os.urandom(30)]
        next_at = time.monotonic()
        while not self.stop.is_set():
            self.sock.sendto(datagrams[self.sent % len(datagrams)], self.to)
            self.sent += 1
            try:
                while self.sock.recv(65536):
                    self.received += 1
            except BlockingIOError:
                pass
            next_at += self.period
            time.sleep(max(0.0, next_at - time.monotonic()))

    def finish(self):
        self.stop.set()
        self.join()
        self.sock.close()


def heartbeat_gaps(m, seconds):
    """The largest pause between the vehicle's HEARTBEATs over `seconds`
    (wall clock, the SITL at real speed), while the GCS sends its own 1 Hz
    HEARTBEAT like any ground station; and how many arrived."""
    last = time.monotonic()
    end = last + seconds
    next_gcs_heartbeat = last
    largest = 0.0
    count = 0
    while time.monotonic() < end:
        now = time.monotonic()
        if now >= next_gcs_heartbeat:
            m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            next_gcs_heartbeat = now + 1.0
        msg = m.recv_match(type="HEARTBEAT", blocking=True, timeout=0.1)
        if msg is not None and msg.get_srcSystem() == 1:
            at = time.monotonic()
            largest = max(largest, at - last)
            last = at
            count += 1
    return max(largest, time.monotonic() - last), count


# The gaps are timed as heartbeats arrive in this process.
@pytest.mark.serial
def test_a_strangers_garbage_leaves_the_gcs_heartbeat_gaps_under_1_1_s(tmp_path, udp_gcs):
    s = Sitl(tmp_path, udp_port=udp_port(udp_gcs), speedup="1")
    stranger = None
    try:
        quiet_gap, _ = heartbeat_gaps(udp_gcs, 3)
        stranger = Stranger(sitl_udp_address(udp_gcs), rate_hz=100)
        stranger.start()
        flood_gap, count = heartbeat_gaps(udp_gcs, 8)
        stranger.finish()
        print(f"heartbeat gap: quiet {quiet_gap:.3f} s, under garbage {flood_gap:.3f} s ({stranger.sent} datagrams)")
        assert stranger.sent >= 600, f"only {stranger.sent} datagrams sent"
        assert flood_gap < MAX_HEARTBEAT_GAP_S, f"gap {flood_gap:.2f} s under garbage (quiet {quiet_gap:.2f} s)"
        assert count >= 7, f"{count} heartbeats in 8 s"
        assert stranger.received == 0, f"the stranger got {stranger.received} datagrams"
        assert s.alive()
    finally:
        if stranger is not None and stranger.is_alive():
            stranger.finish()
        s.stop()


def corrupt_params(tmp_path):
    data = tmp_path / "vehicle"
    data.mkdir()
    (data / "params.parm").write_text("WP_SPEED,2.5\nWP_RADIUS,\x00garbage\n")
    return data


def is_params_notice(t):
    return "Parameter file unreadable" in t.text


def test_a_gcs_that_first_speaks_after_boot_on_udp_gets_the_damaged_params_notice(tmp_path):
    # Nobody reads the UDP link's port at boot: the ground station's socket
    # takes the port from the OS first (so no other process can), and what
    # arrived before it speaks is thrown away unread. Then it hears
    # telemetry and speaks.
    m = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255)
    s = Sitl(tmp_path, udp_port=udp_port(m), data_dir=corrupt_params(tmp_path))
    s.connections.append(m)
    try:
        time.sleep(2)
        discard_pending(m.port)
        assert m.wait_heartbeat(timeout=10)
        m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert recv(m, "STATUSTEXT", 5, is_params_notice) is not None, "the late GCS was never told"
    finally:
        s.stop()


def test_a_gcs_on_a_udpin_endpoint_gets_the_notice_when_it_first_speaks(tmp_path):
    # Port 0: the OS picks it, and the ready line says which.
    s = Sitl(tmp_path, data_dir=corrupt_params(tmp_path), extra_args=["--mavlink", "udpin:127.0.0.1:0"])
    port = int(re.search(r", listening udpin:127\.0\.0\.1:(\d+)", s.ready).group(1))
    try:
        time.sleep(1)
        m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
        s.connections.append(m)
        m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert recv(m, "STATUSTEXT", 5, is_params_notice) is not None, "the GCS was never told"
        # A second GCS on another address of the same endpoint is told too,
        # and both get the telemetry.
        other = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=254)
        s.connections.append(other)
        other.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert recv(other, "STATUSTEXT", 5, is_params_notice) is not None, "the second GCS was never told"
        for gcs in (m, other):
            gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            assert recv(gcs, "HEARTBEAT", 5, lambda h: h.get_srcSystem() == 1) is not None
    finally:
        s.stop()


def read_pty(fd, seconds):
    """Everything the vehicle writes to the pty's master side in `seconds`."""
    data = b""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            data += os.read(fd, 65536)
    return data


def test_a_serial_gcs_that_first_speaks_after_boot_gets_the_notice(tmp_path):
    # A radio link whose GCS attaches late: what the vehicle sent before
    # is gone (drained here), then the GCS's first frame arrives.
    master, slave = os.openpty()
    tty.setraw(master)
    s = Sitl(
        tmp_path,
        data_dir=corrupt_params(tmp_path),
        extra_args=["--mavlink", f"serial:{os.ttyname(slave)}:57600"],
    )
    try:
        before = read_pty(master, 2)
        assert len(before) > 0, "no telemetry on the serial link"
        mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        heartbeat = mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        os.write(master, heartbeat.pack(mav))
        texts = [m for m in mav.parse_buffer(read_pty(master, 3)) or [] if m.get_type() == "STATUSTEXT"]
        assert any(is_params_notice(t) for t in texts), f"not told; texts: {[t.text for t in texts]}"
    finally:
        s.stop()
        os.close(master)
        os.close(slave)


def param_indices(mav, data):
    """The PARAM_VALUE indices in `data`, and the table size."""
    values = [m for m in mav.parse_buffer(data) or [] if m.get_type() == "PARAM_VALUE"]
    return [v.param_index for v in values], (values[0].param_count if values else None)


def test_a_parameter_list_over_a_radio_waits_for_its_buffer_and_loses_nothing(tmp_path):
    # A telemetry radio on a serial port: the list is paced to the port, it
    # pauses while the radio reports its buffer nearly full (RADIO_STATUS
    # txbuf, percent free), and every parameter still arrives once.
    master, slave = os.openpty()
    tty.setraw(master)
    s = Sitl(tmp_path, extra_args=["--mavlink", f"serial:{os.ttyname(slave)}:57600"])
    try:
        gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        radio = mavlink.MAVLink(None, srcSystem=51, srcComponent=68)
        heartbeat = gcs.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        os.write(master, heartbeat.pack(gcs))
        read_pty(master, 1)
        os.write(master, radio.radio_status_encode(200, 200, 10, 50, 50, 0, 0).pack(radio))
        time.sleep(0.2)
        os.write(master, gcs.param_request_list_encode(1, 1).pack(gcs))
        held, _ = param_indices(gcs, read_pty(master, 1.0))
        assert held == [], f"{len(held)} parameters sent while the radio's buffer was full"
        os.write(master, radio.radio_status_encode(200, 200, 100, 50, 50, 0, 0).pack(radio))
        got, count = param_indices(gcs, read_pty(master, 3))
        assert count and sorted(got) == list(range(count)), f"{count} in the table, {len(set(got))} arrived"
        assert len(got) == count, "none twice"
    finally:
        s.stop()
        os.close(master)
        os.close(slave)
