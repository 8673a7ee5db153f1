"""Benchmark (not a test): how long a ground station waits for an
acknowledgement that now means "on disk" — from sending the last mission
item to MISSION_ACK ACCEPTED (1, 100 and 1000 items), and from PARAM_SET to
its PARAM_VALUE echo — with pymavlink over UDP loopback, p50 and p99.

    target/venv/bin/python tests/bench/ack_latency.py [--runs N] [--sets N] [--data-dir D]

The data directory decides the disk that is fsynced (default: under target/).
"""

import argparse
import os
import pathlib
import shutil
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "python"))
from sitl import FURROW, REPO, bench_sitl  # noqa: E402
from gcs import mavlink, mission_item, param_id  # noqa: E402


def quantile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def upload_ack_latency(gcs, items):
    """Uploads `items`; returns seconds from sending the last item to the ACK."""
    gcs.mav.mission_count_send(1, 1, len(items), 0)
    last_sent = None
    while True:
        msg = gcs.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True, timeout=5)
        if msg is None:
            raise RuntimeError("upload timed out")
        if msg.get_type() == "MISSION_ACK":
            if msg.type != mavlink.MAV_MISSION_ACCEPTED:
                raise RuntimeError(f"MISSION_ACK {msg.type}")
            return time.perf_counter() - last_sent
        it = items[msg.seq]
        gcs.mav.mission_item_int_send(1, 1, it.seq, it.frame, it.command, it.current, it.autocontinue,
                                      it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, 0)
        if msg.seq == len(items) - 1:
            last_sent = time.perf_counter()


def echo_latency(gcs, name, value):
    gcs.mav.param_set_send(1, 1, param_id(name), value, mavlink.MAV_PARAM_TYPE_REAL32)
    t0 = time.perf_counter()
    while True:
        v = gcs.recv_match(type="PARAM_VALUE", blocking=True, timeout=5)
        if v is None:
            raise RuntimeError("no echo")
        if v.param_id == name:
            if abs(v.param_value - value) > 1e-6:
                raise RuntimeError(f"{name} echoed {v.param_value}, not {value}")
            return time.perf_counter() - t0


def report(label, values):
    ms = [v * 1e3 for v in values]
    print(f"  {label:<28} p50 {quantile(ms, 0.5):7.2f} ms  p99 {quantile(ms, 0.99):7.2f} ms  (n={len(ms)})")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=40, help="uploads per size (1000 items: a quarter)")
    ap.add_argument("--sets", type=int, default=300)
    ap.add_argument("--data-dir", default=str(REPO / "target" / "bench-ack-data"))
    args = ap.parse_args()
    data = pathlib.Path(args.data_dir)
    shutil.rmtree(data, ignore_errors=True)
    with bench_sitl(data) as (gcs, _sitl):
        gcs.wait_heartbeat(timeout=10)
        print(f"{FURROW}, data in {data}, UDP loopback, pymavlink:")
        for size in (1, 100, 1000):
            runs = max(1, args.runs // 4) if size >= 1000 else args.runs
            latencies = []
            for run in range(runs):
                items = [mission_item(0, 16, 291330000, 1196400000)]
                items += [mission_item(i, 16, 291330000 + i * 10 + run, 1196400000 + i * 10) for i in range(1, size)]
                latencies.append(upload_ack_latency(gcs, items))
            report(f"last item -> ACK, {size} items", latencies)
        names = ["PVW_LAT_P", "PVW_YAW_P", "MAG_STR_P", "MAG_SPD_P"]
        latencies = [echo_latency(gcs, names[i % len(names)], 1.0 + (i % 50) / 8) for i in range(args.sets)]
        report("PARAM_SET -> echo", latencies)


if __name__ == "__main__":
    sys.exit(main())
