#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Check that the iceoryx RouDi configuration, the units and the sysusers.d file agree.

roudi.toml against iceoryx 2.0's parser: [general] version = 1, every [[segment]] with a
writer and a reader group and at least one [[segment.mempool]], sizes multiples of 8 in
ascending order, positive counts. Then drivebus's layout:

- every group roudi.toml, the units and the udev rules name is created by the sysusers.d file
  (or is dialout, which Debian always has);
- the RouDi unit runs with primary group = the reader group of drivebusd's segment (every
  client's group: iceoryx answers clients through sockets of their effective group), which no
  segment has as its writer, and reads the roudi.toml installed to /etc/drivebus;
- each drivebusd unit has the same primary group and, as a supplementary group, the writer
  group of the segment it publishes in (which is the reader group of the requests' segment);
  it is ordered after the RouDi unit but does not require it (roudi = "auto").

usage: check_ipc.py ROUDI_TOML SYSUSERS_CONF RULES ROUDI_UNIT DAEMON_UNIT...
"""
import re
import shlex
import sys
import tomllib

BASE_GROUPS = {"dialout"}


def unit_settings(path):
    """{section: {key: [values]}}."""
    out, section = {}, None
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line or line[0] in "#;":
                continue
            if line.startswith("["):
                section = out.setdefault(line.strip("[]"), {})
            elif section is not None and "=" in line:
                key, value = line.split("=", 1)
                section.setdefault(key.strip(), []).append(value.strip())
    return out


def last(settings, section, key):
    values = settings.get(section, {}).get(key, [])
    return values[-1] if values else ""


def words(settings, section, key):
    return " ".join(settings.get(section, {}).get(key, [])).split()


def sysusers_groups(path):
    groups = set()
    with open(path, encoding="utf-8") as f:
        for line in f:
            fields = shlex.split(line, comments=True)
            if len(fields) >= 2 and fields[0] in ("g", "u"):
                groups.add(fields[1])
            if len(fields) >= 3 and fields[0] == "m":
                groups.add(fields[2])
    return groups


def check_roudi_toml(path):
    problems = []
    with open(path, "rb") as f:
        try:
            cfg = tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            return [f"{path}: {e}"], []
    if cfg.get("general", {}).get("version") != 1:
        problems.append(f"{path}: [general] version must be 1")
    segments = cfg.get("segment", [])
    if not segments:
        problems.append(f"{path}: no [[segment]]")
    for i, seg in enumerate(segments, 1):
        where = f"{path}: segment {i}"
        for key in seg:
            if key not in ("reader", "writer", "mempool"):
                problems.append(f"{where}: unknown key '{key}'")
        for key in ("reader", "writer"):
            if not isinstance(seg.get(key), str) or not seg.get(key):
                problems.append(f"{where}: no {key} group")
        pools = seg.get("mempool", [])
        if not pools:
            problems.append(f"{where}: no [[segment.mempool]]")
        sizes = []
        for pool in pools:
            size, count = pool.get("size"), pool.get("count")
            if not isinstance(size, int) or size <= 0 or size % 8:
                problems.append(f"{where}: mempool size {size!r} is not a positive multiple of 8")
            if not isinstance(count, int) or count <= 0:
                problems.append(f"{where}: mempool count {count!r} is not positive")
            sizes.append(size if isinstance(size, int) else 0)
        if sizes != sorted(set(sizes)):
            problems.append(f"{where}: mempool sizes {sizes} are not in ascending order")
    return problems, segments


def main(argv):
    if len(argv) < 6:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    roudi_toml, sysusers, rules, roudi_unit, daemon_units = argv[1], argv[2], argv[3], argv[4], argv[5:]
    problems, segments = check_roudi_toml(roudi_toml)
    known = sysusers_groups(sysusers) | BASE_GROUPS

    named = {}
    for i, seg in enumerate(segments, 1):
        for key in ("reader", "writer"):
            if isinstance(seg.get(key), str):
                named.setdefault(seg[key], f"{roudi_toml} segment {i} {key}")
    with open(rules, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            for g in re.findall(r'\bGROUP:?="([^"]*)"', line):
                named.setdefault(g, f"{rules}:{n}")

    roudi = unit_settings(roudi_unit)
    roudi_group = last(roudi, "Service", "Group")
    for key in ("Group", "SupplementaryGroups"):
        for g in words(roudi, "Service", key):
            named.setdefault(g, f"{roudi_unit} {key}=")
    writers = {seg.get("writer") for seg in segments}
    readers_of = {seg.get("writer"): seg.get("reader") for seg in segments}

    exec_start = last(roudi, "Service", "ExecStart")
    m = re.search(r"\s-c\s+(\S+)", exec_start)
    if not m or m.group(1) != "/etc/drivebus/roudi.toml":
        problems.append(f"{roudi_unit}: ExecStart= does not read /etc/drivebus/roudi.toml (-c)")
    if roudi_group in writers:
        problems.append(f"{roudi_unit}: Group={roudi_group} is a segment's writer group: every client could publish there")
    if last(roudi, "Service", "UMask") != "0007":
        problems.append(f"{roudi_unit}: UMask= is not 0007 (the management segment and socket are shared by group)")

    for unit in daemon_units:
        s = unit_settings(unit)
        for key in ("Group", "SupplementaryGroups"):
            for g in words(s, "Service", key):
                named.setdefault(g, f"{unit} {key}=")
        if last(s, "Service", "Group") != roudi_group:
            problems.append(f"{unit}: Group={last(s, 'Service', 'Group')}, not the RouDi's group {roudi_group}")
        supplementary = set(words(s, "Service", "SupplementaryGroups"))
        daemon_writes = [w for w in writers if w in supplementary]
        if len(daemon_writes) != 1:
            problems.append(f"{unit}: SupplementaryGroups= holds {len(daemon_writes)} segment writer groups, not exactly one")
        else:
            daemon_group = daemon_writes[0]
            if readers_of.get(daemon_group) != roudi_group:
                problems.append(f"{unit}: the segment drivebusd writes ({daemon_group}) is not readable by {roudi_group}")
            if not any(seg.get("reader") == daemon_group and seg.get("writer") != daemon_group for seg in segments):
                problems.append(f"{unit}: no segment of requests that {daemon_group} reads")
        roudi_name = roudi_unit.rsplit("/", 1)[-1]
        if roudi_name not in words(s, "Unit", "After"):
            problems.append(f"{unit}: not ordered After={roudi_name}")
        for key in ("Requires", "BindsTo", "Requisite"):
            if roudi_name in words(s, "Unit", key):
                problems.append(f"{unit}: {key}={roudi_name}: with roudi = \"auto\" drivebusd must start without it")

    for g, where in sorted(named.items()):
        if g not in known:
            problems.append(f"{where}: group {g} is not created by {sysusers}")

    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} problem(s)")
        return 1
    print(f"{roudi_toml}: {len(segments)} segment(s); groups {', '.join(sorted(named))} all created by {sysusers}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
