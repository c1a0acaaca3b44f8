#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Static check of udev rules files against the udev(7) grammar of systemd 252.

systemd 252 has no `udevadm verify` (it came in 253), so this checks what udev's rule parser
would reject or ignore: every line is a comma-separated list of KEY{attr}<op>"value" with a
known key, an operator that key accepts and an attribute where the key needs one; GOTO
targets a LABEL that follows; MODE is octal. And drivebus's own policy: a rule that names a
device node (NAME, SYMLINK) also sets GROUP and MODE, and symlinks are unique.

usage: check_udev_rules.py FILE...     exit 0 when clean, 1 with one line per problem
"""
import re
import sys

MATCH = {"==", "!="}
ASSIGN = {"=", "+=", "-=", ":="}

# key: (allowed operators, attribute: "required" | "optional" | "none", allowed attributes)
KEYS = {
    "ACTION": (MATCH, "none", None),
    "DEVPATH": (MATCH, "none", None),
    "KERNEL": (MATCH, "none", None),
    "KERNELS": (MATCH, "none", None),
    "SUBSYSTEM": (MATCH, "none", None),
    "SUBSYSTEMS": (MATCH, "none", None),
    "DRIVER": (MATCH, "none", None),
    "DRIVERS": (MATCH, "none", None),
    "ATTRS": (MATCH, "required", None),
    "TAGS": (MATCH, "none", None),
    "TEST": (MATCH, "optional", None),
    "PROGRAM": (MATCH | {"="}, "none", None),
    "RESULT": (MATCH, "none", None),
    "CONST": (MATCH, "required", {"arch", "virt"}),
    "NAME": (MATCH | {"=", ":="}, "none", None),
    "SYMLINK": (MATCH | {"=", "+=", ":="}, "none", None),
    "ENV": (MATCH | {"=", "+=", ":="}, "required", None),
    "TAG": (MATCH | {"=", "+=", "-=", ":="}, "none", None),
    "ATTR": (MATCH | {"="}, "required", None),
    "SYSCTL": (MATCH | {"="}, "required", None),
    "OWNER": ({"=", ":="}, "none", None),
    "GROUP": ({"=", ":="}, "none", None),
    "MODE": ({"=", ":="}, "none", None),
    "SECLABEL": ({"=", "+=", ":="}, "required", None),
    "RUN": ({"=", "+=", ":="}, "optional", {"program", "builtin"}),
    "IMPORT": (MATCH | {"="}, "required", {"program", "builtin", "file", "db", "cmdline", "parent"}),
    "OPTIONS": ({"=", "+=", ":="}, "none", None),
    "LABEL": ({"="}, "none", None),
    "GOTO": ({"="}, "none", None),
}

TOKEN = re.compile(r'\s*([A-Za-z_]+)(?:\{([^}]*)\})?\s*(==|!=|\+=|-=|:=|=)\s*"((?:[^"\\]|\\.)*)"\s*(?:,|$)')


def logical_lines(text):
    """(line number, rule text) with backslash continuations joined, comments and blanks dropped."""
    buf, start = "", 0
    for n, raw in enumerate(text.splitlines(), 1):
        if not buf:
            start = n
            if raw.strip().startswith("#") or not raw.strip():
                continue
        if raw.endswith("\\"):
            buf += raw[:-1]
            continue
        yield start, buf + raw
        buf = ""
    if buf:
        yield start, buf


def check(path):
    errors = []
    rules = []
    with open(path, encoding="utf-8") as f:
        text = f.read()
    for n, line in logical_lines(text):
        where = f"{path}:{n}"
        tokens, pos, s = [], 0, line.rstrip()
        while pos < len(s):
            m = TOKEN.match(s, pos)
            if not m:
                errors.append(f"{where}: cannot parse at column {pos + 1}: {s[pos:pos + 40]!r}")
                break
            key, attr, op, value = m.group(1), m.group(2), m.group(3), m.group(4)
            pos = m.end()
            spec = KEYS.get(key)
            if spec is None:
                errors.append(f"{where}: unknown key {key!r}")
                continue
            ops, attr_rule, attrs = spec
            if op not in ops:
                errors.append(f"{where}: {key} does not take the operator {op!r}")
            if attr_rule == "required" and not attr:
                errors.append(f"{where}: {key} needs an attribute: {key}{{...}}")
            if attr_rule == "none" and attr is not None:
                errors.append(f"{where}: {key} takes no attribute")
            if attrs is not None and attr and attr not in attrs:
                errors.append(f"{where}: {key}{{{attr}}}: attribute must be one of {sorted(attrs)}")
            tokens.append((key, attr, op, value))
        if tokens:
            rules.append((where, tokens))

    labels = {}
    for i, (where, tokens) in enumerate(rules):
        for key, _, _, value in tokens:
            if key == "LABEL":
                labels.setdefault(value, i)
    symlinks = {}
    for i, (where, tokens) in enumerate(rules):
        assigned = {key for key, _, op, _ in tokens if op not in MATCH}
        for key, _, op, value in tokens:
            if key == "GOTO" and labels.get(value, -1) <= i:
                errors.append(f"{where}: GOTO={value!r} has no LABEL after it")
            if key == "MODE" and not re.fullmatch(r"0?[0-7]{3,4}", value):
                errors.append(f"{where}: MODE={value!r} is not an octal mode")
            if key == "SYMLINK" and op not in MATCH:
                for link in value.split():
                    if link in symlinks:
                        errors.append(f"{where}: symlink {link!r} already set at {symlinks[link]}")
                    symlinks[link] = where
        if assigned & {"NAME", "SYMLINK"} and not {"GROUP", "MODE"} <= assigned:
            errors.append(f"{where}: a rule that names a device node must set GROUP and MODE")
    return errors


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    errors = []
    for path in argv[1:]:
        errors += check(path)
    for e in errors:
        print(e)
    print(f"{len(argv) - 1} file(s): {'OK' if not errors else f'{len(errors)} problem(s)'}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
