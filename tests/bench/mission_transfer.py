"""Benchmark (not a test): upload and download time of a 1000-item mission
with pymavlink over UDP and TCP loopback.

    target/venv/bin/python tests/bench/mission_transfer.py [--items N] [--runs N]
"""

import argparse
import os
import pathlib
import re
import statistics
import subprocess
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "python"))
from pymavlink import mavutil  # noqa: E402
from gcs import download_mission, mavlink, mission_item, upload_mission  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
FURROW = os.environ.get("FURROW_BIN") or str(REPO / "target" / "release" / "furrow")
READY = re.compile(r"furrow sitl ready: tcp (\S+):(\d+)")


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
    gcs = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255)
    port = gcs.port.getsockname()[1]
    data = REPO / "target" / "bench-mission-data"
    proc = subprocess.Popen([FURROW, "sitl", "--tcp-port", "0", "--udp-port", str(port), "--data-dir", str(data)],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        tcp_port = int(READY.search(proc.stdout.readline()).group(2))
        items = [mission_item(0, 16, 291330000, 1196400000)]
        items += [mission_item(i, 16, 291330000 + i * 10, 1196400000 + i * 10) for i in range(1, args.items)]
        bench("UDP loopback", gcs, items, args.runs)
        gcs.close()
        tcp = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=254)
        bench("TCP loopback", tcp, items, args.runs)
        tcp.close()
    finally:
        proc.terminate()
        proc.wait()


if __name__ == "__main__":
    sys.exit(main())
