"""One `furrow sitl` process, for the e2e tests (through conftest's
fixtures) and the Python benchmarks in tests/bench alike."""

import os
import pathlib
import re
import signal
import subprocess
import time

# Before pymavlink is imported, or it loads the MAVLink 1 dialect.
os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
FURROW = os.environ.get("FURROW_BIN") or str(REPO / "target" / "release" / "furrow")
READY = re.compile(r"furrow sitl ready: tcp (\S+):(\d+)")


class Sitl:
    """One `furrow sitl` process. Ports come from the OS (TCP port 0), and the
    UDP link sends to the port the test's UDP ground station listens on."""

    def __init__(self, workdir, udp_port=None, speedup="20", extra_args=(), data_dir=None):
        self.workdir = pathlib.Path(workdir)
        self.data_dir = pathlib.Path(data_dir) if data_dir else self.workdir / "data"
        self.stderr_path = self.workdir / f"furrow-{time.monotonic_ns()}.log"
        self.connections = []
        args = [FURROW, "sitl", "--data-dir", str(self.data_dir), "--tcp-port", "0"]
        if speedup is not None:  # None: the data directory's SIM_SPEEDUP
            args += ["--speedup", str(speedup)]
        if udp_port is not None:
            args += ["--udp-port", str(udp_port)]
        args += list(extra_args)
        self.stderr = open(self.stderr_path, "w")
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.stderr, text=True)
        line = self.proc.stdout.readline()
        match = READY.search(line)
        if not match:
            self.stop()
            raise RuntimeError(f"furrow sitl did not start: {line!r}\n{self.log()}")
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
        return self.proc.returncode
