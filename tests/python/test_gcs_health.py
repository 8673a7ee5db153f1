"""What ground stations read for "ready" and "which firmware": SYS_STATUS as
MAVSDK's telemetry plugin interprets it, and AUTOPILOT_VERSION.

MAVSDK (telemetry_impl.cpp, process_sys_status) sets each calibration flag
only when the sensor's present bit is set, to its health bit; global and
local position from GPS present and healthy; is_armable from the
PREARM_CHECK health bit; home from HOME_POSITION. health_all_ok() needs
gyro, accelerometer, magnetometer, local, global and home. The logic is
replayed here with pymavlink (mavsdk_server is not installed)."""

import tomllib

from conftest import REPO
from gcs import command, mavlink, recv

S = mavlink


def mavsdk_health(sys_status, home_seen):
    present, health = sys_status.onboard_control_sensors_present, sys_status.onboard_control_sensors_health
    flags = {}
    for name, bit in [("gyro", S.MAV_SYS_STATUS_SENSOR_3D_GYRO), ("accel", S.MAV_SYS_STATUS_SENSOR_3D_ACCEL),
                      ("mag", S.MAV_SYS_STATUS_SENSOR_3D_MAG)]:
        flags[name] = bool(health & bit) if present & bit else None  # None: never set (stays false)
    gps = bool(present & S.MAV_SYS_STATUS_SENSOR_GPS and health & S.MAV_SYS_STATUS_SENSOR_GPS)
    flags.update(global_position=gps, local_position=gps, home=home_seen,
                 armable=bool(health & S.MAV_SYS_STATUS_PREARM_CHECK))
    return flags


def ready_status(m, timeout=20):
    return recv(m, "SYS_STATUS", timeout, lambda s: s.onboard_control_sensors_health & S.MAV_SYS_STATUS_PREARM_CHECK)


def test_a_ready_vehicle_reports_its_sensors_present_enabled_and_healthy(start_sitl):
    m = start_sitl().tcp()
    status = ready_status(m)
    assert status is not None, "never ready"
    have = (S.MAV_SYS_STATUS_SENSOR_GPS | S.MAV_SYS_STATUS_SENSOR_3D_MAG | S.MAV_SYS_STATUS_AHRS
            | S.MAV_SYS_STATUS_SENSOR_3D_GYRO | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL)
    for field in ("present", "enabled", "health"):
        bits = getattr(status, f"onboard_control_sensors_{field}")
        assert bits & have == have, f"{field}: {bits:#x}"
    ack = command(m, S.MAV_CMD_REQUEST_MESSAGE, S.MAVLINK_MSG_ID_HOME_POSITION)
    assert ack is not None and ack.result == S.MAV_RESULT_ACCEPTED
    home_seen = recv(m, "HOME_POSITION", 5) is not None
    flags = mavsdk_health(status, home_seen)
    assert flags["mag"] and flags["global_position"] and flags["local_position"] and flags["home"] \
        and flags["armable"], flags
    # The simulated IMU backs the gyro and accelerometer bits, so every
    # flag health_all_ok() needs is true.
    assert flags["gyro"] and flags["accel"], flags


def test_without_an_imu_the_gyro_and_accelerometer_are_not_claimed(start_sitl):
    m = start_sitl(extra_args=["--no-imu"]).tcp()
    status = ready_status(m)
    assert status is not None, "never ready"
    flags = mavsdk_health(status, True)
    # MAVSDK never sets these two, so its health_all_ok() stays false
    # (reported, not faked).
    assert flags["gyro"] is None and flags["accel"] is None, flags
    assert flags["mag"] and flags["armable"], flags


def test_a_silent_heading_sensor_turns_the_magnetometer_bit_unhealthy(start_sitl):
    m = start_sitl().tcp()
    assert ready_status(m) is not None
    m.mav.param_set_send(m.target_system, m.target_component, b"SIM_HDG_ENABLE", 0, S.MAV_PARAM_TYPE_REAL32)
    mag = S.MAV_SYS_STATUS_SENSOR_3D_MAG
    status = recv(m, "SYS_STATUS", 15, lambda s: not s.onboard_control_sensors_health & mag)
    assert status is not None and status.onboard_control_sensors_present & mag


def test_autopilot_version_carries_the_git_hash_and_ardupilots_version_packing(start_sitl):
    m = start_sitl().tcp()
    ack = command(m, S.MAV_CMD_REQUEST_MESSAGE, S.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack is not None and ack.result == S.MAV_RESULT_ACCEPTED
    v = recv(m, "AUTOPILOT_VERSION", 5)
    assert v is not None
    custom = bytes(v.flight_custom_version)
    assert len(custom) == 8 and all(chr(b) in "0123456789abcdef" for b in custom), custom
    assert custom != b"00000000", "built in a checkout: a real hash"
    packed = tuple(v.flight_sw_version.to_bytes(4, "big"))
    cargo = tomllib.loads((REPO / "Cargo.toml").read_text())
    version = tuple(int(x) for x in cargo["workspace"]["package"]["version"].split("."))
    assert packed == (*version, 0), "major<<24 | minor<<16 | patch<<8 | FIRMWARE_VERSION_TYPE_DEV"
