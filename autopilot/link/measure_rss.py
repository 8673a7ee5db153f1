"""The check for the symbol order: RSS of `furrow sitl` after the session of
gcs_session.py (all parameters fetched, a mission driven in AUTO, 5 s of
telemetry), from /proc/PID/smaps summed per mapping, over several runs.

    target/venv/bin/python autopilot/link/measure_rss.py target/release/furrow 5

Without the order the binary's code (`r-xp`) was 4.1-4.3 MB of RSS, all of
it 8.1-8.4 MB; with it 1.5-1.6 and 5.5-5.6 MB (docs/architecture.md,
"Binary size and memory")."""

import collections
import os
import re
import sys

import gcs_session


def rss_by_mapping(pid):
    """Mapping group -> Rss kB."""
    rss_kb = collections.Counter()
    group = None
    for line in open(f"/proc/{pid}/smaps"):
        if re.match(r"^[0-9a-f]+-[0-9a-f]+ ", line):
            fields = line.split()
            path = fields[5] if len(fields) > 5 else ""
            base = os.path.basename(path)
            if path.startswith("/") and "furrow" in base:
                group = "furrow " + fields[1]
            elif path.startswith("/"):
                group = base.split(".so")[0]
            else:
                group = path or "anon (thread stacks, arenas)"
        elif line.startswith("Rss:") and group:
            rss_kb[group] += int(line.split()[1])
    return rss_kb


def main():
    exe = os.path.abspath(sys.argv[1])
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    totals = []
    for run in range(runs):
        rss_kb = gcs_session.session(exe, on_done=rss_by_mapping, log=lambda _: None)
        total = sum(rss_kb.values())
        totals.append(total)
        parts = ", ".join(f"{k} {v / 1024:.2f}" for k, v in rss_kb.most_common() if v >= 40)
        print(f"run {run}: RSS {total / 1024:.2f} MB: {parts}", flush=True)
    totals.sort()
    print(f"RSS MB: median {totals[len(totals) // 2] / 1024:.2f}, min {totals[0] / 1024:.2f}, "
          f"max {totals[-1] / 1024:.2f} ({runs} runs)")


if __name__ == "__main__":
    main()
