"""MAVSDK (mavsdk-grpc with its bundled mavsdk_server) against Furrow: the
health flags it derives from SYS_STATUS and HOME_POSITION, and the version
it reads from AUTOPILOT_VERSION."""

import asyncio
import pathlib
import queue
import re
import subprocess
import threading
import time
import tomllib

import mavsdk_grpc
from conftest import REPO
from mavsdk_grpc import System

MAVSDK_SERVER = pathlib.Path(mavsdk_grpc.__file__).parent / "bin" / "mavsdk_server"
LISTENING = re.compile(r"Server set to listen on \S+:(\d+)")


class MavsdkServer:
    """The bundled mavsdk_server, started here rather than by System so that
    its gRPC port can come from the OS (-p 0): once it has found the vehicle
    it says which port it was given."""

    def __init__(self, system_address, timeout=30):
        self.proc = subprocess.Popen([str(MAVSDK_SERVER), "-p", "0", system_address],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.output = []
        lines = queue.Queue()
        # Drained to the end: a full pipe would stall the server.
        threading.Thread(target=self._drain, args=(lines,), daemon=True).start()
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                self.stop()
                raise AssertionError("mavsdk_server did not start its gRPC server:\n" + "".join(self.output))
            if line is None:
                raise AssertionError("mavsdk_server exited:\n" + "".join(self.output))
            if match := LISTENING.search(line):
                self.port = int(match.group(1))
                return

    def _drain(self, lines):
        for line in self.proc.stdout:
            self.output.append(line)
            lines.put(line)
        lines.put(None)

    def stop(self):
        self.proc.kill()
        self.proc.wait()


def health_and_version(tcp_port):
    server = MavsdkServer(f"tcpout://127.0.0.1:{tcp_port}")
    try:
        return asyncio.run(asyncio.wait_for(query_health_and_version(server.port), 60))
    finally:
        server.stop()


async def query_health_and_version(grpc_port):
    drone = System(mavsdk_server_address="127.0.0.1", port=grpc_port)
    await drone.connect()
    async for state in drone.core.connection_state():
        if state.is_connected:
            break
    health, all_ok = None, None
    for _ in range(20):
        async for h in drone.telemetry.health():
            health = h
            break
        if health.is_armable and health.is_home_position_ok and health.is_gyrometer_calibration_ok:
            break
        await asyncio.sleep(0.5)
    async for ok in drone.telemetry.health_all_ok():
        all_ok = ok
        break
    version = await drone.info.get_version()
    return health, all_ok, version


def test_mavsdk_sees_a_ready_vehicle_and_its_version(start_sitl):
    sitl = start_sitl(speedup="1")
    health, all_ok, version = health_and_version(sitl.tcp_port)
    print(health, "health_all_ok", all_ok, version)
    # What Furrow has, reported ready: the simulated IMU (VectorNav $VNIMU,
    # on by default in SITL) as gyro and accelerometer, the heading sensor in
    # the magnetometer slot, GNSS position, home, pre-arm checks passed.
    # MAVSDK sets each calibration flag from SYS_STATUS's present and health
    # bits; health_all_ok() needs all three plus positions and home.
    assert health.is_gyrometer_calibration_ok and health.is_accelerometer_calibration_ok, health
    assert health.is_magnetometer_calibration_ok, health
    assert health.is_global_position_ok and health.is_local_position_ok, health
    assert health.is_home_position_ok and health.is_armable, health
    assert all_ok is True
    cargo = tomllib.loads((REPO / "Cargo.toml").read_text())
    major, minor, patch = (int(x) for x in cargo["workspace"]["package"]["version"].split("."))
    assert (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch) == (major, minor, patch)
    assert version.flight_sw_version_type.name == "DEV"
    # MAVSDK renders flight_custom_version PX4's way (hex of bytes 3..8);
    # what matters is that they are the hash's characters, not NULs.
    assert version.flight_sw_git_hash.strip("\x00") != "0000000000"


def test_without_an_imu_the_gyro_and_accelerometer_flags_stay_false(start_sitl):
    sitl = start_sitl(speedup="1", extra_args=["--no-imu"])
    health, all_ok, _ = health_and_version(sitl.tcp_port)
    print(health, "health_all_ok", all_ok)
    # No unit, no bits: nothing could back them.
    assert not health.is_gyrometer_calibration_ok and not health.is_accelerometer_calibration_ok
    assert health.is_magnetometer_calibration_ok and health.is_armable, health
    assert all_ok is False
