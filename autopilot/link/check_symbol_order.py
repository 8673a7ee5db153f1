"""Fails when `furrow.symbol-order` no longer fits the `furrow` binary well
enough to keep its code compact (tests/run runs it after the release build):

    target/venv/bin/python autopilot/link/check_symbol_order.py target/release/furrow

Two figures, each with its limit:
- the share of the listed functions the binary still defines (by the
  stem of their names, symbol_names.py, whatever the build's hashes). A
  hot function renamed, moved to another module or no longer emitted is
  laid out among the cold code again, and brings its 64 kB block into
  memory. On the code the list was generated from, and on it with a
  function moved between modules (cedba56), 100 % were defined, in both
  builds. The limit, 98 %, lets a few of the ~1,300 functions go (each
  can cost a 64 kB block, which the second figure then sees) and not a
  renamed module.
- the binary's own code resident (`r-xp` in smaps) after the session of
  gcs_session.py at speedup 1 (about 8 s): what the order is for; a hot
  function the list does not name lands among the cold code the same way.
  Measured (`measure_rss.py`): a list generated on the same code, the
  README's build 1.52-1.71 MB, a workspace build (tests/run's: other
  hashes, so each generic function's instances come by stem) 2.01-2.07 MB;
  stale lists: one commit behind (cedba56 on the list of its parent,
  whole names) 2.69-2.75 MB, whole names on a workspace build 3.5-3.6 MB,
  the list of 06fe66a on 6b7a655 (a test added) 3.19-3.29 MB; no order
  4.1-4.3 MB. The limit, 2.4 MB, lies between the fresh and the stale
  figures."""

import pathlib
import sys

import gcs_session
import measure_rss
import symbol_names

HERE = pathlib.Path(__file__).resolve().parent
LIST = HERE / "furrow.symbol-order"
MIN_DEFINED_SHARE = 0.98
MAX_CODE_RESIDENT_MB = 2.4

REGENERATE = """regenerate it on this code and check that RSS is back:
    cargo build --release -p autopilot --bin furrow
    target/venv/bin/python autopilot/link/generate_symbol_order.py target/release/furrow
    cargo build --release -p autopilot --bin furrow
    target/venv/bin/python autopilot/link/measure_rss.py target/release/furrow 5
then commit autopilot/link/furrow.symbol-order with the figures (docs/architecture.md, "Code laid out by use")."""


def defined_share(exe, listed):
    """Share of the listed functions (by stem) the binary defines, and how many are listed."""
    stems = {symbol_names.stem(name) for name in symbol_names.code_symbols(exe)}
    listed_stems = {symbol_names.line_stem(line) for line in listed}
    return len(listed_stems & stems) / len(listed_stems), len(listed_stems)


def code_resident_mb(exe):
    """The binary's code resident after the ground-station session, MB."""
    rss_kb = gcs_session.session(exe, on_done=measure_rss.rss_by_mapping, log=lambda _: None)
    if "furrow r-xp" not in rss_kb:
        # measure_rss groups mappings by a file name with "furrow" in it: a
        # binary named otherwise would read as 0 MB and pass unmeasured.
        sys.exit(f"no code mapping of {exe} found (its file name must contain 'furrow')")
    return rss_kb["furrow r-xp"] / 1024


def main():
    if len(sys.argv) != 2:
        sys.exit(f"usage: {sys.argv[0]} path/to/furrow")
    exe = str(pathlib.Path(sys.argv[1]).resolve())
    listed = LIST.read_text().split()
    defined, functions = defined_share(exe, listed)
    resident = code_resident_mb(exe)
    print(f"symbol order: {defined:.1%} of the {functions} listed functions defined (at least "
          f"{MIN_DEFINED_SHARE:.0%}); code resident after the session {resident:.2f} MB (at most "
          f"{MAX_CODE_RESIDENT_MB} MB)")
    if defined < MIN_DEFINED_SHARE or resident > MAX_CODE_RESIDENT_MB:
        sys.exit(f"{LIST} no longer fits {exe}: {REGENERATE}")


if __name__ == "__main__":
    main()
