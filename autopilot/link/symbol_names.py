"""How `furrow.symbol-order` names the functions to lay out first: each
line is a pattern of `.text.` section names (rustc puts every function in
a section `.text.<mangled name>`), which `autopilot/build.rs` hands to the
linker in the list's order. A pattern leaves out the parts of a mangled
name that change when nothing in the function did:

- Legacy Rust names end in `17h<16 hex digits>E`, a hash of the crate's
  build metadata (which takes in the features cargo enables on its
  dependencies, and those differ between `cargo build -p autopilot` and a
  workspace build) and of the instance's types. A function with one
  instance in the binary is named up to `17h`: `<stem>17h*`.
- Of a generic function, only some instances are hot; the hash is what
  tells them apart. Its hot instances are named whole (`<name>*`) unless
  they are most of its code, then by the stem; a stem also follows the
  hot functions, for builds with other hashes (`generate_symbol_order.py`).
- ThinLTO appends `.llvm.<digits>` to a local function other codegen units
  call; the number is a hash of its unit, which moves with any change to a
  source file in that unit (a test added further down a file is enough).
  Patterns end in `*` there."""

import re
import subprocess

LEGACY_HASH = re.compile(r"17h[0-9a-f]{16}E$")
LLVM_SUFFIX = re.compile(r"\.llvm\.\d+$")


def stem(mangled):
    """A legacy name up to `17h` (others whole), without `.llvm.` suffix."""
    return LEGACY_HASH.sub("17h", LLVM_SUFFIX.sub("", mangled))


def pattern(mangled, whole_stem):
    """The list's line for a hot function; `whole_stem`: every instance of its stem."""
    name = LLVM_SUFFIX.sub("", mangled)
    if LEGACY_HASH.search(name):
        return (stem(name) if whole_stem else name) + "*"
    return name + (".llvm.*" if LLVM_SUFFIX.search(mangled) else "")


def line_stem(line):
    """The stem of the function a line of the list names."""
    return stem(line.removesuffix("*").removesuffix(".llvm."))


def code_symbols(exe):
    """Mangled name -> (address, bytes of code), for the functions the binary defines."""
    out = subprocess.run(["nm", "--defined-only", "--print-size", exe], check=True, capture_output=True,
                         text=True).stdout
    symbols = {}
    for fields in map(str.split, out.splitlines()):
        if len(fields) == 4 and fields[2] in "tTwW":
            symbols[fields[3]] = (int(fields[0], 16), int(fields[1], 16))
    return symbols
