"""Starting `furrow` processes: `furrow sitl` for the e2e tests (through
conftest's fixtures) and the Python benchmarks in tests/bench alike, and the
start-and-wait-for-ready of any `furrow` command that prints a ready line."""

import contextlib
import os
import pathlib
import re
import signal
import subprocess
import tempfile
import time

# Before pymavlink is imported, or it loads the MAVLink 1 dialect.
os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
FURROW = os.environ.get("FURROW_BIN") or str(REPO / "target" / "release" / "furrow")
# The benchmark binary (it also plots logs), built beside `furrow` as
# furrow-bench finds `furrow`: cargo build --release -p furrow_bench.
FURROW_BENCH = os.environ.get("FURROW_BENCH_BIN") or str(pathlib.Path(FURROW).with_name("furrow-bench"))
READY = re.compile(r"furrow sitl ready: tcp (\S+):(\d+)")


# Every FurrowProcess not yet stopped: conftest stops what a failed test left
# (a `--speedup max` simulator left running takes a core until killed).
RUNNING = []


class FurrowProcess:
    """A `furrow` process whose first stdout line says it is ready ("furrow
    sitl ready: tcp HOST:PORT ..." or "furrow run ready: ..."); its stderr
    goes to `stderr_path`. Ports come from the OS (port 0): the ready line
    says which."""

    def __init__(self, args, stderr_path, ready=READY, what="furrow sitl"):
        self.stderr_path = pathlib.Path(stderr_path)
        self.connections = []
        self.stderr = open(self.stderr_path, "w")
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.stderr, text=True)
        RUNNING.append(self)
        line = self.proc.stdout.readline()
        match = ready.search(line)
        if not match:
            self.stop()
            raise RuntimeError(f"{what} did not start: {line!r}\n{self.log()}")
        self.tcp_port = int(match.group(2))
        # The whole ready line: listeners bound to port 0 say their port there.
        self.ready = line

    def tcp(self, source_system=255, wait=True):
        """A TCP ground station, after the first heartbeat."""
        m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{self.tcp_port}", source_system=source_system)
        self.connections.append(m)
        if wait:
            assert m.wait_heartbeat(timeout=10), "no heartbeat over TCP"
        return m

    def alive(self):
        return self.proc.poll() is None

    def log(self):
        if not self.stderr.closed:
            self.stderr.flush()
        return self.stderr_path.read_text()

    def stop(self, timeout=10):
        for c in self.connections:
            try:
                c.close()
            except Exception:
                pass
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.stderr.close()
        if self in RUNNING:
            RUNNING.remove(self)
        return self.proc.returncode


class Sitl(FurrowProcess):
    """One `furrow sitl` process. The UDP link sends to the port the test's
    UDP ground station listens on."""

    def __init__(self, workdir, udp_port=None, speedup="20", extra_args=(), data_dir=None):
        self.workdir = pathlib.Path(workdir)
        self.data_dir = pathlib.Path(data_dir) if data_dir else self.workdir / "data"
        args = [FURROW, "sitl", "--data-dir", str(self.data_dir), "--tcp-port", "0"]
        if speedup is not None:  # None: the data directory's SIM_SPEEDUP
            args += ["--speedup", str(speedup)]
        if udp_port is not None:
            args += ["--udp-port", str(udp_port)]
        args += list(extra_args)
        super().__init__(args, self.workdir / f"furrow-{time.monotonic_ns()}.log")


@contextlib.contextmanager
def bench_sitl(data_dir):
    """For a benchmark: a UDP ground station on a port from the OS and a
    `furrow sitl` at the data directory's SIM_SPEEDUP sending to it. The data
    directory is the benchmark's (kept between runs); the log goes to a
    scratch directory. Yields (gcs, sitl); the ground station is the
    caller's to close."""
    gcs = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255)
    with tempfile.TemporaryDirectory() as logs:
        sitl = Sitl(logs, udp_port=gcs.port.getsockname()[1], speedup=None, data_dir=data_dir)
        try:
            yield gcs, sitl
        finally:
            sitl.stop()
