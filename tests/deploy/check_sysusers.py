#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Apply a sysusers.d file with systemd-sysusers into a scratch root and check what it made:
the groups drivebus, drivebusd and drivebus-control; the system user drivebus with primary
group drivebus and shell nologin, a member of drivebusd and dialout and of nothing else of
drivebus's (not drivebus-control: the daemon sends no requests); the system user
drivebus-gateway, primary group drivebus, a member of drivebus-control and of nothing else (not
drivebusd: only the daemon writes the shared memory; not dialout: it opens no port); the same
for drivebus-mqtt, the MQTT bridge's user, which is also the one member of the group
drivebus-mqtt, the group of its secrets (no other user in it, nor with it as primary group).

The scratch root starts with a group file holding dialout, as on Debian. systemd-sysusers
exits 0 after a line it ignores, so any message naming the file fails too.

usage: check_sysusers.py SYSTEMD_SYSUSERS FILE
"""
import os
import subprocess
import sys
import tempfile

GROUPS = ("drivebus", "drivebusd", "drivebus-control", "drivebus-mqtt")
# Each user: the groups it must be a member of, and those it must not.
USERS = {
    "drivebus": ({"drivebusd", "dialout"}, {"drivebus-control", "drivebus-mqtt"}),
    "drivebus-gateway": ({"drivebus-control"}, {"drivebusd", "dialout", "drivebus-mqtt"}),
    "drivebus-mqtt": ({"drivebus-control", "drivebus-mqtt"}, {"drivebusd", "dialout"}),
}
# Groups of a service's secrets: exactly these members, and no one's primary group.
SECRET_GROUPS = {"drivebus-mqtt": {"drivebus-mqtt"}}


def secret_group_problems(groups, users):
    """Problems with the secret groups in a group and a passwd database (read_db's form)."""
    problems = []
    for g, wanted in SECRET_GROUPS.items():
        entry = groups.get(g)
        if entry is None:
            continue  # "no group" is said once, above
        members = {m for m in entry[3].split(",") if m}
        for extra in sorted(members - wanted):
            problems.append(f"group {g} has member {extra}: only {', '.join(sorted(wanted))} may read its secrets")
        for name, user in sorted(users.items()):
            if user[3] == entry[2]:
                problems.append(f"group {g} is the primary group of user {name}")
    return problems


def read_db(path):
    with open(path, encoding="utf-8") as f:
        return {line.split(":")[0]: line.rstrip("\n").split(":") for line in f if line.strip()}


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    tool, conf = argv[1], os.path.abspath(argv[2])
    problems = []
    with tempfile.TemporaryDirectory(prefix="drivebus-sysusers-") as root:
        os.mkdir(os.path.join(root, "etc"))
        with open(os.path.join(root, "etc", "group"), "w", encoding="utf-8") as f:
            f.write("root:x:0:\ndialout:x:20:\n")
        with open(os.path.join(root, "etc", "passwd"), "w", encoding="utf-8") as f:
            f.write("root:x:0:0:root:/root:/bin/sh\n")
        proc = subprocess.run([tool, f"--root={root}", conf], capture_output=True, text=True, check=False)
        out = (proc.stdout + proc.stderr).strip()
        if out:
            print(out)
        if proc.returncode != 0:
            problems.append(f"systemd-sysusers exit {proc.returncode}")
        problems += [f"systemd-sysusers: {line}" for line in out.splitlines() if os.path.basename(conf) in line]
        groups = read_db(os.path.join(root, "etc", "group"))
        users = read_db(os.path.join(root, "etc", "passwd"))

    for g in GROUPS:
        if g not in groups:
            problems.append(f"no group {g}")
    memberships = {}
    for name, (member_of_wanted, not_member_of) in USERS.items():
        user = users.get(name)
        if user is None:
            problems.append(f"no user {name}")
            continue
        if groups.get("drivebus") and user[3] != groups["drivebus"][2]:
            problems.append(f"user {name} has primary GID {user[3]}, not drivebus's {groups['drivebus'][2]}")
        if not 0 < int(user[2]) < 1000:
            problems.append(f"user {name} has UID {user[2]}, not a system UID")
        if not user[6].endswith("nologin"):
            problems.append(f"user {name} has shell {user[6]}, not nologin")
        member_of = {g for g, entry in groups.items() if name in entry[3].split(",")}
        memberships[name] = member_of
        for g in sorted(member_of_wanted - member_of):
            problems.append(f"user {name} is not a member of {g}")
        for g in sorted(not_member_of & member_of):
            problems.append(f"user {name} is a member of {g}")

    problems += secret_group_problems(groups, users)

    for p in problems:
        print(f"{argv[2]}: {p}")
    if problems:
        return 1
    users_text = "; ".join(f"user {n} in {', '.join(sorted(g))}" for n, g in memberships.items())
    print(f"{argv[2]}: groups {', '.join(GROUPS)}; {users_text}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
