"""MAVProxy (the venv's mavproxy.py) as a ground station a test types into.
Its output is read as it comes, each line with the time it came, so a test
waits for what MAVProxy says rather than for a fixed time."""

import os
import re
import subprocess
import sys
import threading
import time

MAVPROXY = os.path.join(os.path.dirname(sys.executable), "mavproxy.py")


class MavProxy:
    """`mavproxy.py --master tcp:127.0.0.1:PORT ARGS` in `cwd` (where it
    writes mav.tlog and mav.parm)."""

    def __init__(self, tcp_port, cwd, args=()):
        # Unbuffered: MAVProxy's print()s would otherwise come in blocks,
        # late, to a pipe.
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [MAVPROXY, "--master", f"tcp:127.0.0.1:{tcp_port}", *args],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=cwd, env=env)
        self.lines = []  # (time.monotonic(), line)
        self.changed = threading.Condition()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.proc.stdout:
            with self.changed:
                self.lines.append((time.monotonic(), line.rstrip()))
                self.changed.notify_all()

    def send(self, command):
        """Types a command; returns the index of the next line, for wait_for."""
        with self.changed:
            start = len(self.lines)
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return start

    def find(self, pattern, start=0):
        """The first (time, line) from line `start` on that matches, or None."""
        regex = re.compile(pattern)
        with self.changed:
            return next(((t, l) for t, l in self.lines[start:] if regex.search(l)), None)

    def wait_for(self, pattern, timeout=30, start=0):
        """The first (time, line) from line `start` on that matches; fails
        the test with MAVProxy's output if none comes within `timeout`."""
        deadline = time.monotonic() + timeout
        with self.changed:
            while (found := self.find(pattern, start)) is None:
                left = deadline - time.monotonic()
                assert left > 0 and self.proc.poll() is None, \
                    f"MAVProxy never said {pattern!r}:\n{self.output()}"
                self.changed.wait(min(left, 0.5))
        return found

    def output(self):
        with self.changed:
            return "\n".join(l for _, l in self.lines)

    def close(self, terminate=False, timeout=20):
        """Ends MAVProxy: its input closed (it quits at the end of its
        input), or SIGTERM with `terminate`; returns its whole output."""
        if terminate:
            self.proc.terminate()
        else:
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.reader.join(timeout=5)
        return self.output()
