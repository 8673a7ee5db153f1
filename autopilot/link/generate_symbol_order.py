"""Writes `furrow.symbol-order`: the functions `furrow sitl` runs, hottest
first, which `autopilot/build.rs` hands to the linker so they sit together
in `.text` (fewer resident code pages; see docs/architecture.md).

    cargo build --release -p autopilot --bin furrow
    target/venv/bin/python autopilot/link/generate_symbol_order.py target/release/furrow

Runs the ground-station session of gcs_session.py under callgrind, once at
speedup 1 and once at max, keeps the functions callgrind saw in the `furrow` binary, in order of instructions
executed (self), as the linker's mangled names. A session step that does
not complete stops the script with its reason and leaves the list as it was.
A stale list only loses effect: the linker skips names it does not find."""

import collections
import pathlib
import re
import subprocess
import sys
import tempfile

import gcs_session

HERE = pathlib.Path(__file__).resolve().parent


def executed_functions(callgrind_out, binary_name):
    """Mangled name -> instructions executed in it (self), for functions of the binary."""
    cost = collections.Counter()
    tables = {"ob": {}, "fn": {}}  # callgrind names a repeated string "(id)"
    in_binary = False
    current = None
    skip_next_cost = False  # the cost line after "calls=" is the callee's inclusive cost
    for line in open(callgrind_out):
        key, eq, rest = line.rstrip("\n").partition("=")
        if eq and key in ("cob", "cfn"):  # a callee: only names its id
            found = re.match(r"\((\d+)\) (.*)$", rest)
            if found:
                tables[key[1:]].setdefault(*found.groups())
        elif eq and key in tables:
            found = re.match(r"\((\d+)\)(?: (.*))?$", rest)
            name = rest
            if found:
                ident, name = found.groups()
                name = tables[key].setdefault(ident, name) if name else tables[key].get(ident)
            if key == "ob":
                in_binary = pathlib.Path(name or "").name == binary_name
            else:
                # "'2" and up: callgrind's name for a function's recursive calls
                current = re.sub(r"'\d+$", "", name) if in_binary and name else None
        elif eq and key == "calls":
            skip_next_cost = True
        elif line[:1].isdigit() or line[:1] in "+-*":
            if skip_next_cost:
                skip_next_cost = False
            elif current:
                fields = line.split()
                if len(fields) >= 2:
                    cost[current] += int(fields[1])
    return cost


def main():
    exe = str(pathlib.Path(sys.argv[1]).resolve())
    out_dir = tempfile.mkdtemp(prefix="furrow-callgrind-")
    cost = collections.Counter()
    # At speedup 1 (as the README starts it) and at max (as `furrow-bench sitl` does).
    for number, sitl_args in enumerate([(), ("--speedup", "max")]):
        out_file = f"{out_dir}/callgrind.out.{number}"
        # Valgrind runs one thread at a time. At max the core's loop never
        # waits, and valgrind's default lock need not hand over in turn: it
        # can hold the link thread (the ground station's replies) off.
        # Fair scheduling hands the lock round in turn.
        wrap = ["valgrind", "--tool=callgrind", "--fair-sched=yes", "--demangle=no", "--dump-instr=no",
                "--compress-pos=no", f"--callgrind-out-file={out_file}"]
        try:
            gcs_session.session(exe, wrap=wrap, slow=6.0, telemetry_s=3.0, sitl_args=sitl_args)
        except (gcs_session.SessionIncomplete, AssertionError, RuntimeError, TimeoutError) as error:
            sys.exit(f"the session at {' '.join(sitl_args) or 'speedup 1'} under callgrind did not complete: "
                     f"{error}; {HERE / 'furrow.symbol-order'} left as it was")
        cost.update(executed_functions(out_file, pathlib.Path(exe).name))
    defined = set(subprocess.run(["nm", "--defined-only", "--format=just-symbols", exe], check=True,
                                 capture_output=True, text=True).stdout.split())
    ordered = [name for name, _ in sorted(cost.items(), key=lambda kv: (-kv[1], kv[0])) if name in defined]
    (HERE / "furrow.symbol-order").write_text("".join(f"{name}\n" for name in ordered))
    print(f"{len(ordered)} functions ({len(cost)} seen in the binary) -> {HERE / 'furrow.symbol-order'}")


if __name__ == "__main__":
    main()
