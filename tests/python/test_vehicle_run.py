"""`furrow run --config` with real devices stood in for by what the OS gives
us: the GNSS receiver on a pseudo-terminal (behind a symlink, so it can be
unplugged and replugged), an NTRIP caster on loopback TCP, PWM outputs in a
fake sysfs tree. The ground station is pymavlink over TCP, as ever.
"""

import os

os.environ.setdefault("MAVLINK20", "1")

import pathlib
import re
import socket
import subprocess
import threading
import time
import tty

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from conftest import FURROW, REPO
from sitl import FurrowProcess
from gcs import command, distance, goto, param_set, recv

# Python threads feed the vehicle's GNSS and magnetic sensor in real time.
pytestmark = pytest.mark.serial

READY = re.compile(r"furrow run ready: tcp (\S+):(\d+)")
NMEA_LOG = REPO / "tests" / "data" / "nmea" / "agv_rtk.nmea"
TRIM_NS = 1_500_000


class Receiver:
    """A GNSS receiver on a pty whose device path is a symlink."""

    def __init__(self, link):
        self.link = pathlib.Path(link)
        self.master = None
        self.received = bytearray()
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.thread = None
        self.plug()

    def plug(self):
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        tmp = self.link.with_suffix(".new")
        if tmp.exists() or tmp.is_symlink():
            tmp.unlink()
        tmp.symlink_to(os.ttyname(slave))
        os.rename(tmp, self.link)
        # The slave stays open here too, so the pty survives until unplug.
        self.master, self.slave = master, slave
        self.stop.clear()
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        import select
        while not self.stop.is_set():
            r, _, _ = select.select([self.master], [], [], 0.05)
            if r:
                try:
                    data = os.read(self.master, 4096)
                except OSError:
                    return
                with self.lock:
                    self.received += data

    def write(self, data):
        os.write(self.master, data)

    def unplug(self):
        self.link.unlink()
        self.stop.set()
        self.thread.join()
        os.close(self.master)
        os.close(self.slave)

    def take(self):
        with self.lock:
            data = bytes(self.received)
            self.received.clear()
        return data


class Player:
    """Replays the NMEA log at 10 Hz (four sentences per epoch). Paused, the
    receiver is silent; resumed, the replay goes on where it stopped."""

    def __init__(self, receiver):
        self.lines = NMEA_LOG.read_bytes().splitlines(keepends=True)
        self.receiver = receiver
        self.index = 0
        self.last_gga = None
        self.running = threading.Event()
        self.sending = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.running.set()
        self.sending.set()
        self.thread.start()

    def _run(self):
        while self.running.is_set() and self.index < len(self.lines):
            if not self.sending.wait(0.05):
                continue
            epoch = self.lines[self.index:self.index + 4]
            try:
                self.receiver.write(b"".join(epoch))
            except OSError:
                time.sleep(0.1)
                continue
            for line in epoch:
                if line.startswith(b"$GNGGA"):
                    self.last_gga = line.decode()
            self.index += 4
            time.sleep(0.1)

    def pause(self):
        self.sending.clear()

    def resume(self):
        self.sending.set()

    def stop(self):
        self.running.clear()
        self.thread.join()


def crc24q(data):
    crc = 0
    for byte in data:
        crc ^= byte << 16
        for _ in range(8):
            crc <<= 1
            if crc & 0x1000000:
                crc ^= 0x1864CFB
    return crc & 0xFFFFFF


def rtcm3_frame(payload):
    """An RTCM 3 frame: preamble, 10-bit length, payload, CRC-24Q."""
    head = bytes([0xD3, (len(payload) >> 8) & 0x03, len(payload) & 0xFF]) + payload
    return head + crc24q(head).to_bytes(3, "big")


def gga_position(line):
    f = line.split(",")
    lat = int(f[2][:2]) + float(f[2][2:]) / 60.0
    lon = int(f[4][:3]) + float(f[4][3:]) / 60.0
    return lat, lon


class Caster:
    """An NTRIP v2 caster: answers one mountpoint, streams corrections and
    keeps the GGA sentences the client sends back."""

    def __init__(self, frames):
        self.server = socket.socket()
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(1)
        self.port = self.server.getsockname()[1]
        self.frames = frames
        self.request = b""
        self.upstream = bytearray()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        conn, _ = self.server.accept()
        conn.settimeout(0.2)
        while b"\r\n\r\n" not in self.request:
            try:
                self.request += conn.recv(1024)
            except socket.timeout:
                continue
        conn.sendall(b"HTTP/1.1 200 OK\r\nNtrip-Version: Ntrip/2.0\r\nContent-Type: gnss/data\r\n\r\n")
        for frame in self.frames:
            conn.sendall(frame)
            time.sleep(0.2)
        deadline = time.time() + 30
        while time.time() < deadline:
            try:
                data = conn.recv(1024)
            except socket.timeout:
                continue
            if not data:
                break
            self.upstream += data
        conn.close()


def crc8_smbus(data):
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


class MagneticSensor:
    """A 16-probe guide sensor pair on a pty, 50 frames/s in the documented
    frame: A5 5A, front mask, rear mask (u16 LE), sequence, CRC-8/SMBUS."""

    def __init__(self):
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.running = threading.Event()
        self.running.set()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        seq = 0
        while self.running.is_set():
            body = (0x0180).to_bytes(2, "little") + (0x0180).to_bytes(2, "little") + bytes([seq])
            os.write(self.master, b"\xa5\x5a" + body + bytes([crc8_smbus(body)]))
            seq = (seq + 1) % 256
            time.sleep(0.02)

    def close(self):
        self.running.clear()
        self.thread.join()
        os.close(self.master)
        os.close(self.slave)


def fake_pwm_tree(root):
    chip = root / "pwmchip0"
    chip.mkdir(parents=True)
    (chip / "npwm").write_text("4\n")
    (chip / "export").write_text("")
    (chip / "unexport").write_text("")
    for ch in range(4):
        d = chip / f"pwm{ch}"
        d.mkdir()
        (d / "period").write_text("0\n")
        (d / "duty_cycle").write_text("0\n")
        (d / "enable").write_text("0\n")
        (d / "polarity").write_text("normal\n")
    return chip


def duty_ns(chip, ch):
    return int((chip / f"pwm{ch}" / "duty_cycle").read_text().strip() or 0)


class Vehicle(FurrowProcess):
    def __init__(self, config_path, workdir):
        super().__init__([FURROW, "run", "--config", str(config_path)], pathlib.Path(workdir) / "furrow-run.log",
                         ready=READY, what="furrow run")


def write_config(tmp_path, gnss_link, caster_port, pwm_root, magnetic_path):
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

[corrections]
mavlink = true

[corrections.ntrip]
host = "127.0.0.1"
port = {caster_port}
mountpoint = "TEST"
user = "agv"
password = "secret"
version = 2
gga_interval_s = 1

[magnetic]
serial = "{magnetic_path}"
baud = 115200

[pwm]
root = "{pwm_root}"
period_us = 20000

[[pwm.output]]
servo = 1
chip = 0
channel = 0

[[pwm.output]]
servo = 3
chip = 0
channel = 1

[[mavlink]]
endpoint = "tcpin:127.0.0.1:0"
""")
    return config


def statustexts(m, seconds, want):
    """STATUSTEXTs for up to `seconds`, until one contains `want`."""
    seen = []
    deadline = time.time() + seconds
    while time.time() < deadline:
        t = recv(m, "STATUSTEXT", max(0.1, deadline - time.time()))
        if t is None:
            break
        seen.append(t.text)
        if want in t.text:
            return seen
    raise AssertionError(f"no STATUSTEXT with {want!r}; saw {seen}")


def test_vehicle_with_pty_gnss_ntrip_rtcm_and_sysfs_pwm(tmp_path):
    receiver = Receiver(tmp_path / "gnss0")
    player = Player(receiver)
    # Payloads with the bytes a careless link would mangle (CR, LF, NUL, $).
    rtcm_frames = [rtcm3_frame(bytes(range(k, k + 19)) + b"\r\n\x00\x24") for k in range(3)]
    caster = Caster(rtcm_frames)
    chip = fake_pwm_tree(tmp_path / "pwm")
    magnetic = MagneticSensor()
    config = write_config(tmp_path, tmp_path / "gnss0", caster.port, tmp_path / "pwm", magnetic.path)
    vehicle = Vehicle(config, tmp_path)
    m = None
    try:
        m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{vehicle.tcp_port}", source_system=255)
        assert m.wait_heartbeat(timeout=10)

        # Outputs are at trim from the start.
        deadline = time.time() + 5
        while time.time() < deadline and duty_ns(chip, 1) != TRIM_NS:
            time.sleep(0.1)
        assert duty_ns(chip, 0) == TRIM_NS and duty_ns(chip, 1) == TRIM_NS
        assert (chip / "pwm1" / "period").read_text().strip() == "20000000"
        assert (chip / "pwm1" / "enable").read_text().strip() == "1"

        # Position as the log says (the log stands still for its first 20 s).
        time.sleep(3)
        log_lat, log_lon = gga_position(player.last_gga)
        p = recv(m, "GLOBAL_POSITION_INT", 5)
        assert p is not None
        err = distance(p.lat * 1e-7, p.lon * 1e-7, log_lat, log_lon)
        assert err < 0.05, f"GLOBAL_POSITION_INT {err:.3f} m from the log"
        # The dual-antenna heading (HDT 45°) and its quality.
        raw = recv(m, "GPS_RAW_INT", 5, lambda r: r.fix_type == mavlink.GPS_FIX_TYPE_RTK_FIXED)
        assert raw is not None, "no RTK fixed GPS_RAW_INT"
        assert raw.yaw == 4500 and 0 < raw.hdg_acc < 500000, (raw.yaw, raw.hdg_acc)
        hud = recv(m, "VFR_HUD", 5)
        assert hud is not None and hud.heading == 45, hud

        # Corrections from the caster reach the receiver byte-exact, and the
        # caster gets our position back as GGA.
        expected = b"".join(rtcm_frames)
        got = bytearray()
        deadline = time.time() + 10
        while time.time() < deadline and expected not in got:
            got += receiver.take()
            time.sleep(0.1)
        assert expected in got, f"caster corrections not on the GNSS port: {bytes(got)[:80]!r}"
        assert b"Authorization: Basic" in caster.request and b"GET /TEST" in caster.request
        deadline = time.time() + 5
        while time.time() < deadline and b"$GPGGA" not in caster.upstream:
            time.sleep(0.1)
        gga = bytes(caster.upstream).decode(errors="replace")
        assert "$GPGGA" in gga, gga
        up_line = gga[gga.index("$GPGGA"):].split("\r\n")[0]
        up = up_line.split(",")
        up_lat = int(up[2][:2]) + float(up[2][2:]) / 60.0
        assert abs(up_lat - log_lat) < 1e-6, up_line

        # GPS_RTCM_DATA, fragmented as the spec says (400 bytes: 180+180+40),
        # arrives whole and byte-exact.
        message = bytes((7 * i + 3) % 256 for i in range(400))
        seq = 5
        for frag in range(3):
            chunk = message[frag * 180:(frag + 1) * 180]
            flags = 1 | (frag << 1) | (seq << 3)
            m.mav.gps_rtcm_data_send(flags, len(chunk), chunk + bytes(180 - len(chunk)))
        got = bytearray()
        deadline = time.time() + 5
        while time.time() < deadline and message not in got:
            got += receiver.take()
            time.sleep(0.05)
        assert message in got, "fragmented RTCM not reassembled onto the GNSS port"

        # The device table over MAVLink.
        out = subprocess.run([FURROW, "status", "--tcp", f"127.0.0.1:{vehicle.tcp_port}"],
                             capture_output=True, text=True, timeout=20)
        assert out.returncode == 0, out.stderr
        gnss_line = [line for line in out.stdout.splitlines() if line.startswith("GNSS ")]
        assert gnss_line and " OK " in gnss_line[0], out.stdout
        # Four sentences per 10 Hz epoch.
        rate = float(re.search(r"GNSS OK ([0-9.]+)Hz", gnss_line[0]).group(1))
        assert 20.0 <= rate <= 50.0, gnss_line
        assert any(line.startswith("NTRIP OK") for line in out.stdout.splitlines()), out.stdout
        assert any(line.startswith("PWM OK") for line in out.stdout.splitlines()), out.stdout
        mag = [line for line in out.stdout.splitlines() if line.startswith("Magnetic ")]
        assert mag and mag[0].startswith("Magnetic OK"), out.stdout
        assert 25.0 <= float(re.search(r"OK ([0-9.]+)Hz", mag[0]).group(1)) <= 60.0, mag

        # Arm, GUIDED goto ahead: the throttle output moves; disarm: trims.
        # This vehicle has no scanners: obstacle stopping must be off to move.
        param_set(m, "OA_ENABLE", 0)
        m.mav.set_mode_send(m.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15)
        ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED, (ack, vehicle.log()[-2000:])
        goto(m, log_lat + 0.0003, log_lon + 0.0003)
        deadline = time.time() + 5
        while time.time() < deadline and duty_ns(chip, 1) == TRIM_NS:
            goto(m, log_lat + 0.0003, log_lon + 0.0003)
            time.sleep(0.2)
        assert duty_ns(chip, 1) > TRIM_NS, "throttle did not move"
        ack = command(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
        deadline = time.time() + 3
        while time.time() < deadline and (duty_ns(chip, 1), duty_ns(chip, 0)) != (TRIM_NS, TRIM_NS):
            time.sleep(0.05)
        assert (duty_ns(chip, 0), duty_ns(chip, 1)) == (TRIM_NS, TRIM_NS)

        # Garbage on the GNSS line is survived.
        receiver.write(bytes(range(256)) * 8 + b"$GNGGA,garbage*00\r\n")
        assert recv(m, "HEARTBEAT", 3) is not None and vehicle.proc.poll() is None

        # Unplug: announced lost; replug: announced ok, position again.
        player.stop()
        receiver.unplug()
        statustexts(m, 6, "GNSS lost")
        receiver.plug()
        player = Player(receiver)
        statustexts(m, 8, "GNSS ok")
        assert recv(m, "GLOBAL_POSITION_INT", 5) is not None
    finally:
        player.stop()
        magnetic.close()
        if m is not None:
            m.close()
        code = vehicle.stop()
    assert code == 0, vehicle.log()[-3000:]
    # On exit the outputs rest at trim.
    assert (duty_ns(chip, 0), duty_ns(chip, 1)) == (TRIM_NS, TRIM_NS)


def test_bad_config_is_refused_with_key_and_line(tmp_path):
    config = tmp_path / "bad.toml"
    config.write_text('[vehicle]\nframe = "ackermann"\n\n[gnss]\nserial = "/dev/ttyUSB0"\nbaud = 11520\n')
    out = subprocess.run([FURROW, "run", "--config", str(config)], capture_output=True, text=True, timeout=20)
    assert out.returncode == 1
    assert "bad.toml:6" in out.stderr and "gnss.baud" in out.stderr, out.stderr
