#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Checks the house rules a compiler does not: the module layering of docs/design.md and the file
length limit. Run by scripts/test.sh (so by CI); exits non-zero naming every breach.

Layering: a module's headers (include/plumb/<module>) and sources (src/<module>) include `core`
and the modules below it in the stack, nothing above or beside it; `io` sits beside the stack and
includes `core` only. The includes that run against it today are listed in KNOWN_EXCEPTIONS with
the reason; a new one fails, and so does an exception that no longer occurs (so the list shrinks
as the code is fixed).

Length: no source or header over MAX_LINES lines; the files over it today are listed in
LONG_FILES with their length, which they may not exceed.
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

# The stack, top to bottom; a module may include modules in the rows below its own.
STACK = [
    ["pipeline"],
    ["sim"],
    ["registration", "segmentation", "calibration", "optim"],
    ["features", "scan2d", "loam"],
    ["search", "filters", "imu"],
    ["bim", "eval"],
    ["core"],
]
BESIDE = {"io": {"core"}}

# (module, included module) -> why the include is there today.
KNOWN_EXCEPTIONS = {
    ("pipeline", "io"): "pipeline/run.hpp: run_bim_odometry reads an io::FrameDumpReader",
    ("sim", "io"): "sim/scenario writes the frame dump it simulates; sim/lidar_model checks its input file",
}

MAX_LINES = 700
# File -> its length today (may shrink, may not grow).
LONG_FILES = {
}


def allowed_deps():
    allowed = {}
    for row_index, row in enumerate(STACK):
        below = {m for r in STACK[row_index + 1:] for m in r}
        for module in row:
            allowed[module] = below | {"core"}
    allowed.update(BESIDE)
    return allowed


def module_files(module):
    for base in (ROOT / "include" / "plumb" / module, ROOT / "src" / module):
        if base.is_dir():
            yield from sorted(p for p in base.rglob("*") if p.suffix in (".hpp", ".cpp", ".h"))


INCLUDE = re.compile(r'^\s*#\s*include\s+"plumb/([a-z0-9_]+)/')


def check_layering(errors):
    allowed = allowed_deps()
    seen = set()
    for module in sorted(allowed):
        for path in module_files(module):
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                m = INCLUDE.match(line)
                if not m or m.group(1) == module:
                    continue
                dep = m.group(1)
                if dep in allowed[module]:
                    continue
                if (module, dep) in KNOWN_EXCEPTIONS:
                    seen.add((module, dep))
                    continue
                rel = path.relative_to(ROOT)
                errors.append(f"{rel}:{number}: {module} includes {dep}, which is not below it "
                              f"(docs/design.md, Layering): {line.strip()}")
    for pair in sorted(set(KNOWN_EXCEPTIONS) - seen):
        errors.append(f"scripts/check_layering.py: the exception {pair[0]} -> {pair[1]} no longer "
                      f"occurs; remove it from KNOWN_EXCEPTIONS and from docs/design.md")


def check_lengths(errors):
    for base in ("include", "src", "examples", "tests", "bench", "fuzz"):
        for path in sorted((ROOT / base).rglob("*")):
            if path.suffix not in (".hpp", ".cpp", ".h") or not path.is_file():
                continue
            rel = str(path.relative_to(ROOT))
            lines = len(path.read_text(encoding="utf-8").splitlines())
            cap = LONG_FILES.get(rel, MAX_LINES)
            if lines > cap:
                what = f"grew past its {cap} lines" if rel in LONG_FILES else f"is over {MAX_LINES} lines"
                errors.append(f"{rel}: {lines} lines; it {what}: split it by concern")
    for rel in LONG_FILES:
        if not (ROOT / rel).is_file():
            errors.append(f"scripts/check_layering.py: {rel} in LONG_FILES no longer exists")


def main():
    errors = []
    check_layering(errors)
    check_lengths(errors)
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check_layering: {len(errors)} breach(es)", file=sys.stderr)
        return 1
    print("check_layering: layering and file lengths as in docs/design.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
