"""Writes `furrow.symbol-order`: the functions `furrow sitl` runs, hottest
first, which `autopilot/build.rs` hands to the linker so they sit together
in `.text` (fewer resident code pages; see docs/architecture.md).

    cargo build --release -p autopilot --bin furrow
    target/venv/bin/python autopilot/link/generate_symbol_order.py target/release/furrow

Runs the ground-station session of gcs_session.py under callgrind, once at
speedup 1 and once at max, keeps the functions callgrind saw in the `furrow` binary, in order of instructions
executed (self), as patterns of section names (symbol_names.py). A session step that does
not complete stops the script with its reason and leaves the list as it was.
A stale list only loses effect: a pattern no section matches is skipped
(`check_symbol_order.py` tells when too many are)."""

import collections
import pathlib
import re
import sys
import tempfile

import gcs_session
import symbol_names

HERE = pathlib.Path(__file__).resolve().parent
WHOLE_STEM_SHARE = 0.75


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


def order_patterns(cost, exe):
    """The list's lines (symbol_names.py), hottest first. A generic function's
    instances are told apart only by their hashes, which differ between
    builds: when the hot ones are at least WHOLE_STEM_SHARE of its code its
    stem stands for all of them; else the hot ones are named whole, and its
    stem comes after every hot function, so that a build whose hashes
    differ still finds them there, with its cold instances (on 6b7a655: 84 %
    of the 1.3 MB of hot code is named by stem, which brings 6 kB of cold
    instances; every stem in the hot order, 1.85 MB). A function LLVM found
    identical to another is an alias of it, in the section named after the
    other, so every name at a hot function's address is listed."""
    symbols = symbol_names.code_symbols(exe)
    at_address = collections.defaultdict(list)
    stem_bytes = collections.Counter()
    for name, (address, size) in sorted(symbols.items()):
        at_address[address].append(name)
        stem_bytes[symbol_names.stem(name)] += size
    hot = [name for name, _ in sorted(cost.items(), key=lambda kv: (-kv[1], kv[0])) if name in symbols]
    hot_bytes = collections.Counter()
    for name in hot:
        hot_bytes[symbol_names.stem(name)] += symbols[name][1]
    lines, after = [], []
    for name in (alias for name in hot for alias in [name, *at_address[symbols[name][0]]]):
        stem = symbol_names.stem(name)
        whole_stem = hot_bytes[stem] >= WHOLE_STEM_SHARE * stem_bytes[stem]
        lines.append(symbol_names.pattern(name, whole_stem))
        if not whole_stem:
            after.append(symbol_names.pattern(name, True))
    return list(dict.fromkeys(lines + after))


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
    ordered = order_patterns(cost, exe)
    (HERE / "furrow.symbol-order").write_text("".join(f"{line}\n" for line in ordered))
    print(f"{len(ordered)} patterns ({len(cost)} functions seen in the binary) -> {HERE / 'furrow.symbol-order'}")


if __name__ == "__main__":
    main()
