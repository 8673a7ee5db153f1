"""Fixtures: a `furrow sitl` process per test, and pymavlink ground stations.

MAVLINK20 must be set before pymavlink is imported, or it loads the
MAVLink 1 dialect (no mission_type and other extension fields).
"""

import os

os.environ.setdefault("MAVLINK20", "1")

import pytest
from pymavlink import mavutil
import sitl
from sitl import FURROW, FURROW_BENCH, READY, REPO, Sitl  # noqa: F401 (the tests import them from here)


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "serial: passes only if this test's own Python keeps real time to a fraction of a second (a "
        "thread feeding a vehicle's devices, rates or gaps timed on arrival); tests/run runs these "
        "alone, after the others, which run several at a time")


@pytest.fixture(autouse=True)
def stop_leftover_furrows():
    """After each test, stops the `furrow` processes it started and left
    running (an assertion failed before its own stop)."""
    yield
    for process in list(sitl.RUNNING):
        process.stop()


@pytest.fixture
def start_sitl(tmp_path):
    started = []

    def start(**kwargs):
        s = Sitl(tmp_path, **kwargs)
        started.append(s)
        return s

    yield start
    for s in started:
        s.stop()


@pytest.fixture
def udp_gcs():
    """A UDP ground station listening on a free port (like QGC on 14550)."""
    m = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255)
    yield m
    m.close()


def udp_port(m):
    return m.port.getsockname()[1]
