#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The layers of docs/architecture.md, as the build sees them.

Each library exports its own include directory, so a source file can include only the layers
its target links. This check reads the build's compile_commands.json and fails when a source
file of a layer is compiled with the include directory of a layer it must not see (a target
that links too much): the master with the configuration; each library with the libraries above
it; the simulator, the gateway or the MQTT bridge (libdrivebus clients) with anything of
drivebusd or of each other.

The public headers (include/drivebus/) are one directory, so which of them a layer includes
is checked in its files (headers too): the shared-memory layout (drivebus/shm.hpp) is
drivebusd's ipc's, its configuration's (the sizes a name must fit) and the clients', never the
libraries', the master's, the bus thread's or the simulator's; libdrivebus's API
(drivebus/client.hpp, drivebus/altivar.hpp) is for its clients only.

usage: check_layers.py SOURCE_DIR compile_commands.json
"""
import json
import re
import shlex
import sys
from pathlib import Path

# A layer (the folder its sources are in) and the folders whose include directories it must
# not be given. The first rule whose folder holds the file applies.
DAEMON = ["daemon/"]
EDGES = ["client/", "sim/", "gateway/", "mqtt/", "python/"]
RULES = [
    ("lib/rtu/", ["lib/", "include"] + DAEMON + EDGES),
    ("lib/duration/", ["lib/", "include"] + DAEMON + EDGES),
    ("lib/settings/", ["lib/rtu/", "lib/profile/", "lib/sys/", "lib/log/", "lib/rt/", "lib/serial/", "include"]
     + DAEMON + EDGES),
    ("lib/profile/", ["lib/rtu/", "lib/duration/", "lib/sys/", "lib/log/", "lib/rt/", "lib/serial/"]
     + DAEMON + EDGES),
    ("lib/sys/", ["lib/duration/", "lib/settings/", "lib/profile/", "lib/log/", "lib/rt/", "lib/serial/",
                  "include"] + DAEMON + EDGES),
    ("lib/log/", ["lib/duration/", "lib/settings/", "lib/profile/", "lib/rt/", "lib/serial/", "include"]
     + DAEMON + EDGES),
    ("lib/rt/", ["lib/duration/", "lib/settings/", "lib/profile/", "lib/serial/", "include"] + DAEMON + EDGES),
    ("lib/serial/", ["lib/duration/", "lib/settings/", "lib/profile/", "lib/log/", "lib/rt/", "include"]
     + DAEMON + EDGES),
    ("lib/", DAEMON + EDGES),
    ("daemon/master/", ["daemon/config/", "daemon/bus/", "daemon/ipc/", "daemon/ipc_core/",
                        "lib/serial/", "lib/sys/", "lib/log/", "lib/rt/", "lib/settings/"] + EDGES),
    ("daemon/config/", ["daemon/bus/", "daemon/ipc/", "daemon/ipc_core/"] + EDGES),
    ("daemon/ipc_core/", ["daemon/bus/", "daemon/ipc/"] + EDGES),
    ("daemon/bus/", ["daemon/ipc/", "daemon/ipc_core/"] + EDGES),
    ("daemon/", EDGES),
    ("sim/", DAEMON + ["client/", "gateway/", "mqtt/", "python/"]),
    # The gateway, the MQTT bridge and the Python module are libdrivebus clients: its public headers, never
    # drivebusd's layers, the library's insides or each other.
    ("gateway/", DAEMON + ["client/", "sim/", "mqtt/", "python/"]),
    ("client/", DAEMON + ["sim/", "gateway/", "mqtt/", "python/"]),
    ("mqtt/", DAEMON + ["client/", "sim/", "gateway/", "python/"]),
    # The Python module is libdrivebus's public API in Python, nothing else.
    ("python/", DAEMON + ["client/", "sim/", "gateway/", "mqtt/"]),
]

# Folders, the public headers none of their files may include, and why.
SHM = "drivebus/shm.hpp"
API = ["drivebus/client.hpp", "drivebus/altivar.hpp"]
HEADER_RULES = [
    (["lib/", "daemon/master/", "daemon/bus/", "sim/"], [SHM],
     "the shared-memory layout is drivebusd's ipc's and its clients'"),
    (["lib/", "daemon/", "sim/"], API, "libdrivebus's API is for its clients"),
]
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')


def header_problems(source):
    """Each file of a folder of HEADER_RULES that includes a header that folder may not."""
    problems = []
    checked = set()
    for folders, headers, why in HEADER_RULES:
        for folder in folders:
            root = source / folder
            if not root.is_dir():
                continue
            for path in sorted(root.rglob("*")):
                if path.suffix not in (".cpp", ".hpp", ".h", ".c") or not path.is_file():
                    continue
                rel = path.relative_to(source).as_posix()
                checked.add(rel)
                for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                    m = INCLUDE.match(line)
                    if m and m.group(1) in headers:
                        problems.append(f"{rel}:{number}: includes {m.group(1)}, which {folder} must not: {why}")
    return problems, len(checked)


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
    headers, files = header_problems(source)
    problems += headers
    for p in problems:
        print(p)
    if checked == 0:
        print("no source file of any layer in the compile commands")
        return 1
    print(f"{checked} source files' include directories and {files} files' includes checked, "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
