"""Benchmark (not a test): upload and download time of a 1000-item mission
with pymavlink over UDP and TCP loopback.

    target/venv/bin/python tests/bench/mission_transfer.py [--items N] [--runs N]
"""

import argparse
import os
import pathlib
import statistics
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "python"))
from pymavlink import mavutil  # noqa: E402
from sitl import REPO, bench_sitl  # noqa: E402
from gcs import download_mission, mavlink, mission_item, upload_mission  # noqa: E402


def bench(name, gcs, items, runs):
    gcs.wait_heartbeat(timeout=10)
    up, down = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        ack = upload_mission(gcs, items)
        up.append(time.perf_counter() - t0)
        assert ack is not None and ack.type == mavlink.MAV_MISSION_ACCEPTED, ack
        t0 = time.perf_counter()
        back, _ = download_mission(gcs)
        down.append(time.perf_counter() - t0)
        assert len(back) == len(items)
    print(f"{len(items)}-item mission over {name} with pymavlink, {runs} runs:")
    print(f"  upload   median {statistics.median(up) * 1000:.1f} ms (max {max(up) * 1000:.1f} ms)")
    print(f"  download median {statistics.median(down) * 1000:.1f} ms (max {max(down) * 1000:.1f} ms)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--items", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    with bench_sitl(REPO / "target" / "bench-mission-data") as (gcs, sitl):
        tcp_port = sitl.tcp_port
        items = [mission_item(0, 16, 291330000, 1196400000)]
        items += [mission_item(i, 16, 291330000 + i * 10, 1196400000 + i * 10) for i in range(1, args.items)]
        bench("UDP loopback", gcs, items, args.runs)
        gcs.close()
        tcp = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=254)
        bench("TCP loopback", tcp, items, args.runs)
        tcp.close()


if __name__ == "__main__":
    sys.exit(main())
