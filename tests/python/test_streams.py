"""Stream rates follow SRn_* defaults and change on request, in wall time."""

import pytest
from gcs import command, mavlink, message_rate, message_rates

# Rates are counted as messages arrive in this process.
pytestmark = pytest.mark.serial


def test_request_data_stream_and_message_interval(start_sitl):
    # Rates are wall-clock rates whatever the speedup.
    m = start_sitl(speedup="5").tcp()
    base = message_rate(m, "GLOBAL_POSITION_INT", 3)
    assert 3 <= base <= 5, f"SR0_POSITION default 4 Hz, got {base:.1f}"

    # What MAVProxy sends on connect.
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_POSITION, 10, 1)
    fast = message_rate(m, "GLOBAL_POSITION_INT", 3)
    assert 8.5 <= fast <= 11, f"asked 10 Hz, got {fast:.1f}"

    ack = command(m, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    att = message_rate(m, "ATTITUDE", 3)
    assert 17 <= att <= 21, f"asked 20 Hz, got {att:.1f}"

    ack = command(m, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -1)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    m.recv_match(type="ATTITUDE", blocking=True, timeout=0.5)
    assert message_rate(m, "ATTITUDE", 2) == 0

    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 0, 0)
    m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=0.5)
    assert message_rate(m, "GLOBAL_POSITION_INT", 2) == 0
    # The heartbeat is not a stream: it keeps coming.
    assert message_rate(m, "HEARTBEAT", 3) >= 0.6


def test_rates_are_per_link(start_sitl):
    sitl = start_sitl()
    a, b = sitl.tcp(), sitl.tcp()
    a.mav.request_data_stream_send(a.target_system, a.target_component, mavlink.MAV_DATA_STREAM_POSITION, 20, 1)
    rate_a, rate_b = message_rates([a, b], "GLOBAL_POSITION_INT", 3)
    assert rate_a > 15 and 3 <= rate_b <= 5, (rate_a, rate_b)
