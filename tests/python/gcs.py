"""Small helpers a pymavlink script would have."""

import math
import time

from pymavlink import mavutil

mavlink = mavutil.mavlink
EARTH_A = 6378137.0
EARTH_E2 = 6.69437999014e-3


def radii(lat_deg):
    s = math.sin(math.radians(lat_deg))
    w = math.sqrt(1.0 - EARTH_E2 * s * s)
    return EARTH_A * (1.0 - EARTH_E2) / w**3, EARTH_A / w


def offset(lat, lon, north_m, east_m):
    """Point north_m/east_m from (lat, lon); exact to well under a millimetre
    over tens of metres."""
    m, n = radii(lat)
    return lat + math.degrees(north_m / m), lon + math.degrees(east_m / (n * math.cos(math.radians(lat))))


def distance(lat1, lon1, lat2, lon2):
    m, n = radii((lat1 + lat2) / 2)
    dn = math.radians(lat2 - lat1) * m
    de = math.radians(lon2 - lon1) * n * math.cos(math.radians((lat1 + lat2) / 2))
    return math.hypot(dn, de)


def recv(m, mtype, timeout=10, cond=None):
    """The next message of a type (satisfying cond), or None."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        msg = m.recv_match(type=mtype, blocking=True, timeout=max(0.05, deadline - time.time()))
        if msg is not None and (cond is None or cond(msg)):
            return msg
    return None


def command(m, cmd, *params, timeout=5):
    """COMMAND_LONG and its ACK."""
    p = list(params) + [0] * (7 - len(params))
    m.mav.command_long_send(m.target_system, m.target_component, cmd, 0, *p)
    return recv(m, "COMMAND_ACK", timeout, lambda a: a.command == cmd)


def position(m, timeout=10):
    p = recv(m, "GLOBAL_POSITION_INT", timeout)
    assert p is not None, "no GLOBAL_POSITION_INT"
    return p.lat * 1e-7, p.lon * 1e-7


def home(m):
    ack = command(m, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    h = recv(m, "HOME_POSITION")
    assert h is not None
    return h.latitude * 1e-7, h.longitude * 1e-7


def goto(m, lat, lon):
    """A GUIDED position target, as MAVProxy's `guided` and MAVSDK send it."""
    mask = 0b0000_1111_1111_1000  # position only
    m.mav.set_position_target_global_int_send(
        0, m.target_system, m.target_component,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mask,
        int(round(lat * 1e7)), int(round(lon * 1e7)), 0,
        0, 0, 0, 0, 0, 0, 0, 0)


def reposition(m, lat, lon, yaw_deg=0):
    """DO_REPOSITION as a COMMAND_INT, switching to GUIDED as QGC's "go
    here" does; the yaw is the heading to arrive with. Returns its ACK."""
    m.mav.command_int_send(
        m.target_system, m.target_component, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_DO_REPOSITION, 0, 0,
        -1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, yaw_deg, int(lat * 1e7), int(lon * 1e7), 0)
    return recv(m, "COMMAND_ACK", 5, lambda a: a.command == mavlink.MAV_CMD_DO_REPOSITION)


def wait_mode(m, name, timeout=10):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if recv(m, "HEARTBEAT", 2) is not None and m.flightmode == name:
            return True
    return False


def message_rate(m, mtype, seconds):
    """Messages of a type per second, counted over `seconds` of wall time."""
    count = 0
    deadline = time.time() + seconds
    while time.time() < deadline:
        msg = m.recv_match(type=mtype, blocking=True, timeout=0.1)
        if msg is not None:
            count += 1
    return count / seconds


def message_rates(connections, mtype, seconds):
    """Rates of a message type on several links, counted in the same window."""
    counts = [0] * len(connections)
    deadline = time.time() + seconds
    while time.time() < deadline:
        for i, m in enumerate(connections):
            while m.recv_match(type=mtype, blocking=False) is not None:
                counts[i] += 1
        time.sleep(0.005)
    return [c / seconds for c in counts]


def param_id(name):
    return name.encode() if isinstance(name, str) else name


def fetch_all_params(m, timeout=10):
    """PARAM_REQUEST_LIST and every PARAM_VALUE that comes back, by index."""
    m.mav.param_request_list_send(m.target_system, m.target_component)
    got = {}
    count = None
    duplicates = 0
    deadline = time.time() + timeout
    while time.time() < deadline and (count is None or len(got) < count):
        v = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if v is None:
            continue
        count = v.param_count
        if v.param_index in got:
            duplicates += 1
        got[v.param_index] = v
    return got, count, duplicates


def param_read(m, name=None, index=-1, timeout=5):
    m.mav.param_request_read_send(m.target_system, m.target_component, param_id(name or ""), index)
    want = name

    def match(v):
        return (v.param_id == want) if want else v.param_index == index

    return recv(m, "PARAM_VALUE", timeout, match)


def param_set(m, name, value, ptype=mavlink.MAV_PARAM_TYPE_REAL32, timeout=5):
    """PARAM_SET and its PARAM_VALUE echo."""
    m.mav.param_set_send(m.target_system, m.target_component, param_id(name), value, ptype)
    return recv(m, "PARAM_VALUE", timeout, lambda v: v.param_id == name)


# --- Missions -----------------------------------------------------------------

def mission_item(seq, command, x=0, y=0, z=0.0, params=(0, 0, 0, 0), frame=None, mission_type=0, current=0):
    """A MISSION_ITEM_INT (x/y: degE7 for global frames, metres × 1e4 for local)."""
    if frame is None:
        frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT if command < 100 or command >= 5000 else mavlink.MAV_FRAME_MISSION
    return mavlink.MAVLink_mission_item_int_message(
        0, 0, seq, frame, command, current, 1, *params, x, y, z, mission_type)


def load_waypoints(path):
    """A QGC WPL 110 file as MISSION_ITEM_INT messages."""
    items = []
    with open(path) as f:
        assert f.readline().startswith("QGC WPL 110")
        for line in f:
            v = line.split()
            if not v:
                continue
            seq, current, frame, command = (int(x) for x in v[:4])
            p = [float(x) for x in v[4:8]]
            lat, lon, alt = float(v[8]), float(v[9]), float(v[10])
            items.append(mission_item(seq, command, int(round(lat * 1e7)), int(round(lon * 1e7)), alt, p, frame, current=current))
    return items


def upload_mission(m, items, mission_type=0, timeout=30):
    """Uploads items the way QGroundControl does (answering the vehicle's
    MISSION_REQUEST_INT); returns the final MISSION_ACK."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(items), mission_type)
    deadline = time.time() + timeout
    while time.time() < deadline:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True, timeout=1)
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ACK":
            if msg.mission_type == mission_type:
                return msg
            continue
        if msg.mission_type != mission_type:
            continue
        it = items[msg.seq]
        m.mav.mission_item_int_send(m.target_system, m.target_component, it.seq, it.frame, it.command, it.current,
                                    it.autocontinue, it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z,
                                    mission_type)
    return None


def download_mission(m, mission_type=0, timeout=30, counts=None):
    """Downloads a plan item by item, as QGroundControl does (an item not
    there within a second is requested again); returns (items, opaque_id).
    A dict `counts` gets how many requests were sent again ("resent") and
    how many MISSION_ITEM_INT came that were not the one asked for
    ("unexpected": duplicates, or items nobody asked for)."""
    deadline = time.time() + timeout
    count_msg = None
    while count_msg is None:
        # As QGroundControl does, the list is asked for again when no count came within a
        # second: a slow vehicle (a simulator under a profiler) must not fail the download.
        assert time.time() < deadline, "no MISSION_COUNT"
        m.mav.mission_request_list_send(m.target_system, m.target_component, mission_type)
        count_msg = recv(m, "MISSION_COUNT", 1, lambda c: c.mission_type == mission_type)
    opaque_id = count_opaque_id(count_msg)
    items = []
    resent = unexpected = 0
    for seq in range(count_msg.count):
        while True:
            m.mav.mission_request_int_send(m.target_system, m.target_component, seq, mission_type)
            it, others = mission_item_reply(m, seq, mission_type)
            unexpected += others
            if it is not None:
                items.append(it)
                break
            resent += 1
            assert time.time() < deadline, f"item {seq} never came"
    m.mav.mission_ack_send(m.target_system, m.target_component, mavlink.MAV_MISSION_ACCEPTED, mission_type)
    if counts is not None:
        counts["resent"] = counts.get("resent", 0) + resent
        counts["unexpected"] = counts.get("unexpected", 0) + unexpected
    return items, opaque_id


def mission_item_reply(m, seq, mission_type, timeout=1):
    """The MISSION_ITEM_INT `seq` of `mission_type` (None if it does not
    come within `timeout`), and how many other MISSION_ITEM_INT came first."""
    others = 0
    deadline = time.time() + timeout
    while time.time() < deadline:
        it = m.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=max(0.05, deadline - time.time()))
        if it is None:
            continue
        if it.seq == seq and it.mission_type == mission_type:
            return it, others
        others += 1
    return None, others


def same_item(a, b):
    fields = ("seq", "frame", "command", "autocontinue", "x", "y")
    if any(getattr(a, f) != getattr(b, f) for f in fields):
        return False
    import math as _m
    for f in ("param1", "param2", "param3", "param4", "z"):
        x, y = getattr(a, f), getattr(b, f)
        if not ((_m.isnan(x) and _m.isnan(y)) or x == y):
            return False
    return True


def raw_u32(msg, offset):
    """A field pymavlink's dialect does not define (a newer extension such as
    the opaque plan ids): read from the raw MAVLink 2 payload, where trailing
    zeros may have been trimmed."""
    import struct as _s
    buf = msg.get_msgbuf()
    payload = bytes(buf[10:-2]) + bytes(64)
    return _s.unpack_from("<I", payload, offset)[0]


def ack_opaque_id(ack):
    return raw_u32(ack, 4)


def count_opaque_id(count):
    return raw_u32(count, 5)


def current_ids(cur):
    """MISSION_CURRENT's (mission_id, fence_id, rally_points_id)."""
    return raw_u32(cur, 6), raw_u32(cur, 10), raw_u32(cur, 14)
