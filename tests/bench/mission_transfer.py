"""Benchmark (not a test): upload and download time of a 1000-item mission
with pymavlink over UDP and TCP loopback, with the requests sent again
(an item not there within a second: lost) and the items that came unasked
(duplicates), and what pymavlink alone takes for a download's messages.

    target/venv/bin/python tests/bench/mission_transfer.py [--items N] [--runs N] [--link tcp|udp|both]

Upload: MISSION_COUNT, then each MISSION_REQUEST_INT the vehicle sends
answered with its item, until MISSION_ACK. Download: MISSION_REQUEST_LIST,
then one MISSION_REQUEST_INT per item, each sent once the previous item
arrived (as QGroundControl and Mission Planner do), then MISSION_ACK. Each
is timed from its first message sent: the upload to its MISSION_ACK
received, the download to its own MISSION_ACK sent.
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
    up, down, counts = [], [], {}
    for _ in range(runs):
        t0 = time.perf_counter()
        ack = upload_mission(gcs, items)
        up.append(time.perf_counter() - t0)
        assert ack is not None and ack.type == mavlink.MAV_MISSION_ACCEPTED, ack
        t0 = time.perf_counter()
        back, _ = download_mission(gcs, counts=counts)
        down.append(time.perf_counter() - t0)
        assert len(back) == len(items)
    print(f"{len(items)}-item mission over {name} with pymavlink, {runs} runs:")
    print(f"  upload   median {statistics.median(up) * 1000:.1f} ms (max {max(up) * 1000:.1f} ms)")
    print(f"  download median {statistics.median(down) * 1000:.1f} ms (min {min(down) * 1000:.1f} ms, "
          f"max {max(down) * 1000:.1f} ms); requests sent again {counts['resent']}, "
          f"items unasked or twice {counts['unexpected']}")


def client_floor(count):
    """How long pymavlink alone takes to encode `count` MISSION_REQUEST_INT
    and decode `count` MISSION_ITEM_INT: the part of a download no vehicle
    can make faster."""
    from pymavlink.dialects.v20 import ardupilotmega as dialect
    enc = dialect.MAVLink(None, srcSystem=1, srcComponent=1)
    replies = b"".join(mission_item(seq, 16, 291330000, 1196400000).pack(enc) for seq in range(count))
    best = None
    for _ in range(5):
        dec = dialect.MAVLink(None)
        start = time.perf_counter()
        for seq in range(count):
            enc.mission_request_int_encode(1, 1, seq, 0).pack(enc)
        n = len(dec.parse_buffer(replies) or [])
        elapsed = time.perf_counter() - start
        assert n == count, n
        best = elapsed if best is None else min(best, elapsed)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--items", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--link", choices=["tcp", "udp", "both"], default="both")
    args = ap.parse_args()
    with bench_sitl(REPO / "target" / "bench-mission-data") as (gcs, sitl):
        tcp_port = sitl.tcp_port
        items = [mission_item(0, 16, 291330000, 1196400000)]
        items += [mission_item(i, 16, 291330000 + i * 10, 1196400000 + i * 10) for i in range(1, args.items)]
        if args.link in ("udp", "both"):
            bench("UDP loopback", gcs, items, args.runs)
        gcs.close()
        if args.link in ("tcp", "both"):
            tcp = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=254)
            bench("TCP loopback", tcp, items, args.runs)
            tcp.close()
    print(f"pymavlink alone encodes the {args.items} requests and decodes the items in "
          f"{client_floor(args.items) * 1000:.1f} ms")


if __name__ == "__main__":
    sys.exit(main())
