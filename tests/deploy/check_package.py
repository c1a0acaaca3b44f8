#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Check the Debian packages that `dpkg-buildpackage -us -uc -b` built (debian/), as dpkg sees
them: scripts/package-check runs it on the .debs of a fresh build.

- exactly the eight packages (drivebusd, drivebus-common, libdrivebus0, libdrivebus-dev,
  drivebusctl, drivebus-sim, drivebus-gateway, drivebus-mqtt, each at VERSION; debug symbol
  packages aside), each with its fields: Architecture, a Maintainer that is not @localhost, the dependencies between them;
- each file in the package it belongs to and in no other: the table of PACKAGES below;
- no udev rule anywhere (/lib/udev/rules.d, /usr/lib/udev/rules.d, /etc/udev);
- every man page compressed (.gz), nothing under /usr/share/man uncompressed;
- drivebusd's conffiles are exactly /etc/drivebus/drivebusd.toml and roudi.toml, and
  drivebus-gateway's /etc/drivebus/gateway.toml; no other package has a file in /etc;
- the maintainer scripts pass `sh -n` and hold the snippets debhelper writes:
  systemd-sysusers drivebus.conf, drivebusd.service enabled, started and restarted after an
  upgrade, drivebus-roudi.service not enabled, the template never enabled, the units stopped
  on removal and forgotten on purge; drivebus-gateway.service enabled, started, stopped on
  removal and forgotten on purge; libdrivebus0 has the ldconfig trigger, shlibs and the
  symbols file of debian/libdrivebus0.symbols;
- `systemd-analyze verify` of each extracted unit (tests/deploy/verify_unit.py, the program
  taken from the package), when systemd-analyze is there;
- the units' ExecStart= programs and --config files, their Documentation= files and every
  concrete /usr, /etc and /lib file the man pages name are installed by one of the packages;
  drivebusd looks for profiles where drivebus-common puts them;
- the MQTT bridge's secrets are its own: the packaged drivebus.conf, applied by
  systemd-sysusers into a scratch root (check_sysusers.py), makes the group drivebus-mqtt with
  the user drivebus-mqtt its only member; the packaged unit puts the bridge in it; the packaged
  mqtt.md and drivebus-mqtt(1) say root:drivebus-mqtt, never the watchers' root:drivebus.

usage: check_package.py DEB_DIR VERSION SOURCE_DIR [ARCH]
"""
import glob
import gzip
import os
import re
import shutil
import subprocess
import sys
import tempfile

# Every file of each package (directories aside), * matching any suffix. {multiarch} is the
# host's triplet. The packages hold these and nothing else.
PACKAGES = {
    "drivebusd": [
        "/etc/drivebus/drivebusd.toml",
        "/etc/drivebus/roudi.toml",
        "{unitdir}/drivebus-roudi.service",
        "{unitdir}/drivebusd.service",
        "{unitdir}/drivebusd@.service",
        "/usr/lib/sysusers.d/drivebus.conf",
        "/usr/sbin/drivebusd",
        "/usr/share/man/man5/drivebusd.toml.5.gz",
        "/usr/share/man/man8/drivebusd.8.gz",
    ],
    "drivebus-common": [
        "/usr/share/drivebus/profiles/atv21.toml",
        "/usr/share/drivebus/profiles/atv58.toml",
        "/usr/share/drivebus/profiles/generic.toml",
        "/usr/share/doc/drivebus/*.md",
        "/usr/share/doc/drivebus/examples/atv21-atv58.toml",
        "/usr/share/doc/drivebus/examples/gpio.toml",
        "/usr/share/doc/drivebus/examples/sim.toml",
        "/usr/share/doc/drivebus/examples/mqtt.toml",
        "/usr/share/doc/drivebus/udev/README.md",
    ],
    "libdrivebus0": [
        "/usr/lib/{multiarch}/libdrivebus.so.0",
        "/usr/lib/{multiarch}/libdrivebus.so.0.*",
    ],
    "libdrivebus-dev": [
        "/usr/include/drivebus/*.hpp",
        "/usr/lib/{multiarch}/libdrivebus.so",
        "/usr/lib/{multiarch}/cmake/drivebus/*.cmake",
        "/usr/lib/{multiarch}/pkgconfig/drivebus.pc",
    ],
    "drivebusctl": [
        "/usr/bin/drivebusctl",
        "/usr/share/man/man1/drivebusctl.1.gz",
    ],
    "drivebus-sim": [
        "/usr/bin/drivebus-sim",
        "/usr/share/man/man1/drivebus-sim.1.gz",
    ],
    "drivebus-gateway": [
        "/etc/drivebus/gateway.toml",
        "{unitdir}/drivebus-gateway.service",
        "/usr/sbin/drivebus-gateway",
        "/usr/share/man/man8/drivebus-gateway.8.gz",
    ],
    "drivebus-mqtt": [
        "/usr/bin/drivebus-mqtt",
        "/usr/share/man/man1/drivebus-mqtt.1.gz",
        "{unitdir}/drivebus-mqtt.service",
    ],
}
# Files that must be there (the patterns above only say where a file may be).
REQUIRED = {
    "drivebusd": PACKAGES["drivebusd"],
    "drivebus-common": PACKAGES["drivebus-common"][:3] + [
        "/usr/share/doc/drivebus/README.md", "/usr/share/doc/drivebus/deployment.md",
        "/usr/share/doc/drivebus/configuration.md", "/usr/share/doc/drivebus/mqtt.md"] + PACKAGES["drivebus-common"][4:],
    "libdrivebus0": PACKAGES["libdrivebus0"],
    "libdrivebus-dev": ["/usr/include/drivebus/client.hpp", "/usr/include/drivebus/version.hpp",
                        "/usr/lib/{multiarch}/libdrivebus.so",
                        "/usr/lib/{multiarch}/cmake/drivebus/drivebusConfig.cmake",
                        "/usr/lib/{multiarch}/cmake/drivebus/drivebusTargets.cmake",
                        "/usr/lib/{multiarch}/pkgconfig/drivebus.pc"],
    "drivebusctl": PACKAGES["drivebusctl"],
    "drivebus-sim": PACKAGES["drivebus-sim"],
    "drivebus-gateway": PACKAGES["drivebus-gateway"],
    "drivebus-mqtt": PACKAGES["drivebus-mqtt"],
}
# Named by the man pages as the administrator's, not installed: the udev rule of the board, and
# the configuration fragments (the drivebusd package ships their directory, empty).
ADMIN_PATHS = ("/etc/udev/rules.d/", "/etc/drivebus/drivebusd.d/", "/etc/drivebus/mqtt.toml",
               "/etc/drivebus/profiles/", "/etc/drivebus/profiles", "/etc/drivebus/mqtt.password")
CONFFILES = ["/etc/drivebus/drivebusd.toml", "/etc/drivebus/roudi.toml"]
GATEWAY_CONFFILES = ["/etc/drivebus/gateway.toml"]
# drivebus-gateway's snippets (dh_installsystemd): enabled, started, stopped on removal, purged.
GATEWAY_SNIPPETS = {
    "postinst": [r"was-enabled 'drivebus-gateway\.service'", r"deb-systemd-invoke \$_dh_action 'drivebus-gateway\.service'"],
    "prerm": [r"deb-systemd-invoke stop 'drivebus-gateway\.service'"],
    "postrm": [r"deb-systemd-helper purge 'drivebus-gateway\.service'"],
}

# debhelper's snippets in drivebusd's maintainer scripts (dh_installsysusers,
# dh_installsystemd): the text that must be there, and what must not.
SNIPPETS = {
    "postinst": [
        r'systemd-sysusers \$\{DPKG_ROOT:\+--root="\$DPKG_ROOT"\} drivebus\.conf',
        r"was-enabled 'drivebusd\.service'; then\s+# Enables the unit on first installation",
        r"_dh_action=restart\s+else\s+_dh_action=start\s+fi\s+deb-systemd-invoke \$_dh_action 'drivebusd\.service'",
        r"deb-systemd-helper debian-installed 'drivebus-roudi\.service'",
        r"deb-systemd-invoke \$_dh_action 'drivebus-roudi\.service'",
    ],
    "prerm": [
        r"\[ \"\$1\" = remove \].*\n\s*deb-systemd-invoke stop 'drivebusd\.service'",
        r"\[ \"\$1\" = remove \].*\n\s*deb-systemd-invoke stop 'drivebus-roudi\.service'",
        r"list-units .*'drivebusd@\*\.service'",
    ],
    "postrm": [
        r"deb-systemd-helper purge 'drivebusd\.service'",
        r"deb-systemd-helper purge 'drivebus-roudi\.service'",
        r"daemon-reload",
    ],
}
NOT_SNIPPETS = {
    "postinst": [r"deb-systemd-helper enable 'drivebus-roudi\.service' >/dev/null \|\| true\n\telse",
                 r"deb-systemd-helper (enable|update-state) 'drivebusd@", r"/udev/|udevadm"],
}


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)


def matches(path, pattern):
    if pattern.endswith("*") or "*" in pattern:
        return re.fullmatch(re.escape(pattern).replace(r"\*", "[^/]*"), path) is not None
    return path == pattern


def man_paths(root):
    """Concrete absolute paths under /usr, /etc and /lib that the man pages set as file names
    (.I, .IR: FILES, SEE ALSO), not placeholders (NAME.toml) or commands' examples."""
    paths = set()
    for page in glob.glob(os.path.join(root, "usr/share/man/man*/*.gz")):
        with gzip.open(page, "rt", encoding="utf-8") as f:
            text = "\n".join(line for line in f.read().replace("\\-", "-").splitlines()
                             if line.startswith((".I ", ".IR ")))
        for m in re.finditer(r"(?<![\w/.])(/(?:usr|etc|lib)/[A-Za-z0-9_./@-]*)", text):
            path = m.group(1).rstrip(".")
            if not re.search(r"[A-Z]", path):
                paths.add((path, os.path.basename(page)))
    return sorted(paths)


def normalised_symbols(text, bits):
    """The symbols of a symbols file as a set of (demangled name@version node, version):
    debian/libdrivebus0.symbols has (c++) patterns, a line tagged arch-bits=N counting only on
    an N-bit architecture; the file in the package has the mangled symbols they matched."""
    out = set()
    for line in text.splitlines():
        if not line.startswith(" "):
            continue
        m = re.match(r'^ \(([^)]*)\)"(.*)" (\S+)$', line)
        if m:
            tags = m.group(1).split("|")
            if any(t.startswith("arch-bits=") and t != f"arch-bits={bits}" for t in tags):
                continue
            out.add((m.group(2), m.group(3)))
            continue
        symbol, version = line.split()[:2]
        name, _, node = symbol.partition("@")
        if name.startswith("_Z"):
            name = run(["c++filt", name]).stdout.strip()
        out.add((f"{name}@{node}", version))
    return out


def optional_symbols(text, bits):
    """The (c++|optional) patterns of a symbols file, as normalised_symbols() gives them."""
    lines = [line for line in text.splitlines() if re.match(r'^ \([^)]*\boptional\b[^)]*\)"', line)]
    return normalised_symbols("\n".join(lines), bits)


def unit_directory(deb_dir, arch):
    """Where the build put the systemd units: /usr/lib/systemd/system where its debhelper installs
    units from /usr (13.11.6 and later: Debian 13, whose lintian calls /lib an aliased location),
    /lib/systemd/system with Debian 12's (13.11.4), as debian/rules chooses. The debhelper of the
    build is the one its .buildinfo records."""
    buildinfo = glob.glob(os.path.join(deb_dir, f"*_{arch}.buildinfo"))
    text = open(buildinfo[0], encoding="utf-8").read() if buildinfo else ""
    found = re.search(r"^ debhelper \(= ([^)]+)\)", text, re.M)
    if not found:
        return "/lib/systemd/system"
    newer = subprocess.run(["dpkg", "--compare-versions", found.group(1), "ge", "13.11.6"], check=False)
    return "/usr/lib/systemd/system" if newer.returncode == 0 else "/lib/systemd/system"


def mqtt_secret_problems(roots, unitdir):
    """The bridge's password file and TLS key belong to a group only its user is in."""
    problems = []
    here = os.path.dirname(os.path.abspath(__file__))
    conf = os.path.join(roots.get("drivebusd", ""), "usr/lib/sysusers.d/drivebus.conf")
    sysusers = shutil.which("systemd-sysusers")
    if not sysusers:
        print("no systemd-sysusers: drivebus.conf not applied")
    elif os.path.exists(conf):
        p = run([sys.executable, os.path.join(here, "check_sysusers.py"), sysusers, conf])
        if p.returncode != 0:
            problems += [f"drivebus.conf: {line.split(': ', 1)[-1]}" for line in p.stdout.splitlines()
                         if line.startswith(conf + ": ")] or [f"drivebus.conf: check_sysusers.py exit {p.returncode}"]
    unit = os.path.join(roots.get("drivebus-mqtt", ""), unitdir.lstrip("/") + "/drivebus-mqtt.service")
    if os.path.exists(unit):
        settings = dict(re.findall(r"^(User|SupplementaryGroups)=(.*)$", open(unit, encoding="utf-8").read(), re.M))
        if settings.get("User") != "drivebus-mqtt" or "drivebus-mqtt" not in settings.get("SupplementaryGroups",
                                                                                             "").split():
            problems.append("drivebus-mqtt.service: not run as user drivebus-mqtt with SupplementaryGroups "
                            f"drivebus-mqtt ({settings})")
    docs = [(os.path.join(roots.get("drivebus-common", ""), "usr/share/doc/drivebus/mqtt.md"), open),
            (os.path.join(roots.get("drivebus-mqtt", ""), "usr/share/man/man1/drivebus-mqtt.1.gz"), gzip.open)]
    for path, opener in docs:
        if not os.path.exists(path):
            continue
        with opener(path, "rt", encoding="utf-8") as f:
            text = f.read().replace("\\-", "-")
        if "root:drivebus-mqtt" not in text:
            problems.append(f"{os.path.basename(path)}: does not say root:drivebus-mqtt for the bridge's secrets")
        if re.search(r"root:drivebus(?![-\w])", text):
            problems.append(f"{os.path.basename(path)}: names root:drivebus, the watchers' group, for a secret")
    return problems


def main(argv):
    if len(argv) not in (4, 5):
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    deb_dir, version, source = argv[1:4]
    problems = []
    arch = argv[4] if len(argv) == 5 else run(["dpkg", "--print-architecture"]).stdout.strip()
    multiarch = run(["dpkg-architecture", f"-a{arch}", "-qDEB_HOST_MULTIARCH"]).stdout.strip()
    bits = run(["dpkg-architecture", f"-a{arch}", "-qDEB_HOST_ARCH_BITS"]).stdout.strip()
    unitdir = unit_directory(deb_dir, arch)
    print(f"{arch} ({multiarch}), units in {unitdir}")

    debs = {}
    for deb in sorted(glob.glob(os.path.join(deb_dir, "*.deb"))):
        name = os.path.basename(deb).split("_")[0]
        if name.endswith("-dbgsym"):
            continue
        debs[name] = deb
    if sorted(debs) != sorted(PACKAGES):
        problems.append(f"packages built: {sorted(debs)}, wanted {sorted(PACKAGES)}")

    scratch = tempfile.mkdtemp(prefix="drivebus-package-check-")
    try:
        owner = {}
        roots = {}
        controls = {}
        everything = os.path.join(scratch, "all")
        for name, deb in sorted(debs.items()):
            want_arch = "all" if name == "drivebus-common" else arch
            expected = f"{name}_{version}_{want_arch}.deb"
            if os.path.basename(deb) != expected:
                problems.append(f"{os.path.basename(deb)}: not named {expected}")
            info = run(["dpkg-deb", "--field", deb])
            if info.returncode != 0:
                problems.append(f"{name}: dpkg-deb --field: {info.stderr.strip()}")
                continue
            fields = dict(re.findall(r"^([A-Za-z-]+): (.*(?:\n .*)*)", info.stdout, flags=re.M))
            for key, want in (("Package", name), ("Version", version), ("Architecture", want_arch)):
                if fields.get(key) != want:
                    problems.append(f"{name}: {key} is {fields.get(key)!r}, not {want!r}")
            maintainer = fields.get("Maintainer", "")
            if not re.fullmatch(r"[^<>]+ <[^@<>\s]+@[^@<>\s]+\.[a-z]+>", maintainer) or "localhost" in maintainer:
                problems.append(f"{name}: Maintainer {maintainer!r}")
            depends = fields.get("Depends", "")
            wanted_depends = {
                # procps: /bin/kill of the units' ExecReload= (not essential in Debian).
                "drivebusd": [f"drivebus-common (= {version})", "procps", "systemd | systemd-standalone-sysusers"],
                "libdrivebus0": [f"drivebus-common (= {version})"],
                "libdrivebus-dev": [f"libdrivebus0 (= {version})"],
                "drivebusctl": [f"libdrivebus0 (>= {version})"],
                "drivebus-sim": [f"drivebus-common (= {version})"],
                # drivebusd: the daemon it is a client of, and the sysusers.d file of its user.
                "drivebus-gateway": [f"drivebusd (= {version})", f"libdrivebus0 (>= {version})"],
                # drivebusd: the groups and the user of the bridge (drivebus.conf), a local drivebusd.
                "drivebus-mqtt": [f"drivebusd (= {version})", f"libdrivebus0 (>= {version})", "libmosquitto1"],
            }.get(name, [])
            for d in wanted_depends:
                if d not in depends:
                    problems.append(f"{name}: Depends has no '{d}': {depends}")
            if name == "drivebusd" and "iceoryx" not in fields.get("Recommends", ""):
                problems.append("drivebusd: iceoryx is not in Recommends")

            root = os.path.join(scratch, "root", name)
            control = os.path.join(scratch, "control", name)
            for d in (root, control, everything):
                os.makedirs(d, exist_ok=True)
            for cmd in (["dpkg-deb", "-x", deb, root], ["dpkg-deb", "-x", deb, everything],
                        ["dpkg-deb", "-e", deb, control]):
                p = run(cmd)
                if p.returncode != 0:
                    problems.append(f"{name}: {' '.join(cmd[:2])}: {p.stderr.strip()}")
            roots[name] = root
            controls[name] = control
            listing = run(["dpkg-deb", "-c", deb]).stdout.splitlines()
            files = [line.split(None, 5)[5].split(" -> ")[0][1:] for line in listing
                     if not line.startswith("d")]
            patterns = [p.format(multiarch=multiarch, unitdir=unitdir) for p in PACKAGES.get(name, [])]
            for f in files:
                if f in owner:
                    problems.append(f"{f}: in {owner[f]} and {name}")
                owner[f] = name
                if "udev" in f and f != "/usr/share/doc/drivebus/udev/README.md":
                    problems.append(f"{name}: {f}: the packages install nothing of udev but its README")
                if f.startswith("/usr/share/man/") and not f.endswith(".gz"):
                    problems.append(f"{name}: {f}: man page not compressed")
                if f.startswith("/etc/") and name not in ("drivebusd", "drivebus-gateway"):
                    problems.append(f"{name}: {f}: only drivebusd and drivebus-gateway have files in /etc")
                if f.startswith(f"/usr/share/doc/{name}/") and os.path.basename(f) in ("copyright", "changelog.gz"):
                    continue
                if not any(matches(f, p) for p in patterns):
                    problems.append(f"{name}: {f} does not belong in this package")
            for p in REQUIRED.get(name, []):
                p = p.format(multiarch=multiarch, unitdir=unitdir)
                if not any(matches(f, p) for f in files):
                    problems.append(f"{name}: no {p}")
            for doc in ("copyright", "changelog.gz"):
                if f"/usr/share/doc/{name}/{doc}" not in files:
                    problems.append(f"{name}: no /usr/share/doc/{name}/{doc}")
            for script in ("preinst", "postinst", "prerm", "postrm"):
                path = os.path.join(control, script)
                if os.path.exists(path):
                    p = run(["sh", "-n", path])
                    if p.returncode != 0:
                        problems.append(f"{name}: {script}: sh -n: {p.stderr.strip()}")

        # drivebusd: conffiles and the debhelper snippets.
        control = controls.get("drivebusd")
        if control:
            conffiles_path = os.path.join(control, "conffiles")
            listed = open(conffiles_path, encoding="utf-8").read().split() if os.path.exists(conffiles_path) else []
            if sorted(listed) != sorted(CONFFILES):
                problems.append(f"drivebusd: conffiles {listed}, wanted {CONFFILES}")
            for script, patterns in SNIPPETS.items():
                path = os.path.join(control, script)
                text = open(path, encoding="utf-8").read() if os.path.exists(path) else ""
                if not text:
                    problems.append(f"drivebusd: no {script}")
                for pattern in patterns:
                    if not re.search(pattern, text):
                        problems.append(f"drivebusd: {script} has no /{pattern}/")
                for pattern in NOT_SNIPPETS.get(script, []):
                    if re.search(pattern, text):
                        problems.append(f"drivebusd: {script} has /{pattern}/")
        control = controls.get("drivebus-gateway")
        if control:
            conffiles_path = os.path.join(control, "conffiles")
            listed = open(conffiles_path, encoding="utf-8").read().split() if os.path.exists(conffiles_path) else []
            if sorted(listed) != GATEWAY_CONFFILES:
                problems.append(f"drivebus-gateway: conffiles {listed}, wanted {GATEWAY_CONFFILES}")
            for script, patterns in GATEWAY_SNIPPETS.items():
                path = os.path.join(control, script)
                text = open(path, encoding="utf-8").read() if os.path.exists(path) else ""
                for pattern in patterns:
                    if not re.search(pattern, text):
                        problems.append(f"drivebus-gateway: {script} has no /{pattern}/")
        # drivebus-mqtt: its unit is not enabled, stopped on removal, forgotten on purge; older
        # root:drivebus secrets get the group drivebus-mqtt (tests/deploy/mqtt_secrets_upgrade.sh).
        control = controls.get("drivebus-mqtt")
        if control:
            for script, pattern in (("postinst", r"deb-systemd-helper debian-installed 'drivebus-mqtt\.service'"),
                                    ("postinst", r'chgrp drivebus-mqtt "\$secret"'),
                                    ("postrm", r"deb-systemd-helper purge 'drivebus-mqtt\.service'")):
                path = os.path.join(control, script)
                text = open(path, encoding="utf-8").read() if os.path.exists(path) else ""
                if not re.search(pattern, text):
                    problems.append(f"drivebus-mqtt: {script} has no /{pattern}/")
            path = os.path.join(control, "postinst")
            # As drivebus-roudi.service: enabled again only where the administrator had enabled it.
            if os.path.exists(path) and re.search(r"deb-systemd-helper enable 'drivebus-mqtt\.service' >/dev/null "
                                                  r"\|\| true\n\telse", open(path, encoding="utf-8").read()):
                problems.append("drivebus-mqtt: postinst enables drivebus-mqtt.service")
        for name, control in controls.items():
            if name not in ("drivebusd", "drivebus-gateway", "drivebus-mqtt") and any(
                    os.path.exists(os.path.join(control, s)) for s in ("preinst", "postinst", "prerm", "postrm")):
                problems.append(f"{name}: has maintainer scripts ({os.listdir(control)})")

        # libdrivebus0: ldconfig, shlibs, the symbols file as debian/ has it.
        control = controls.get("libdrivebus0")
        if control:
            triggers = os.path.join(control, "triggers")
            if not os.path.exists(triggers) or not re.search(r"^activate-noawait ldconfig$",
                                                             open(triggers, encoding="utf-8").read(), flags=re.M):
                problems.append("libdrivebus0: no ldconfig trigger")
            shlibs = os.path.join(control, "shlibs")
            if not os.path.exists(shlibs) or f"libdrivebus 0 libdrivebus0 (>= {version})" not in open(shlibs).read():
                problems.append("libdrivebus0: shlibs does not say 'libdrivebus 0 libdrivebus0 (>= VERSION)'")
            built = os.path.join(control, "symbols")
            with open(os.path.join(source, "debian/libdrivebus0.symbols"), encoding="utf-8") as f:
                wanted = normalised_symbols(f.read(), bits)
            got = normalised_symbols(open(built, encoding="utf-8").read(), bits) if os.path.exists(built) else set()
            with open(os.path.join(source, "debian/libdrivebus0.symbols"), encoding="utf-8") as f:
                optional = optional_symbols(f.read(), bits)
            # An optional one (an implicitly defined member the compiler may or may not emit out
            # of line) may be there or not; every other one must be exactly as listed.
            differ = (got ^ wanted) - optional
            if differ:
                problems.append("libdrivebus0: its symbols file is not debian/libdrivebus0.symbols: "
                                f"{sorted(differ)[:5]}")

        # The units: verified, and what they run and read is in the packages.
        root = roots.get("drivebusd", "")
        units = sorted(glob.glob(os.path.join(root, unitdir.lstrip("/"), "*.service")))
        gateway_root = roots.get("drivebus-gateway", "")
        gateway_units = sorted(glob.glob(os.path.join(gateway_root, unitdir.lstrip("/"), "*.service")))
        mqtt_root = roots.get("drivebus-mqtt", "")
        mqtt_units = sorted(glob.glob(os.path.join(mqtt_root, unitdir.lstrip("/"), "*.service"))) if mqtt_root else []
        analyze = shutil.which("systemd-analyze")
        for unit in units + gateway_units + mqtt_units:
            base = os.path.basename(unit)
            with open(unit, encoding="utf-8") as f:
                text = f.read()
            for line in text.splitlines():
                if line.startswith("ExecStart="):
                    argv_ = line.split("=", 1)[1].split()
                    program = argv_[0].lstrip("-@:+!")
                    if "drivebus" in os.path.basename(program) and program not in owner:
                        problems.append(f"{base}: ExecStart={program} is not in a package")
                    for opt, value in zip(argv_, argv_[1:]):
                        if (opt in ("--config", "-c") and "%" not in value and value not in owner
                                and value not in ADMIN_PATHS):
                            problems.append(f"{base}: {opt} {value} is not in a package")
                if line.startswith("Documentation="):
                    for doc in line.split("=", 1)[1].split():
                        if doc.startswith("file:") and doc[5:] not in owner:
                            problems.append(f"{base}: Documentation={doc} is not in a package")
            if analyze and (base != "drivebus-roudi.service" or shutil.which("iox-roudi")):
                program = (os.path.join(gateway_root, "usr/sbin/drivebus-gateway") if base == "drivebus-gateway.service"
                           else os.path.join(mqtt_root, "usr/bin/drivebus-mqtt") if base == "drivebus-mqtt.service"
                           else os.path.join(root, "usr/sbin/drivebusd"))
                p = run([sys.executable, os.path.join(os.path.dirname(os.path.abspath(__file__)), "verify_unit.py"),
                         analyze, program, unit])
                print(p.stdout.strip().splitlines()[-1] if p.stdout.strip() else f"{base}: verify said nothing")
                if p.returncode != 0:
                    problems.append(f"{base}: systemd-analyze verify failed:\n{p.stdout}{p.stderr}")
        if len(units) != 3:
            problems.append(f"drivebusd: {len(units)} units, wanted 3")
        if len(gateway_units) != 1:
            problems.append(f"drivebus-gateway: {len(gateway_units)} units, wanted 1")
        if len(mqtt_units) != 1:
            problems.append(f"drivebus-mqtt: {len(mqtt_units)} units, wanted 1")
        if not analyze:
            print("no systemd-analyze: the units are not verified")

        for path, page in man_paths(everything):
            if path in ADMIN_PATHS:
                continue
            if path.endswith("/"):
                found = any(f.startswith(path) for f in owner)
            else:
                found = path in owner or any(f.startswith(path + "/") for f in owner)
            if not found:
                problems.append(f"{path} (named by {page}) is not in a package")

        problems += mqtt_secret_problems(roots, unitdir)

        daemon = os.path.join(root, "usr/sbin/drivebusd")
        if os.path.exists(daemon):
            with open(daemon, "rb") as f:
                if b"/usr/share/drivebus/profiles\0" not in f.read():
                    problems.append("drivebusd does not look for profiles in /usr/share/drivebus/profiles")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)

    for p in problems:
        print(p)
    if problems:
        print(f"packages: {len(problems)} problem(s)")
        return 1
    print(f"packages: {', '.join(sorted(debs))} at {version}: {len(owner)} files where they belong, "
          f"conffiles {', '.join(CONFFILES + GATEWAY_CONFFILES)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
