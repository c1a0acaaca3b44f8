#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""libdrivebus exports its public API and nothing else.

Usage: check_symbols.py INCLUDE_DIR (LIBRARY | --symbols FILE)

The exported symbols (nm -D --defined-only -C LIBRARY, or a list of demangled names in FILE)
must all be in namespace drivebus, none of them an implementation detail (profile_detail, a
class's Impl, std:: or toml:: code); and every part of the API the public headers export
(classes and functions marked DRIVEBUS_API, the profile loader's functions) must be there.
Prints each problem; exit status 1 if there is any.
"""
import pathlib
import re
import subprocess
import sys

HIDDEN = ("drivebus::profile_detail::", "drivebus::settings::", "::Impl::", "toml::")


def exported(library):
    out = subprocess.run(["nm", "-D", "--defined-only", "-C", library], check=True, capture_output=True,
                         text=True).stdout
    names = []
    for line in out.splitlines():
        parts = line.split(" ", 2)
        if len(parts) == 3 and parts[1] != "A":  # A: the version node itself
            names.append(parts[2].split("@@")[0])
    return names


def class_body(text, start):
    """The text between the braces of the class whose declaration starts at `start`."""
    open_at = text.index("{", start)
    depth = 0
    for i in range(open_at, len(text)):
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return text[open_at + 1:i]
    return text[open_at + 1:]


def public_api(include):
    """Names the headers promise: DRIVEBUS_API classes with a member defined out of line,
    DRIVEBUS_API functions, the profile loader's functions."""
    wanted = set()
    for header in sorted(pathlib.Path(include).glob("*.hpp")):
        text = header.read_text()
        for m in re.finditer(r"class\s+DRIVEBUS_API\s+(\w+)", text):
            # A member declared and not defined here: ") const;", ") noexcept;", ");", once
            # the inline bodies are taken out.
            body = class_body(text, m.end())
            while re.search(r"\{[^{}]*\}", body):
                body = re.sub(r"\{[^{}]*\}", "", body)
            if re.search(r"\)\s*(const)?\s*(noexcept)?\s*;", body):
                wanted.add(f"drivebus::{m.group(1)}::")
        for m in re.finditer(r"DRIVEBUS_API\s+[\w:<>,\s&*]+?\s(\w+)\(", text):
            wanted.add(f"drivebus::{m.group(1)}(")
    profile = (pathlib.Path(include) / "profile.hpp").read_text()
    for m in re.finditer(r"^\[\[nodiscard\]\]\s+(?!constexpr)[\w:<>,\s*&]+?\s(\w+)\(", profile, re.M):
        wanted.add(f"drivebus::{m.group(1)}(")
    return wanted


def main():
    args = sys.argv[1:]
    if len(args) == 3 and args[1] == "--symbols":
        symbols = [line.strip() for line in pathlib.Path(args[2]).read_text().splitlines() if line.strip()]
    elif len(args) == 2:
        symbols = exported(args[1])
    else:
        print(__doc__)
        return 2
    problems = []
    for s in symbols:
        if not s.startswith("drivebus::") and not s.startswith("typeinfo for drivebus::"):
            problems.append(f"exported, not in namespace drivebus: {s}")
        elif any(h in s for h in HIDDEN):
            problems.append(f"exported implementation detail: {s}")
    wanted = public_api(args[0])
    if not wanted:
        problems.append(f"no public API found in {args[0]}")
    plain = [s.replace("[abi:cxx11]", "") for s in symbols]
    for w in sorted(wanted):
        if not any(s.startswith(w) or (" " + w) in s for s in plain):
            problems.append(f"public API not exported: {w}")
    for p in problems:
        print(p)
    print(f"{len(symbols)} symbols exported, {len(wanted)} parts of the public API, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
