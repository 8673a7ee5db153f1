#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (fuzz/corpus/TARGET/seed-*)
from the repository's own data and from MAVLink frames made with pymavlink.

    target/venv/bin/python fuzz/seeds.py

Deterministic: running it again rewrites the same files. Inputs libFuzzer
found worth keeping (merged from long runs) sit beside them, named by their
SHA-1. Byte 0 of the stream targets (mavlink_core, nmea, cola) is the chunk
size the target pushes the rest in; of param_file, the format.
"""
import os
import pathlib

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as mav2  # noqa: E402
from pymavlink.dialects.v10 import ardupilotmega as mav1  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
HOME_LAT, HOME_LON = 29.1330, 119.6400


def write(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    (d / f"seed-{name}").write_bytes(data)


class Gcs:
    """Packs messages as a ground station (255/190) would send them."""

    def __init__(self, module):
        self.m = module.MAVLink(None, srcSystem=255, srcComponent=190)
        self.mod = module

    def pack(self, msg):
        return msg.pack(self.m)


def mavlink_seeds():
    g = Gcs(mav2)
    m = mav2
    e7 = lambda d: int(round(d * 1e7))  # noqa: E731

    def item(seq, command, lat=0.0, lon=0.0, frame=m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, params=(0, 0, 0, 0),
             mission_type=0):
        return m.MAVLink_mission_item_int_message(1, 1, seq, frame, command, 0, 1, *params, e7(lat), e7(lon), 0.0,
                                                  mission_type)

    def cmd_long(command, *p):
        p = list(p) + [0.0] * (7 - len(p))
        return m.MAVLink_command_long_message(1, 1, command, 0, *p)

    single = {
        "heartbeat": m.MAVLink_heartbeat_message(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3),
        "param_request_list": m.MAVLink_param_request_list_message(1, 1),
        "param_request_read_name": m.MAVLink_param_request_read_message(1, 1, b"WP_SPEED", -1),
        "param_request_read_index": m.MAVLink_param_request_read_message(1, 1, b"", 3),
        "param_set": m.MAVLink_param_set_message(1, 1, b"WP_SPEED", 2.5, m.MAV_PARAM_TYPE_REAL32),
        "param_set_sysid": m.MAVLink_param_set_message(1, 1, b"SYSID_THISMAV", 7, m.MAV_PARAM_TYPE_UINT8),
        "param_set_hash": m.MAVLink_param_set_message(1, 1, b"_HASH_CHECK", 0, m.MAV_PARAM_TYPE_UINT32),
        "mission_request_list": m.MAVLink_mission_request_list_message(1, 1, 0),
        "mission_request_list_fence": m.MAVLink_mission_request_list_message(1, 1, 1),
        "mission_request_int": m.MAVLink_mission_request_int_message(1, 1, 0, 0),
        "mission_request": m.MAVLink_mission_request_message(1, 1, 0, 0),
        "mission_ack": m.MAVLink_mission_ack_message(1, 1, 0, 0),
        "mission_clear_all": m.MAVLink_mission_clear_all_message(1, 1, 0),
        "mission_write_partial_list": m.MAVLink_mission_write_partial_list_message(1, 1, 0, 1, 0),
        "mission_set_current": m.MAVLink_mission_set_current_message(1, 1, 1),
        "set_mode_guided": m.MAVLink_set_mode_message(1, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15),
        "manual_control": m.MAVLink_manual_control_message(1, 0, 300, 500, 0, 0),
        "rc_override": m.MAVLink_rc_channels_override_message(1, 1, 1600, 0, 1700, 0, 0, 0, 0, 0),
        "request_data_stream": m.MAVLink_request_data_stream_message(1, 1, 0, 10, 1),
        "position_target": m.MAVLink_set_position_target_global_int_message(
            0, 1, 1, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0b0000111111111000, e7(HOME_LAT + 0.0003),
            e7(HOME_LON), 0, 0, 0, 0, 0, 0, 0, 0, 0),
        "cmd_arm": cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 1),
        "cmd_force_arm": cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196),
        "cmd_disarm": cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 0),
        "cmd_set_mode": cmd_long(m.MAV_CMD_DO_SET_MODE, 1, 10),
        "cmd_rtl": cmd_long(m.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        "cmd_set_home": cmd_long(m.MAV_CMD_DO_SET_HOME, 1),
        "cmd_change_speed": cmd_long(m.MAV_CMD_DO_CHANGE_SPEED, 1, 1.5, -1),
        "cmd_mission_start": cmd_long(m.MAV_CMD_MISSION_START),
        "cmd_set_mission_current": cmd_long(m.MAV_CMD_DO_SET_MISSION_CURRENT, 1),
        "cmd_request_message": cmd_long(m.MAV_CMD_REQUEST_MESSAGE, 148),
        "cmd_set_interval": cmd_long(m.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 100000),
        "cmd_get_interval": cmd_long(m.MAV_CMD_GET_MESSAGE_INTERVAL, 33),
        "cmd_get_home": cmd_long(m.MAV_CMD_GET_HOME_POSITION),
        "cmd_reposition": m.MAVLink_command_int_message(
            1, 1, m.MAV_FRAME_GLOBAL_INT, m.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0, e7(HOME_LAT + 0.0002),
            e7(HOME_LON + 0.0001), 0),
        "item_waypoint": item(1, m.MAV_CMD_NAV_WAYPOINT, HOME_LAT + 0.0003, HOME_LON),
        "item_float": m.MAVLink_mission_item_message(1, 1, 1, m.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                                     m.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, HOME_LAT,
                                                     HOME_LON, 0, 0),
    }
    for name, msg in single.items():
        write("mavlink_core", name, bytes([255]) + g.pack(msg))

    # A complete mission upload: count, home and three waypoints, a speed
    # change; then AUTO and arm.
    upload = [m.MAVLink_mission_count_message(1, 1, 5, 0),
              item(0, m.MAV_CMD_NAV_WAYPOINT, HOME_LAT, HOME_LON),
              item(1, m.MAV_CMD_NAV_WAYPOINT, HOME_LAT + 0.0003, HOME_LON),
              item(2, m.MAV_CMD_DO_CHANGE_SPEED, frame=m.MAV_FRAME_MISSION, params=(1, 2, -1, 0)),
              item(3, m.MAV_CMD_NAV_WAYPOINT, HOME_LAT + 0.0003, HOME_LON + 0.0003),
              item(4, m.MAV_CMD_NAV_RETURN_TO_LAUNCH, frame=m.MAV_FRAME_MISSION),
              cmd_long(m.MAV_CMD_DO_SET_MODE, 1, 10),
              cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 1)]
    session = b"".join(g.pack(x) for x in upload)
    write("mavlink_core", "mission_upload", bytes([255]) + session)
    write("mavlink_core", "mission_upload_chunked", bytes([7]) + session)

    fence = [m.MAVLink_mission_count_message(1, 1, 2, 1),
             item(0, m.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, HOME_LAT, HOME_LON, frame=m.MAV_FRAME_GLOBAL_INT,
                  params=(100, 0, 0, 0), mission_type=1),
             item(1, m.MAV_CMD_NAV_FENCE_RETURN_POINT, HOME_LAT, HOME_LON, frame=m.MAV_FRAME_GLOBAL_INT,
                  mission_type=1)]
    write("mavlink_core", "fence_upload", bytes([255]) + b"".join(g.pack(x) for x in fence))

    guided = [m.MAVLink_set_mode_message(1, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15),
              cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 1),
              single["position_target"]]
    write("mavlink_core", "guided", bytes([255]) + b"".join(g.pack(x) for x in guided))

    # MAVLink 1, garbage around frames, a bad CRC, an unknown command id and
    # an item with a command the dialect lacks.
    g1 = Gcs(mav1)
    write("mavlink_core", "v1_param_set",
          bytes([255]) + g1.pack(mav1.MAVLink_param_set_message(1, 1, b"WP_SPEED", 1.0, 9)))
    arm = g.pack(cmd_long(m.MAV_CMD_COMPONENT_ARM_DISARM, 1))
    bad_crc = arm[:-1] + bytes([arm[-1] ^ 0xFF])
    write("mavlink_core", "garbage", bytes([3]) + b"\x00\xfd\x01garbage\xfe" + bad_crc + arm + b"\xfd")
    unknown = bytearray(g.pack(cmd_long(m.MAV_CMD_NAV_WAYPOINT)))
    write("mavlink_core", "unknown_command", bytes([255]) + repack(unknown, 28, 31999, m))
    bad_item = bytearray(g.pack(item(1, m.MAV_CMD_NAV_WAYPOINT, HOME_LAT, HOME_LON)))
    write("mavlink_core", "undecodable_item", bytes([255]) + repack(bad_item, 30, 31999, m))


def repack(frame, offset, value, m):
    """A MAVLink 2 frame with a u16 payload field replaced, CRC recomputed."""
    from pymavlink.generator import mavcrc

    length = frame[1]
    payload = bytearray(frame[10:10 + length])
    payload += bytes(max(0, offset + 2 - len(payload)))
    payload[offset:offset + 2] = value.to_bytes(2, "little")
    while len(payload) > 1 and payload[-1] == 0:
        payload.pop()
    msgid = int.from_bytes(frame[7:10], "little")
    header = bytes([0xFD, len(payload)]) + bytes(frame[2:10])
    crc = mavcrc.x25crc(header[1:] + payload)
    crc.accumulate(bytes([m.mavlink_map[msgid].crc_extra]))
    return header + payload + crc.crc.to_bytes(2, "little")


def nmea_seeds():
    data = (ROOT / "tests/data/nmea/agv_rtk.nmea").read_bytes()
    lines = data.splitlines(keepends=True)
    write("nmea", "agv_rtk_head", bytes([255]) + b"".join(lines[:16]))
    write("nmea", "agv_rtk_chunked", bytes([5]) + b"".join(lines[16:32]))

    def sentence(body):
        c = 0
        for b in body.encode():
            c ^= b
        return f"${body}*{c:02X}\r\n"

    others = [
        "GPVTG,45.0,T,,M,0.5,N,0.9,K,A",
        "GNTHS,123.4,A", "GNTHS,,V", "HCHDM,98.3,M", "HCHDG,98.3,0.0,E,12.6,W", "HCHDG,98.3,,,,",
        "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "GPGGA,,,,,,0,,,,,,,,",
        "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W", "GPRMC,123519,V,,,,,,,230394,,",
        "GPGST,172814.0,0.006,0.023,0.020,273.6,0.023,0.020,0.031", "GPHDT,274.07,T", "GPZDA,201530.00,04,07,2002,00,00",
        "PUBX,00,081350.00,4717.113210,N",
    ]
    write("nmea", "sentences", bytes([255]) + "".join(sentence(s) for s in others).encode())
    write("nmea", "bad_checksum", bytes([255]) + b"$GPHDT,274.07,T*00\r\n$GPGGA,1*ZZ\r\n!AIVDM,1*00\n")


def cola_seeds():
    sra = ("sRA LMDscandata 1 1 10A2F3C 0 0 2B3 2B7 5F5E100 5F5E4E8 0 0 7 0 0 1388 168 0 "
           "1 DIST1 3F800000 00000000 FFF92230 1388 5 1F4 0 3E8 FFFF 64 0 0 0 0 0 0")
    ssn = ("sSN LMDscandata 1 1 A1B2C3 0 0 10 11 1000 1010 0 0 0 0 0 9C4 1C2 1 5DC 64 "
           "2 RSSI1 3F800000 00000000 0 2710 3 FF 80 0 "
           "DIST1 40000000 3F800000 0 2710 3 A 14 0 "
           "1 RSSI2 3F800000 00000000 0 2710 3 1 2 3 "
           "0 1 7 LMS-111 0 1 7E8 1 F 8 1E 2D 0 0")
    framed = lambda body: b"\x02" + body.encode() + b"\x03"  # noqa: E731
    write("cola", "lms1xx_sra", bytes([255]) + framed(sra))
    write("cola", "streamed_ssn", bytes([9]) + framed(ssn))
    write("cola", "answers", bytes([255]) + framed("sEA LMDscandata 1") + framed("sFA 5")
          + framed("sAN SetAccessMode 1") + b"noise" + framed("sWA LMPoutputRange"))
    write("cola", "cut_short", bytes([4]) + b"\x02sSN LMDscandata 1 1\x02" + framed(sra))


def file_seeds():
    for path in sorted((ROOT / "tests/data/worlds").glob("*.toml")):
        write("world_file", path.stem, path.read_bytes())
    for path in sorted((ROOT / "autopilot/examples").glob("*.toml")):
        write("config_file", path.stem, path.read_bytes())
    for path in sorted((ROOT / "tests/data/bench").glob("*.waypoints")):
        write("mission_file", path.stem, path.read_bytes())
    write("mission_file", "qgc_plan", PLAN)
    write("param_file", "mission_planner",
          b"\x00# saved\nWP_SPEED,2.5\nWP_RADIUS 1.5\nCRUISE_SPEED\t3\n\nFS_ACTION,2 # hold\n"
          b"SR0_POSITION        10.000000\nSYSID_THISMAV,1\nSCHED_LOOP_RATE,50\n")
    write("param_file", "qgroundcontrol",
          b"\x01# Onboard parameters\n#\n# Vehicle-Id Component-Id Name Value Type\n"
          b"1\t1\tWP_SPEED\t2.500000000000000000\t9\n1\t1\tFS_ACTION\t2\t2\n1\t1\tSR0_POSITION\t10\t4\n")


PLAN = """{
    "fileType": "Plan",
    "geoFence": {
        "circles": [{"circle": {"center": [29.1330, 119.6400], "radius": 120}, "inclusion": true, "version": 1}],
        "polygons": [{"inclusion": false, "polygon": [[29.1331, 119.6401], [29.1332, 119.6401],
                      [29.1332, 119.6402]], "version": 1}],
        "version": 2
    },
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 2,
        "firmwareType": 3,
        "hoverSpeed": 5,
        "items": [
            {"AMSLAltAboveTerrain": null, "Altitude": 0, "AltitudeMode": 1, "autoContinue": true, "command": 16,
             "doJumpId": 1, "frame": 3, "params": [0, 0, 0, null, 29.1333, 119.6400, 0], "type": "SimpleItem"},
            {"autoContinue": true, "command": 178, "doJumpId": 2, "frame": 2, "params": [1, 1.5, -1, 0, 0, 0, 0],
             "type": "SimpleItem"},
            {"autoContinue": true, "command": 16, "doJumpId": 3, "frame": 3,
             "params": [0, 0, 0, null, 29.1333, 119.6404, 0], "type": "SimpleItem"},
            {"autoContinue": true, "command": 177, "doJumpId": 4, "frame": 2, "params": [1, 2, 0, 0, 0, 0, 0],
             "type": "SimpleItem"},
            {"autoContinue": true, "command": 20, "doJumpId": 5, "frame": 2, "params": [0, 0, 0, 0, 0, 0, 0],
             "type": "SimpleItem"}
        ],
        "plannedHomePosition": [29.1330, 119.6400, 40],
        "vehicleType": 10,
        "version": 2
    },
    "rallyPoints": {"points": [[29.1331, 119.6399, 0]], "version": 2},
    "version": 1
}
"""

if __name__ == "__main__":
    mavlink_seeds()
    nmea_seeds()
    cola_seeds()
    file_seeds()
