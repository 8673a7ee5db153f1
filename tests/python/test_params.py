"""The parameter service against pymavlink, persistence across restarts, and
the offline tool with .param files."""

import math
import random
import signal
import struct
import subprocess
import time
import zlib

import pytest
from conftest import FURROW, Sitl, udp_port
from gcs import fetch_all_params, mavlink, param_read, param_set, recv
from mavproxy import MavProxy


@pytest.mark.parametrize("link", ["udp", "tcp"])
def test_fetch_all_has_every_index_once(start_sitl, udp_gcs, link):
    sitl = start_sitl(udp_port=udp_port(udp_gcs))
    m = udp_gcs if link == "udp" else sitl.tcp()
    assert m.wait_heartbeat(timeout=10)
    # Telemetry at full rate shares the link with the lists: the lists are
    # sent as fast as the link drains, and not one parameter may be lost.
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 50, 1)
    for _ in range(5):
        got, count, duplicates = fetch_all_params(m)
        assert count and count > 50
        assert sorted(got) == list(range(count)), f"no gaps over {link}: {count - len(got)} missing"
        assert duplicates == 0
    names = [v.param_id for v in got.values()]
    assert len(set(names)) == count
    assert all(v.param_count == count for v in got.values())
    for expected in ("SYSID_THISMAV", "WP_SPEED", "WP_RADIUS", "SR0_POSITION", "PVW_DIST", "SIM_SPEEDUP"):
        assert expected in names


def test_read_by_id_and_by_index_and_a_16_character_id(start_sitl):
    m = start_sitl().tcp()
    v = param_read(m, "WP_RADIUS")
    assert v is not None and v.param_value == 2.0 and v.param_type == mavlink.MAV_PARAM_TYPE_REAL32
    by_index = param_read(m, index=v.param_index)
    assert by_index.param_id == "WP_RADIUS"
    v16 = param_read(m, "RC_OVERRIDE_TIME")
    assert v16 is not None and len(v16.param_id) == 16 and v16.param_value == 3.0
    assert param_set(m, "RC_OVERRIDE_TIME", 5.0).param_value == 5.0


def test_set_then_read_back_and_integers(start_sitl):
    m = start_sitl().tcp()
    echo = param_set(m, "WP_SPEED", 3.25)
    assert echo.param_value == 3.25
    assert param_read(m, "WP_SPEED").param_value == 3.25
    echo = param_set(m, "SR1_EXTRA3", 5, mavlink.MAV_PARAM_TYPE_INT16)
    assert echo.param_value == 5 and echo.param_type == mavlink.MAV_PARAM_TYPE_INT16


@pytest.mark.parametrize("name,value,error", [
    ("WP_SPEED", float("nan"), mavlink.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE),
    ("WP_SPEED", float("inf"), mavlink.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE),
    ("WP_SPEED", 99.0, mavlink.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE),
    ("STAT_BOOTCNT", 77.0, mavlink.MAV_PARAM_ERROR_READ_ONLY),
])
def test_refused_sets_keep_the_old_value(start_sitl, name, value, error):
    m = start_sitl().tcp()
    old = param_read(m, name).param_value
    m.mav.param_set_send(m.target_system, m.target_component, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32)
    echo = recv(m, "PARAM_VALUE", 5, lambda v: v.param_id == name)
    assert echo is not None and echo.param_value == old
    text = recv(m, "STATUSTEXT", 5, lambda t: name in t.text)
    assert text is not None, "a STATUSTEXT names the parameter"
    assert param_read(m, name).param_value == old


def test_unknown_parameter_gets_param_error_and_statustext(start_sitl):
    m = start_sitl().tcp()
    m.mav.param_set_send(m.target_system, m.target_component, b"NO_SUCH_PARAM", 1.0, mavlink.MAV_PARAM_TYPE_REAL32)
    err = recv(m, "PARAM_ERROR", 5)
    assert err is not None and err.error == mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST
    assert recv(m, "STATUSTEXT", 5, lambda t: "NO_SUCH_PARAM" in t.text) is not None
    m.mav.param_request_read_send(m.target_system, m.target_component, b"NO_SUCH_PARAM", -1)
    assert recv(m, "PARAM_ERROR", 5) is not None


def test_a_set_with_an_invalid_type_still_gets_its_echo(start_sitl):
    m = start_sitl().tcp()
    m.mav.param_set_send(m.target_system, m.target_component, b"WP_RADIUS", 1.5, 0)
    echo = recv(m, "PARAM_VALUE", 5, lambda v: v.param_id == "WP_RADIUS")
    assert echo is not None and echo.param_value == 1.5


def test_values_survive_a_restart(tmp_path):
    data = tmp_path / "vehicle"
    s = Sitl(tmp_path, data_dir=data)
    m = s.tcp()
    boots = param_read(m, "STAT_BOOTCNT").param_value
    param_set(m, "WP_SPEED", 1.75)
    param_set(m, "SR0_POSITION", 7, mavlink.MAV_PARAM_TYPE_INT16)
    assert s.stop() == 0
    s = Sitl(tmp_path, data_dir=data)
    try:
        m = s.tcp()
        assert param_read(m, "WP_SPEED").param_value == 1.75
        assert param_read(m, "SR0_POSITION").param_value == 7
        assert param_read(m, "STAT_BOOTCNT").param_value == boots + 1
        text = (data / "params.parm").read_text()
        assert "WP_SPEED,1.75" in text and "WP_RADIUS" not in text, "only non-defaults, readable"
    finally:
        s.stop()


def test_speedup_flag_is_not_saved_over_the_stored_value(tmp_path):
    data = tmp_path / "vehicle"
    s = Sitl(tmp_path, data_dir=data, speedup="7")
    m = s.tcp()
    assert param_read(m, "SIM_SPEEDUP").param_value == 7
    s.stop()
    assert "SIM_SPEEDUP" not in (data / "params.parm").read_text()


def test_corrupt_file_is_set_aside_and_reported(tmp_path):
    data = tmp_path / "vehicle"
    data.mkdir()
    (data / "params.parm").write_text("WP_SPEED,2.5\nWP_RADIUS,\x00garbage\n")
    s = Sitl(tmp_path, data_dir=data)
    try:
        m = s.tcp(wait=False)
        text = recv(m, "STATUSTEXT", 10, lambda t: "unreadable" in t.text.lower() or "Parameter file" in t.text)
        assert text is not None
        assert param_read(m, "WP_SPEED").param_value == 2.0, "defaults loaded"
        moved = [p.name for p in data.iterdir() if "corrupt" in p.name]
        assert len(moved) == 1
        assert "unreadable" in s.log()
    finally:
        s.stop()


def run_furrow(*args):
    return subprocess.run([FURROW, *map(str, args)], capture_output=True, text=True, timeout=30)


def test_param_file_export_edit_import_round_trip(tmp_path):
    data = tmp_path / "vehicle"
    s = Sitl(tmp_path, data_dir=data)
    param_set(s.tcp(), "PVW_DIST", 2.5)
    s.stop()

    exported = tmp_path / "vehicle.param"
    r = run_furrow("params", "--data-dir", data, "export", exported)
    assert r.returncode == 0, r.stderr
    text = exported.read_text()
    assert "PVW_DIST,2.5\n" in text
    text = text.replace("PVW_DIST,2.5\n", "PVW_DIST,3.5\n").replace("WP_RADIUS,2\n", "WP_RADIUS,1.25\n")
    exported.write_text(text)
    r = run_furrow("params", "--data-dir", data, "import", exported)
    assert r.returncode == 0, r.stderr
    assert "2 changed" in r.stdout, r.stdout

    # QGroundControl's layout too.
    qgc = tmp_path / "vehicle.params"
    assert run_furrow("params", "--data-dir", data, "export", qgc).returncode == 0
    assert "\tPVW_DIST\t3.5\t9" in qgc.read_text()

    s = Sitl(tmp_path, data_dir=data)
    try:
        m = s.tcp()
        assert param_read(m, "PVW_DIST").param_value == 3.5
        assert param_read(m, "WP_RADIUS").param_value == 1.25
    finally:
        s.stop()


def test_offline_tool_rejects_bad_input_and_changes_nothing(tmp_path):
    data = tmp_path / "vehicle"
    s = Sitl(tmp_path, data_dir=data)
    # The first save is asked for by the core's first steps: wait for them
    # (a loaded machine may not have stepped yet when the ready line comes).
    s.tcp()
    deadline = time.monotonic() + 10
    while not (data / "params.parm").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    # While the autopilot runs, the directory is locked.
    r = run_furrow("params", "--data-dir", data, "set", "WP_SPEED", "3")
    assert r.returncode != 0 and "in use" in r.stderr
    s.stop()
    before = (data / "params.parm").read_text()
    for args, message in [
        (("set", "NO_SUCH", "1"), "unknown parameter NO_SUCH"),
        (("set", "WP_SPEED", "fast"), "not a number"),
        (("set", "WP_SPEED", "1e9"), "outside"),
        (("get", "NOPE"), "unknown parameter NOPE"),
    ]:
        r = run_furrow("params", "--data-dir", data, *args)
        assert r.returncode != 0 and message in r.stderr, (args, r.stderr)
    bad = tmp_path / "bad.param"
    bad.write_text("WP_SPEED,3\nWP_RADIUS,400\n")
    r = run_furrow("params", "--data-dir", data, "import", bad)
    assert r.returncode != 0 and "line 2" in r.stderr
    assert (data / "params.parm").read_text() == before
    assert run_furrow("params", "--data-dir", data, "get", "WP_SPEED").stdout.strip() == "2"


def test_hash_check_matches_the_values_a_gcs_received(start_sitl):
    m = start_sitl().tcp()

    def hash_now():
        v = param_read(m, "_HASH_CHECK")
        assert v.param_type == mavlink.MAV_PARAM_TYPE_UINT32
        return struct.unpack("<I", struct.pack("<f", v.param_value))[0]

    got, count, _ = fetch_all_params(m)
    crc = 0
    for v in sorted(got.values(), key=lambda v: v.param_id):
        crc = zlib.crc32(v.param_id.encode(), crc)
        crc = zlib.crc32(struct.pack("<f", v.param_value), crc)
    h0 = hash_now()
    assert h0 == crc, "the hash is computable from the downloaded values"
    param_set(m, "PVW_DIST_K", 0.75)
    assert hash_now() != h0


# A line `param show` prints, after any prompts ("HOLD> ") before it.
SHOWN = r"^(\w+> )*"


def test_mavproxy_param_show_and_set(start_sitl, tmp_path):
    sitl = start_sitl()
    mavproxy = MavProxy(sitl.tcp_port, tmp_path, ["--cmd", "set param_ftp 0"])
    try:
        # MAVProxy downloads the parameters first; type once it has them.
        mavproxy.wait_for(r"Received \d+ parameters")
        mavproxy.wait_for(rf"{SHOWN}WP_SPEED\s", start=mavproxy.send("param show WP_SPEED"))
        mavproxy.send("param set WP_SPEED 2.7")
        # MAVProxy sends the set from its idle loop, and its table takes
        # the vehicle's echo: shown, 2.7 means the vehicle has it.
        deadline = time.monotonic() + 10
        while mavproxy.find(rf"{SHOWN}WP_SPEED\s+2\.7(0{{4,}}\d*)?\s*$") is None:
            assert time.monotonic() < deadline, mavproxy.output()
            mavproxy.wait_for(rf"{SHOWN}WP_SPEED\s", start=mavproxy.send("param show WP_SPEED"))
        mavproxy.wait_for(rf"{SHOWN}WP_RADIUS\s", start=mavproxy.send("param show WP_RADIUS"))
    finally:
        out = mavproxy.close()
    assert "WP_SPEED         2.0" in out, out
    assert "WP_RADIUS        2.0" in out, out
    m = sitl.tcp()
    assert math.isclose(param_read(m, "WP_SPEED").param_value, 2.7, rel_tol=1e-6)


def test_sigkill_during_parameter_bursts_never_corrupts_the_table(tmp_path):
    """Sets parameters in a loop and SIGKILLs the process at random moments,
    20 times: every restart loads a valid table holding, for each parameter,
    either its value before the burst or one of the values sent in it."""
    data = tmp_path / "vehicle"
    names = ["PVW_LAT_P", "PVW_LAT_I", "PVW_LAT_D"]
    rng = random.Random(42)
    allowed = None
    total_sets = 0
    for round_ in range(21):
        s = Sitl(tmp_path, data_dir=data, speedup="1")
        m = s.tcp()
        assert "unreadable" not in s.log(), f"round {round_}: {s.log()}"
        before = {n: param_read(m, n).param_value for n in names}
        if allowed is not None:
            for n in names:
                assert any(math.isclose(before[n], x, rel_tol=1e-6) for x in allowed[n]), (round_, n, before[n])
        if round_ == 20:
            s.stop()
            break
        allowed = {n: [before[n]] for n in names}
        kill_at = time.time() + rng.uniform(0.05, 1.0)
        while time.time() < kill_at:
            n = rng.choice(names)
            value = round(rng.uniform(0, 5), 3)
            m.mav.param_set_send(m.target_system, m.target_component, n.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32)
            allowed[n].append(value)
            total_sets += 1
            time.sleep(0.002)
        s.proc.send_signal(signal.SIGKILL)
        s.proc.wait()
        s.stop()
        # The stored file parses (the offline tool reads it without a warning).
        r = run_furrow("params", "--data-dir", data, "list", "--changed")
        assert r.returncode == 0 and "unreadable" not in r.stderr, r.stderr
    assert total_sets > 200, "the bursts really set parameters"
