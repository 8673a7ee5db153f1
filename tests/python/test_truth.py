"""What a ground station checks Furrow's accuracy with, from outside:
LOCAL_POSITION_NED (the estimate in float metres about the local origin) and,
in SITL, SIMSTATE (the simulator's true pose), both read with pymavlink and
checked against GLOBAL_POSITION_INT within its 1e-7 degree resolution."""

import math
import time

from gcs import distance, mavlink, offset, position, recv, wait_mode, goto

# Half a 1e-7 degree step on each axis at the SITL home (29 degrees north).
HALF_STEP_M = math.hypot(0.5e-7 * 111_000, 0.5e-7 * 111_000 * math.cos(math.radians(29.1)))


def collect(m, seconds):
    """Every LOCAL_POSITION_NED, GLOBAL_POSITION_INT, SIMSTATE and ATTITUDE
    for a while (wall seconds)."""
    got = {"LOCAL_POSITION_NED": [], "GLOBAL_POSITION_INT": [], "SIMSTATE": [], "ATTITUDE": [], "STATUSTEXT": []}
    deadline = time.time() + seconds
    while time.time() < deadline:
        msg = m.recv_match(type=list(got), blocking=True, timeout=0.2)
        if msg is not None:
            got[msg.get_type()].append(msg)
    return got


def pairs(got):
    """LOCAL_POSITION_NED and GLOBAL_POSITION_INT built on the same tick."""
    by_time = {g.time_boot_ms: g for g in got["GLOBAL_POSITION_INT"]}
    return [(l, by_time[l.time_boot_ms]) for l in got["LOCAL_POSITION_NED"] if l.time_boot_ms in by_time]


def travelled(matched):
    """How far the vehicle went over the pairs (0 for none)."""
    if not matched:
        return 0.0
    ranges = [math.hypot(l.x, l.y) for l, _ in matched]
    return max(ranges) - min(ranges)


def test_local_position_and_simstate_agree_with_the_global_position(start_sitl):
    m = start_sitl(speedup="5").tcp()
    lat0, lon0 = position(m)
    for stream in (mavlink.MAV_DATA_STREAM_POSITION, mavlink.MAV_DATA_STREAM_EXTRA1):
        m.mav.request_data_stream_send(m.target_system, m.target_component, stream, 10, 1)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    m.arducopter_arm()
    assert recv(m, "HEARTBEAT", 5, lambda h: h.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED) is not None
    target = offset(lat0, lon0, 12.0, 5.0)
    goto(m, *target)

    # Compare while it drives: until it has moved a few metres (a busy
    # machine may start it late), within a bound.
    matched, texts = [], []
    deadline = time.time() + 30
    while time.time() < deadline and travelled(matched) <= 3.0:
        chunk = collect(m, 0.5)
        matched += pairs(chunk)
        texts += [t.text for t in chunk["STATUSTEXT"]]
    assert len(matched) >= 10, f"LOCAL_POSITION_NED beside GLOBAL_POSITION_INT: {len(matched)}"
    # The local origin as each pair places it; their mean is the origin to
    # well under a step, and every pair then agrees within half a step.
    origins = [offset(g.lat * 1e-7, g.lon * 1e-7, -l.x, -l.y) for l, g in matched]
    origin = (sum(o[0] for o in origins) / len(origins), sum(o[1] for o in origins) / len(origins))
    moved = travelled(matched)
    assert moved > 1.0, f"the vehicle should drive while we compare ({moved:.2f} m)"
    for l, g in matched:
        here = offset(*origin, l.x, l.y)
        off_m = distance(here[0], here[1], g.lat * 1e-7, g.lon * 1e-7)
        assert off_m <= HALF_STEP_M + 0.002, f"LOCAL_POSITION_NED {l.x:.4f}/{l.y:.4f} is {off_m * 1000:.1f} mm off"
        assert abs(g.vx / 100.0 - l.vx) <= 0.006 and abs(g.vy / 100.0 - l.vy) <= 0.006

    # At rest after the stop: the truth (SIMSTATE) and the estimate agree to
    # the resolution plus the estimate's error.
    # The verdict comes once a stop is in tolerance by the estimate (a miss
    # is re-approached, so the first stop report may not be the last):
    # "Reached destination", or "Stopped at destination" where the
    # estimate's σ cannot confirm the tolerance.
    verdicts = ("Reached destination", "Stopped at destination")
    verdict = any(t.startswith(verdicts) for t in texts)
    verdict = verdict or recv(m, "STATUSTEXT", 60, lambda t: t.text.startswith(verdicts)) is not None
    assert verdict, "not reached"
    resting = collect(m, 2.0)
    assert resting["SIMSTATE"], "no SIMSTATE from SITL"
    estimate = resting["GLOBAL_POSITION_INT"][-1]
    truth = resting["SIMSTATE"][-1]
    gap_m = distance(truth.lat * 1e-7, truth.lng * 1e-7, estimate.lat * 1e-7, estimate.lon * 1e-7)
    assert gap_m <= 2 * HALF_STEP_M + 0.015, f"estimate {gap_m * 1000:.1f} mm from the truth"
    assert distance(truth.lat * 1e-7, truth.lng * 1e-7, *target) < 0.03
    attitude = resting["ATTITUDE"][-1]
    yaw_gap = math.degrees(math.remainder(truth.yaw - attitude.yaw, math.tau))
    assert abs(yaw_gap) < 0.2, f"SIMSTATE yaw {math.degrees(truth.yaw):.3f} vs ATTITUDE {math.degrees(attitude.yaw):.3f}"
    assert abs(truth.zacc + 9.80665) < 1e-3 and abs(truth.zgyro) < 1e-3


def test_the_stop_reports_its_true_error(start_sitl):
    m = start_sitl(speedup="5").tcp()
    lat0, lon0 = position(m)
    m.set_mode("GUIDED")
    assert wait_mode(m, "GUIDED")
    m.arducopter_arm()
    goto(m, *offset(lat0, lon0, 8.0, 0.0))
    stop = recv(m, "STATUSTEXT", 60, lambda t: t.text.startswith("Stop"))
    assert stop is not None, "no stop"
    truth = recv(m, "STATUSTEXT", 5, lambda t: t.text.startswith("SITL truth: "))
    assert truth is not None, "no true error after the stop"
    mm = float(truth.text.split(": ")[1].split(" mm")[0])
    assert 0.0 <= mm < 50.0, truth.text
