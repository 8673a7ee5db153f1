"""Benchmark (not a test): time to fetch the whole parameter table with
pymavlink over UDP loopback, with the table size and any parameters lost.

    target/venv/bin/python tests/bench/params_fetch.py [--runs N]
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
FURROW = os.environ.get("FURROW_BIN") or str(REPO / "target" / "release" / "furrow")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=10)
    args = ap.parse_args()
    gcs = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255)
    port = gcs.port.getsockname()[1]
    data = REPO / "target" / "bench-params-data"
    proc = subprocess.Popen([FURROW, "sitl", "--tcp-port", "0", "--udp-port", str(port), "--data-dir", str(data)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        proc.stdout.readline()
        gcs.wait_heartbeat(timeout=10)
        times, counts, lost = [], [], []
        for _ in range(args.runs):
            while gcs.recv_match(blocking=False) is not None:
                pass
            start = time.perf_counter()
            gcs.mav.param_request_list_send(gcs.target_system, gcs.target_component)
            seen, count = set(), None
            deadline = start + 5
            while time.perf_counter() < deadline and (count is None or len(seen) < count):
                v = gcs.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                if v is not None:
                    count = v.param_count
                    seen.add(v.param_index)
            times.append(time.perf_counter() - start)
            counts.append(count or 0)
            lost.append((count or 0) - len(seen))
        print(f"parameter table: {counts[0]} parameters")
        print(f"full fetch over UDP loopback with pymavlink, {args.runs} runs: "
              f"median {statistics.median(times) * 1000:.0f} ms, max {max(times) * 1000:.0f} ms, "
              f"lost {sum(lost)} parameters in all")
    finally:
        proc.terminate()
        proc.wait()


if __name__ == "__main__":
    sys.exit(main())
