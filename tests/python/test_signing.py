"""MAVLink 2 signing against the real binary, with pymavlink as a ground
station would use it: the key is set with SETUP_SIGNING on a secure link
(`--secure-mavlink`), kept in the data directory, and from then on the TCP
server (stream slot 0, in SIGN_REQUIRE by default) acts only on signed
packets. Telemetry still reaches a client without the key (the frames are
signed, and pymavlink without a key does not check signatures), as with
ArduPilot."""

import os

os.environ.setdefault("MAVLINK20", "1")

import re
import stat
import time

import pytest
from pymavlink import mavutil

from conftest import Sitl
from gcs import recv

mavlink = mavutil.mavlink
SECURE = re.compile(r", secure tcpin:127\.0\.0\.1:(\d+)")
KEY = bytes(range(101, 133))
OTHER_KEY = bytes(range(1, 33))
SIGNING_EPOCH = 1420070400


class SigningSitl(Sitl):
    """`furrow sitl` with one secure TCP endpoint whose port is read from the
    ready line."""

    def __init__(self, workdir, data_dir=None, extra_args=()):
        super().__init__(workdir, data_dir=data_dir,
                         extra_args=["--secure-mavlink", "tcpin:127.0.0.1:0", *extra_args])
        secure = SECURE.search(self.ready)
        if not secure:
            self.stop()
            raise RuntimeError(f"no secure endpoint in the ready line: {self.ready!r}\n{self.log()}")
        self.secure_port = int(secure.group(1))

    def connect(self, port=None, source_system=255, key=None):
        """A TCP client, signing with `key` when given, after a heartbeat."""
        m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port or self.tcp_port}", source_system=source_system)
        self.connections.append(m)
        if key is not None:
            m.setup_signing(key, sign_outgoing=True)
        assert m.wait_heartbeat(timeout=10), "no heartbeat"
        return m

    def key_file(self):
        return self.data_dir / "signing.key"


@pytest.fixture
def sitls(tmp_path):
    started = []

    def start(**kwargs):
        s = SigningSitl(tmp_path, **kwargs)
        started.append(s)
        return s

    yield start
    for s in started:
        s.stop()


def signing_now():
    return int((time.time() - SIGNING_EPOCH) * 100_000)


def set_key(m, key, target_system=1):
    m.mav.setup_signing_send(target_system, 1, key, signing_now())


def wait_for(predicate, timeout=5):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


def provision(sitl, key=KEY):
    """Sets the key over the secure link and waits until it is stored."""
    secure = sitl.connect(port=sitl.secure_port, source_system=254)
    set_key(secure, key)
    assert wait_for(lambda: sitl.key_file().exists()), "no key file after SETUP_SIGNING on the secure link"
    secure.setup_signing(key, sign_outgoing=True)
    return secure


def param(m, name, timeout=3):
    m.mav.param_request_read_send(1, 1, name.encode(), -1)
    return recv(m, "PARAM_VALUE", timeout, lambda p: p.param_id == name)


def command_ack(m, cmd, timeout):
    return recv(m, "COMMAND_ACK", timeout, lambda a: a.command == cmd)


def arm_command(m, arm):
    return m.mav.command_long_encode(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1 if arm else 0,
                                     0, 0, 0, 0, 0, 0)


def armed(m):
    hb = recv(m, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1)
    assert hb is not None, "no vehicle heartbeat"
    return bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)


def arm(m, want=True, timeout=20):
    """Arms (retrying while pre-arm checks wait for a position fix) or disarms."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        m.mav.send(arm_command(m, want))
        ack = command_ack(m, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 2)
        if ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED:
            return ack
        time.sleep(0.3)
    raise AssertionError(f"{'arm' if want else 'disarm'} not accepted")


def signature_timestamp(msg):
    buf = msg.get_msgbuf()
    assert buf[0] == 0xFD and buf[2] & 1, "not a signed MAVLink 2 frame"
    return int.from_bytes(buf[-12:-6], "little")


def test_key_set_on_the_secure_link_only_and_never_leaks(sitls, tmp_path):
    tlog = tmp_path / "link.tlog"
    sitl = sitls(extra_args=["--tlog", str(tlog)])
    plain = sitl.connect(source_system=253)
    # (5) SETUP_SIGNING on the TCP server (not secure): refused, no key.
    set_key(plain, OTHER_KEY)
    assert param(plain, "SIGN_REQUIRE") is not None, "the link still works unsigned before any key"
    assert not sitl.key_file().exists()
    assert "SETUP_SIGNING refused on insecure link" in sitl.log()

    # (1) On the secure link: stored, owner-only.
    secure = provision(sitl)
    mode = stat.S_IMODE(os.stat(sitl.key_file()).st_mode)
    assert mode == 0o600, oct(mode)
    stored = sitl.key_file().read_text()
    assert KEY.hex() in stored
    # The secure link goes on with signed traffic both ways.
    value = param(secure, "SIGN_REQUIRE")
    assert value is not None and value.param_value == 15
    assert signature_timestamp(value) > 0

    # (5) again, now that a key is set: the plain link still cannot change it.
    set_key(plain, OTHER_KEY)
    set_key(plain, bytes(32))
    assert wait_for(lambda: sitl.log().count("SETUP_SIGNING refused on insecure link") >= 3)
    assert sitl.key_file().read_text() == stored

    sitl.stop()
    # The key is nowhere else: parameters, missions, tlog, log.
    for path in [p for p in sitl.data_dir.iterdir() if p.name != "signing.key"] + [tlog, sitl.stderr_path]:
        data = path.read_bytes()
        assert KEY not in data and KEY.hex().encode() not in data, f"key material in {path.name}"
    log = mavutil.mavlink_connection(str(tlog))
    types = set()
    while (m := log.recv_match()) is not None:
        types.add(m.get_type())
    assert "HEARTBEAT" in types and "PARAM_VALUE" in types, types
    assert "SETUP_SIGNING" not in types


def test_only_signed_commands_act_replays_do_not_and_radios_pass(sitls):
    sitl = sitls()
    secure = provision(sitl)
    signed = sitl.connect(key=KEY)
    unsigned = sitl.connect(source_system=254)

    # (3) Unsigned: telemetry still arrives, commands and PARAM_SET do not act.
    assert recv(unsigned, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1) is not None
    unsigned.mav.send(arm_command(unsigned, True))
    assert command_ack(unsigned, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) is None
    unsigned.mav.param_set_send(1, 1, b"SIGN_REQUIRE", 0, mavlink.MAV_PARAM_TYPE_INT8)
    assert recv(unsigned, "PARAM_VALUE", 1.0) is None
    assert not armed(signed)
    assert param(signed, "SIGN_REQUIRE").param_value == 15

    # (2) Signed: arms and disarms.
    ack = arm(signed, True)
    assert signature_timestamp(ack) > 0
    assert armed(signed)

    # (4) A captured signed disarm, replayed verbatim after re-arming, on the
    # same connection and on another: the vehicle stays armed.
    disarm = arm_command(signed, False)
    signed.mav.send(disarm)
    captured = bytes(disarm.get_msgbuf())
    assert command_ack(signed, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 3).result == mavlink.MAV_RESULT_ACCEPTED
    assert wait_for(lambda: not armed(signed), 5)
    arm(signed, True)
    signed.write(captured)
    unsigned.write(captured)
    assert command_ack(signed, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) is None
    assert armed(signed) and armed(signed)
    assert wait_for(lambda: "replayed" in sitl.log() and re.search(r"[1-9]\d* replayed", sitl.log()), 5)
    arm(signed, False)

    # (7) Unsigned RADIO_STATUS on the requiring link is taken; an unsigned
    # HEARTBEAT is not. Observable: the router learns a sender only from
    # frames it took, and forwards broadcasts (the signed client's
    # heartbeats) only to links where it has learned someone.
    def forwarded_heartbeats(seconds):
        deadline = time.time() + seconds
        seen = 0
        while time.time() < deadline:
            signed.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            if recv(unsigned, "HEARTBEAT", 0.2, lambda h: h.get_srcSystem() == 255) is not None:
                seen += 1
        return seen

    unsigned.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    assert forwarded_heartbeats(1.0) == 0, "an unsigned HEARTBEAT taught the router"
    unsigned.mav.radio_status_send(200, 180, 90, 20, 18, 0, 0)
    assert forwarded_heartbeats(1.0) > 0, "the unsigned RADIO_STATUS was dropped"

    # SIGN_REQUIRE set by a signed PARAM_SET reaches the links: slot 0 no
    # longer requires signatures.
    signed.mav.param_set_send(1, 1, b"SIGN_REQUIRE", 14, mavlink.MAV_PARAM_TYPE_INT8)
    assert recv(signed, "PARAM_VALUE", 3, lambda p: p.param_id == "SIGN_REQUIRE").param_value == 14
    value = param(unsigned, "SIGN_REQUIRE")
    assert value is not None and value.param_value == 14
    secure.close()


def test_key_and_timestamp_survive_a_restart(sitls, tmp_path):
    data = tmp_path / "kept"
    first = sitls(data_dir=data)
    provision(first)
    signed = first.connect(key=KEY)
    arm(signed, True)
    arm(signed, False)
    last = signature_timestamp(recv(signed, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1))
    first.stop()
    # Saved at the clean exit, at least as late as anything signed before.
    stored = int(re.search(r"^timestamp (\d+)$", first.key_file().read_text(), re.M).group(1))
    assert stored >= last

    # (6) Same data directory: the key is there, a signed client arms, an
    # unsigned one cannot. The vehicle's timestamps start a minute past the
    # stored one (what a crash could have lost since the last save), not
    # at the clock, which is only seconds later.
    second = sitls(data_dir=data)
    again = second.connect(key=KEY)
    hb = recv(again, "HEARTBEAT", 3, lambda h: h.get_srcSystem() == 1)
    assert hb is not None and signature_timestamp(hb) > stored + 60 * 100_000
    unsigned = second.connect(source_system=254)
    unsigned.mav.send(arm_command(unsigned, True))
    assert command_ack(unsigned, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) is None
    arm(again, True)
    assert armed(again)
