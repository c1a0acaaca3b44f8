#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The layers of docs/architecture.md, as the build sees them.

Each library exports its own include directory, so a source file can include only the layers
its target links. This check reads the build's compile_commands.json and fails when a source
file of a layer is compiled with the include directory of a layer it must not see (a target
that links too much): the master with the configuration; the libraries, the simulator, the
gateway or the MQTT bridge (libdrivebus clients) with anything of drivebusd.

usage: check_layers.py SOURCE_DIR compile_commands.json
"""
import json
import shlex
import sys
from pathlib import Path

# A layer (the folder its sources are in) and the folders whose include directories it must
# not be given.
DAEMON = ["daemon/"]
RULES = [
    ("lib/rtu/", ["lib/", "daemon/", "client/", "sim/", "include"]),
    ("lib/", DAEMON + ["client/", "sim/"]),
    ("daemon/master/", ["daemon/config/", "daemon/bus/", "daemon/ipc/", "daemon/ipc_core/",
                        "lib/serial/", "lib/sys/", "lib/log/", "lib/rt/"]),
    ("daemon/config/", ["daemon/bus/", "daemon/ipc/", "daemon/ipc_core/"]),
    ("daemon/ipc_core/", ["daemon/bus/", "daemon/ipc/"]),
    ("daemon/bus/", ["daemon/ipc/", "daemon/ipc_core/"]),
    ("sim/", DAEMON + ["client/"]),
    ("gateway/", DAEMON + ["sim/"]),
    ("client/", DAEMON + ["sim/"]),
    # The MQTT bridge is a client: libdrivebus's public headers, never drivebusd's layers or
    # the library's insides.
    ("mqtt/", DAEMON + ["client/", "sim/"]),
]


def include_dirs(entry):
    args = entry.get("arguments") or shlex.split(entry["command"])
    dirs = []
    for i, a in enumerate(args):
        if a in ("-I", "-isystem") and i + 1 < len(args):
            dirs.append(args[i + 1])
        elif a.startswith("-I"):
            dirs.append(a[2:])
    return dirs


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    source = Path(sys.argv[1]).resolve()
    entries = json.loads(Path(sys.argv[2]).read_text())
    problems = []
    checked = 0
    for entry in entries:
        try:
            base = Path(entry.get("directory", source))
            rel = (base / entry["file"]).resolve().relative_to(source).as_posix()
        except ValueError:
            continue
        rule = next((r for r in RULES if rel.startswith(r[0])), None)
        if rule is None:
            continue
        checked += 1
        for d in include_dirs(entry):
            try:
                rel_dir = (base / d).resolve().relative_to(source).as_posix()
            except ValueError:
                continue  # outside the tree: a system or generated directory
            rel_dir += "/"
            if rel_dir.startswith("build") or rel_dir.startswith(rule[0]):
                continue
            for forbidden in rule[1]:
                if rel_dir.startswith(forbidden if forbidden.endswith("/") else forbidden + "/"):
                    problems.append(f"{rel}: compiled with {rel_dir}, which {rule[0]} must not see")
    for p in problems:
        print(p)
    if checked == 0:
        print("no source file of any layer in the compile commands")
        return 1
    print(f"{checked} source files checked, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
