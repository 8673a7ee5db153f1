"""Benchmark (not a test): time to fetch the whole parameter table with
pymavlink over TCP and UDP loopback, with the table size, parameters lost
and duplicates.

    target/venv/bin/python tests/bench/params_fetch.py [--runs N] [--link tcp|udp|both]
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


def fetch(gcs):
    """One PARAM_REQUEST_LIST: (seconds to the last parameter, table size,
    lost, duplicates)."""
    while gcs.recv_match(blocking=False) is not None:
        pass
    start = time.perf_counter()
    gcs.mav.param_request_list_send(gcs.target_system, gcs.target_component)
    seen, count, duplicates, last = set(), None, 0, start
    deadline = start + 5
    while time.perf_counter() < deadline and (count is None or len(seen) < count):
        v = gcs.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
        if v is None:
            continue
        count = v.param_count
        duplicates += v.param_index in seen
        seen.add(v.param_index)
        last = time.perf_counter()
    return last - start, count or 0, (count or 0) - len(seen), duplicates


def bench(name, gcs, runs):
    gcs.wait_heartbeat(timeout=10)
    results = [fetch(gcs) for _ in range(runs)]
    times = sorted(r[0] for r in results)
    p95 = times[min(len(times) - 1, int(0.95 * len(times)))]
    floor = client_floor(results[0][1])
    print(f"{name}: {results[0][1]} parameters, {runs} full fetches with pymavlink: "
          f"median {statistics.median(times) * 1000:.1f} ms, p95 {p95 * 1000:.1f} ms, "
          f"max {times[-1] * 1000:.1f} ms; lost {sum(r[2] for r in results)}, "
          f"duplicates {sum(r[3] for r in results)} (pymavlink alone decodes them in {floor * 1000:.1f} ms)")


def client_floor(count):
    """How long pymavlink alone takes to decode `count` PARAM_VALUE: the
    part of a fetch no vehicle can make faster."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
    enc = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    data = b"".join(enc.param_value_encode(b"WP_SPEED", 1.0, mavlink.MAV_PARAM_TYPE_REAL32, count, i).pack(enc)
                    for i in range(count))
    best = None
    for _ in range(5):
        dec = mavlink.MAVLink(None)
        start = time.perf_counter()
        n = len(dec.parse_buffer(data) or [])
        elapsed = time.perf_counter() - start
        assert n == count, n
        best = elapsed if best is None else min(best, elapsed)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--link", choices=["tcp", "udp", "both"], default="both")
    args = ap.parse_args()
    with bench_sitl(REPO / "target" / "bench-params-data") as (udp, sitl):
        tcp_port = sitl.tcp_port
        if args.link in ("udp", "both"):
            bench("UDP loopback", udp, args.runs)
        udp.close()
        if args.link in ("tcp", "both"):
            tcp = mavutil.mavlink_connection(f"tcp:127.0.0.1:{tcp_port}", source_system=254)
            bench("TCP loopback", tcp, args.runs)
            tcp.close()


if __name__ == "__main__":
    sys.exit(main())
