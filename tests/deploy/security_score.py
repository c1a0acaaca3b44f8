#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""`systemd-analyze security --offline=yes` of a drivebus unit: fail above a maximum exposure,
and fail when the hardening takes away what drivebusd needs (SCHED_FIFO, mlock, the
serial and GPIO devices, /tmp and /dev/shm for iceoryx), or what the RouDi of
drivebus-roudi.service or a client's unit (drivebus-gateway.service; drivebus-mqtt.service, the
network and group drivebus-control too) needs (/tmp, /dev/shm, the host's users and groups, local
sockets), so the score cannot be bought by breaking the service.

usage: security_score.py SYSTEMD_ANALYZE UNIT MAX_EXPOSURE
"""
import re
import subprocess
import sys


def settings(path):
    """Each key of [Service] with its values, in order."""
    values, section = {}, None
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line or line[0] in "#;":
                continue
            if line.startswith("["):
                section = line
                continue
            if section == "[Service]" and "=" in line:
                key, value = line.split("=", 1)
                values.setdefault(key.strip(), []).append(value.strip())
    return values


def iceoryx_needs(s, user):
    """What every process of drivebus's iceoryx needs, the RouDi and its clients alike: the host's
    /tmp and /dev/shm, its users and groups, local sockets; User=`user` (None: any) and Group=drivebus."""
    last = lambda key: (s.get(key) or [""])[-1]  # noqa: E731
    words = lambda key: " ".join(s.get(key, [])).split()  # noqa: E731
    problems = []
    if last("PrivateTmp") in ("yes", "true", "1"):
        problems.append("PrivateTmp=yes hides /tmp/roudi and the clients' sockets")
    if last("PrivateUsers") in ("yes", "true", "1"):
        problems.append("PrivateUsers=yes unmaps the groups the segments' ACLs name")
    if last("ProtectSystem") == "strict":
        rw = words("ReadWritePaths")
        for path in ("/tmp", "/dev/shm"):
            if path not in rw and "-" + path not in rw:
                problems.append(f"ProtectSystem=strict without ReadWritePaths={path}")
    families = words("RestrictAddressFamilies")
    if families and ("AF_UNIX" not in families if not families[0].startswith("~") else "~AF_UNIX" in families):
        problems.append("RestrictAddressFamilies= takes AF_UNIX away (the iceoryx sockets)")
    for key, value in (("User", user), ("Group", "drivebus")):
        if value is not None and last(key) != value:
            problems.append(f"{key}= is '{last(key)}', not {value}")
    return problems


def roudi_needs(s):
    """drivebus-roudi.service: its segments and sockets are shared with the clients (UMask 0007)."""
    problems = iceoryx_needs(s, "drivebus")
    umask = (s.get("UMask") or [""])[-1]
    if umask != "0007":
        problems.append(f"UMask= is '{umask}', not 0007")
    return problems


def network_client_needs(s, user):
    """A libdrivebus client that serves the network (drivebus-gateway, drivebus-mqtt)."""
    last = lambda key: (s.get(key) or [""])[-1]  # noqa: E731
    words = lambda key: " ".join(s.get(key, [])).split()  # noqa: E731
    problems = iceoryx_needs(s, user)
    if last("PrivateNetwork") in ("yes", "true", "1"):
        problems.append("PrivateNetwork=yes cuts it off the network it serves")
    families = words("RestrictAddressFamilies")
    for family in ("AF_INET", "AF_INET6"):
        if families and family not in families:
            problems.append(f"RestrictAddressFamilies= takes {family} away")
    return problems


def mqtt_needs(s):
    """drivebus-mqtt: reaches a broker, sends commands (group drivebus-control), no capability."""
    words = lambda key: " ".join(s.get(key, [])).split()  # noqa: E731
    problems = network_client_needs(s, "drivebus-mqtt")
    if words("CapabilityBoundingSet") or words("AmbientCapabilities"):
        problems.append("the bridge needs no capability")
    if "drivebus-control" not in words("SupplementaryGroups"):
        problems.append("SupplementaryGroups= has no drivebus-control (commands)")
    return problems


def gateway_needs(s):
    """drivebus-gateway: serves Modbus TCP; port 502 needs CAP_NET_BIND_SERVICE, nothing more."""
    words = lambda key: " ".join(s.get(key, [])).split()  # noqa: E731
    problems = network_client_needs(s, "drivebus-gateway")
    for key in ("CapabilityBoundingSet", "AmbientCapabilities"):
        if words(key) != ["CAP_NET_BIND_SERVICE"]:
            problems.append(f"{key}= is '{' '.join(words(key))}', not CAP_NET_BIND_SERVICE alone")
    return problems


def needs(unit):
    s = settings(unit)
    if "iox-roudi" in " ".join(s.get("ExecStart", [])):
        return roudi_needs(s)
    if "drivebus-mqtt" in " ".join(s.get("ExecStart", [])):
        return mqtt_needs(s)
    if "drivebus-gateway" in " ".join(s.get("ExecStart", [])):
        return gateway_needs(s)
    last = lambda key: (s.get(key) or [""])[-1]  # noqa: E731
    words = lambda key: " ".join(s.get(key, [])).split()  # noqa: E731
    problems = []
    for cap in ("CAP_SYS_NICE", "CAP_IPC_LOCK"):
        if cap not in words("AmbientCapabilities") or cap not in words("CapabilityBoundingSet"):
            problems.append(f"{cap} missing from AmbientCapabilities= or CapabilityBoundingSet=")
    if last("RestrictRealtime") not in ("", "no", "false", "0"):
        problems.append("RestrictRealtime= must stay off (SCHED_FIFO)")
    if last("PrivateDevices") in ("yes", "true", "1"):
        problems.append("PrivateDevices=yes hides the serial ports")
    if last("PrivateTmp") in ("yes", "true", "1"):
        problems.append("PrivateTmp=yes hides the iceoryx sockets in /tmp from clients")
    if last("PrivateUsers") in ("yes", "true", "1"):
        problems.append("PrivateUsers=yes voids CAP_SYS_NICE and CAP_IPC_LOCK on the host")
    if last("ProtectProc") not in ("", "default"):
        problems.append(f"ProtectProc={last('ProtectProc')} hides the clients' processes, "
                        "and the lock reaper then frees nothing")
    allowed = [v.split()[0] for v in s.get("DeviceAllow", []) if v.split()]
    if last("DevicePolicy") in ("closed", "strict"):
        for dev in ("char-ttyS", "char-ttyUSB", "char-ttyACM", "char-gpiochip"):
            if dev not in allowed:
                problems.append(f"DeviceAllow={dev} rw missing under DevicePolicy={last('DevicePolicy')}")
    for group in ("@resources", "@memlock"):
        for value in s.get("SystemCallFilter", []):
            if value.startswith("~") and group in value[1:].split():
                problems.append(f"SystemCallFilter= denies {group} (sched_setscheduler, mlock)")
    # lock_memory finds the heap and stack pages in use with mincore(), which @system-service
    # leaves out: an allow-list must name it.
    allow = [v for v in s.get("SystemCallFilter", []) if v and not v.startswith("~")]
    if allow and not any(w in ("mincore", "@known") for v in allow for w in v.split()):
        problems.append("SystemCallFilter= allows no mincore (lock_memory)")
    if last("ProtectSystem") == "strict":
        rw = words("ReadWritePaths")
        for path in ("/tmp", "/dev/shm"):
            if path not in rw and "-" + path not in rw:
                problems.append(f"ProtectSystem=strict without ReadWritePaths={path}")
    return problems


def main(argv):
    if len(argv) != 4:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    analyze, unit, limit = argv[1], argv[2], float(argv[3])
    proc = subprocess.run([analyze, "security", "--offline=yes", "--no-pager", unit],
                          capture_output=True, text=True, check=False)
    out = proc.stdout + proc.stderr
    m = re.search(r"Overall exposure level for \S+: (\d+(?:\.\d+)?)", out)
    if not m:
        print(out)
        print(f"{unit}: no 'Overall exposure level' in the output of systemd-analyze security (exit {proc.returncode})")
        return 1
    score = float(m.group(1))
    problems = needs(unit)
    for p in problems:
        print(f"{unit}: {p}")
    if score > limit:
        print("\n".join(line for line in out.splitlines() if line.startswith("\u2717")))
        print(f"{unit}: exposure {score} > {limit}")
        return 1
    print(f"{unit}: exposure {score} <= {limit}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
