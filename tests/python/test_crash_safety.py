"""Crash safety: SIGKILL at random moments during mission uploads and
parameter saves; every restart on the same data directory must find the
old or the new mission (never a mix), each parameter at its old or new
value, and files that load without a "damaged file" notice. A change
acknowledged (MISSION_ACK, PARAM_VALUE echo) DURABLE_AFTER before the kill
must have survived it. `furrow bench safety --only kill` does this at
length; this is the quick version, independent of the bench's client."""

import random
import threading
import time

from conftest import Sitl
from gcs import download_mission, mavlink, mission_item, param_read, param_set, same_item

HOME = (29.1330, 119.6400)
DURABLE_AFTER = 0.1
PARAMS = ["PVW_DIST", "PVW_LAT_P", "PVW_LAT_I", "PVW_YAW_P", "PVW_FF_TIME",
          "MAG_STR_P", "MAG_STR_I", "MAG_SPD_P", "MAG_SPEED", "MAG_LOST_HOLD"]


def make_mission(rng, n):
    lat0, lon0 = (int(round(v * 1e7)) for v in HOME)
    items = [mission_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, lat0, lon0, 40.0, frame=mavlink.MAV_FRAME_GLOBAL)]
    for seq in range(1, n):
        # Binary fractions: exact in the f32 fields, so the items compare equal.
        hold = rng.randint(0, 100) / 8
        items.append(mission_item(seq, mavlink.MAV_CMD_NAV_WAYPOINT, lat0 + rng.randint(-40000, 40000),
                                  lon0 + rng.randint(-40000, 40000), rng.randint(0, 50) / 16, (hold, 0, 0, 0)))
    return items


def upload_until_killed(m, sitl, items):
    """Uploads as a GCS does until the vehicle ACKs or dies; returns when the
    ACCEPTED ack arrived (None if it did not)."""
    m.mav.mission_count_send(1, 1, len(items), 0)
    while sitl.alive():
        try:
            msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True, timeout=0.2)
        except OSError:
            return None
        if msg is None or msg.mission_type != 0:
            continue
        if msg.get_type() == "MISSION_ACK":
            return time.monotonic() if msg.type == mavlink.MAV_MISSION_ACCEPTED else None
        it = items[msg.seq]
        try:
            m.mav.mission_item_int_send(1, 1, it.seq, it.frame, it.command, it.current, it.autocontinue,
                                        it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, 0)
        except OSError:
            return None
    return None


def set_until_killed(m, sitl, values):
    """PARAM_SET one after the other, each after its echo; when each was echoed."""
    echoed = {}
    for name, value in values.items():
        try:
            v = param_set(m, name, value, timeout=1)
        except OSError:
            break
        if v is None or not sitl.alive():
            break
        echoed[name] = time.monotonic()
    return echoed


def kill_later(sitl, delay):
    """SIGKILLs the process after `delay` s; the returned list gets the time."""
    at = []

    def fire():
        sitl.proc.kill()
        at.append(time.monotonic())

    t = threading.Timer(delay, fire)
    t.start()
    return t, at


def same_mission(got, items):
    # Item 0 is home, which a download reports as the current home.
    return len(got) == len(items) and all(same_item(a, b) for a, b in zip(got[1:], items[1:]))


def restart(tmp_path, data):
    s = Sitl(tmp_path, speedup="max", data_dir=data)
    m = s.tcp()
    return s, m


def check_clean_start(s, data):
    log = s.log()
    assert "unreadable" not in log and "could not be read" not in log, log
    assert not [p.name for p in data.iterdir() if ".corrupt-" in p.name]


def test_sigkill_during_uploads_and_parameter_saves_leaves_old_or_new(tmp_path):
    rng = random.Random(8)
    data = tmp_path / "data"
    s, m = restart(tmp_path, data)
    # A known starting point, acknowledged well before the kill.
    old_mission = make_mission(rng, 30)
    upload_until_killed(m, s, old_mission)
    old_params = {name: round(rng.uniform(0.1, 1.0), 3) for name in PARAMS}
    assert len(set_until_killed(m, s, old_params)) == len(PARAMS)
    t0 = time.monotonic()
    upload_until_killed(m, s, make_mission(rng, 200))
    per_item = (time.monotonic() - t0) / 200
    time.sleep(DURABLE_AFTER + 0.2)
    # That upload replaced the 30 items: it is the old mission now.
    got, _ = download_mission(m)
    assert len(got) == 200
    old_mission = got
    s.proc.kill()
    s.stop()

    outcomes = {"mission new": 0, "mission old": 0, "params new": 0, "params old": 0}
    for run in range(8):
        s, m = restart(tmp_path, data)
        check_clean_start(s, data)
        if run % 2 == 0:
            new = make_mission(rng, rng.choice([10, 60, 250]))
            timer, killed = kill_later(s, rng.uniform(0, per_item * len(new) + 0.05))
            acked = upload_until_killed(m, s, new)
        else:
            new = {name: round(rng.uniform(0.1, 1.0), 3) for name in PARAMS}
            timer, killed = kill_later(s, rng.uniform(0, 0.1))
            echoed = set_until_killed(m, s, new)
        timer.join()
        s.stop()

        s, m = restart(tmp_path, data)
        check_clean_start(s, data)
        got, _ = download_mission(m)
        if run % 2 == 0:
            if same_mission(got, new):
                outcomes["mission new"] += 1
                old_mission = got
            else:
                assert same_mission(got, old_mission), f"run {run}: a mix of {len(got)} items"
                outcomes["mission old"] += 1
                assert acked is None or killed[0] - acked < DURABLE_AFTER, "acknowledged mission lost"
        else:
            assert same_mission(got, old_mission), f"run {run}: mission changed without an upload"
            for name in PARAMS:
                v = param_read(m, name).param_value
                if abs(v - new[name]) < 1e-6:
                    outcomes["params new"] += 1
                    old_params[name] = new[name]
                else:
                    assert abs(v - old_params[name]) < 1e-6, f"{name} = {v}: neither {old_params[name]} nor {new[name]}"
                    outcomes["params old"] += 1
                    if name in echoed:
                        assert killed[0] - echoed[name] < DURABLE_AFTER, f"{name} echoed, then lost"
        s.stop()
    print(outcomes)
    assert sum(outcomes.values()) > 0
