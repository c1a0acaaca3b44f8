#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""No source file of the product (outside bench/ and tests/) is over 400 lines, but for those
KNOWN lists, each at most at the size it has now and with what it is waiting for: a listed file
may not grow, and one that has come down to 400 lines must be taken off the list, so the list
only shrinks. docs/architecture.md states the rule.

usage: check_sizes.py SOURCE_DIR
       check_sizes.py --self-test   (a tree that breaks each rule, made and checked here)
"""
import io
import sys
import tempfile
from contextlib import redirect_stdout
from pathlib import Path

LIMIT = 400
SUFFIXES = (".cpp", ".hpp", ".h", ".c")
SKIP = ("bench", "tests", ".git")

# Path: (its lines when listed, what will bring it under the limit).
KNOWN = {
    "include/drivebus/shm.hpp": (458, "the shared-memory layout: one header clients include whole"),
    "daemon/ipc/host.cpp": (457, "RouDi's start and the services' set-up apart"),
    "daemon/bus/bus_thread.cpp": (428, "the line's reopening apart from the bus thread's loop"),
    "daemon/master/scheduler.cpp": (406, "the poll plan apart from the queue's order"),
}


def lines_of(path):
    with open(path, "rb") as f:
        return f.read().count(b"\n")


def check(source):
    problems = []
    checked = 0
    seen = set()
    for path in sorted(source.rglob("*")):
        rel = path.relative_to(source)
        if rel.parts[0] in SKIP or rel.parts[0].startswith("build") or path.suffix not in SUFFIXES:
            continue
        if not path.is_file():
            continue
        checked += 1
        name = rel.as_posix()
        lines = lines_of(path)
        if name in KNOWN:
            seen.add(name)
            listed, _ = KNOWN[name]
            if lines <= LIMIT:
                problems.append(f"{name}: {lines} lines, no longer over {LIMIT}: take it off KNOWN")
            elif lines > listed:
                problems.append(f"{name}: {lines} lines, more than the {listed} it is listed with: split it")
        elif lines > LIMIT:
            problems.append(f"{name}: {lines} lines, over {LIMIT}: split it by what its parts do")
    for name in sorted(set(KNOWN) - seen):
        problems.append(f"{name}: listed in KNOWN, not in the tree: take it off")
    for p in problems:
        print(p)
    print(f"{checked} source files checked, {len(KNOWN)} listed over {LIMIT} lines, {len(problems)} problem(s)")
    return problems


def self_test():
    """A new file over the limit, a listed one grown, one come down, the others gone; a test
    file over the limit is no problem."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = {"daemon/long.cpp": LIMIT + 1, "tests/long_test.cpp": LIMIT + 100,
                 "daemon/bus/bus_thread.cpp": KNOWN["daemon/bus/bus_thread.cpp"][0] + 1,
                 "daemon/master/scheduler.cpp": 10}
        for name, count in files.items():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            (root / name).write_text("// a line\n" * count)
        out = io.StringIO()
        with redirect_stdout(out):
            problems = check(root)
    expected = {
        f"daemon/long.cpp: {LIMIT + 1} lines, over {LIMIT}: split it by what its parts do",
        f"daemon/bus/bus_thread.cpp: {KNOWN['daemon/bus/bus_thread.cpp'][0] + 1} lines, more than the "
        f"{KNOWN['daemon/bus/bus_thread.cpp'][0]} it is listed with: split it",
        f"daemon/master/scheduler.cpp: 10 lines, no longer over {LIMIT}: take it off KNOWN",
    } | {f"{name}: listed in KNOWN, not in the tree: take it off" for name in KNOWN
         if name not in files}
    for p in sorted(set(problems) ^ expected):
        print(("unexpected: " if p in problems else "missing: ") + p)
    print(f"self-test: {len(problems)} problem(s) found, {len(expected)} expected")
    return 0 if set(problems) == expected and len(problems) == len(expected) else 1


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    return 1 if check(Path(sys.argv[1]).resolve()) else 0


if __name__ == "__main__":
    sys.exit(main())
