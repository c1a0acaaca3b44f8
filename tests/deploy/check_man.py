#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Check the man pages: each renders without a single groff warning, its .TH names the page
of its file name, and, with --config-doc, drivebusd.toml(5) names every key of
docs/configuration.md.

groff exits 0 after warnings (an unknown macro, a bad escape), so any output on stderr fails.

usage: check_man.py [--config-doc docs/configuration.md] PAGE...
"""
import os
import re
import subprocess
import sys


def config_keys(doc):
    """The keys of the tables in docs/configuration.md: first cell `key`."""
    keys = set()
    with open(doc, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"\|\s*`([a-z_]+)`\s*\|", line)
            if m:
                keys.add(m.group(1))
    return keys


def page_keys(text):
    """Keys the page introduces as a tagged paragraph: .TP, then .B key."""
    return set(re.findall(r"^\.TP\n\.B ([a-z_]+)$", text, flags=re.M))


def check(page, doc_keys):
    problems = []
    name = os.path.basename(page)
    m = re.fullmatch(r"(.+)\.([1-8])", name)
    if not m:
        return [f"{page}: not named NAME.SECTION"]
    with open(page, encoding="utf-8") as f:
        text = f.read()
    th = re.search(r"^\.TH\s+(\S+)\s+(\S+)", text, flags=re.M)
    if not th:
        problems.append(f"{page}: no .TH line")
    else:
        title = th.group(1).replace("\\-", "-")
        if title != m.group(1).upper() or th.group(2) != m.group(2):
            problems.append(f"{page}: .TH says {title}({th.group(2)}), the file name {m.group(1)}({m.group(2)})")
    proc = subprocess.run(["groff", "-man", "-Tutf8", "-ww", "-z", page],
                          capture_output=True, text=True, check=False)
    for line in (proc.stdout + proc.stderr).splitlines():
        problems.append(f"{page}: groff: {line}")
    if proc.returncode != 0:
        problems.append(f"{page}: groff exit {proc.returncode}")
    if doc_keys is not None and name == "drivebusd.toml.5":
        missing = sorted(doc_keys - page_keys(text))
        if missing:
            problems.append(f"{page}: keys of docs/configuration.md not described: {', '.join(missing)}")
    return problems


def main(argv):
    args = argv[1:]
    doc_keys = None
    if len(args) >= 2 and args[0] == "--config-doc":
        doc_keys = config_keys(args[1])
        if not doc_keys:
            print(f"{args[1]}: no keys found")
            return 1
        args = args[2:]
    if not args:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    problems = [p for page in args for p in check(page, doc_keys)]
    for p in problems:
        print(p)
    print(f"{len(args)} page(s): {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
