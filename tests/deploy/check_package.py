#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Build the .deb with cpack into a scratch directory and check it as dpkg sees it.

- cpack -G DEB makes exactly drivebus_<version>_<arch>.deb;
- dpkg-deb --info and --contents accept it; the control file names the package, version,
  maintainer and Recommends: iceoryx; the maintainer scripts pass `sh -n`;
- the conffiles list holds the given configuration files; a shared library comes with the
  ldconfig trigger;
- `dpkg -x` into a scratch root holds every path of PATHS_FILE (one a line; a trailing *
  matches any suffix, as in libdrivebus.so.0*) and every concrete /usr, /etc and /lib file
  the man pages name;
- the units' ExecStart= programs of drivebus and their --config/-c files are in the package,
  and drivebusd looks for profiles where the package puts them.

usage: check_package.py CPACK CPACK_CONFIG SCRATCH_DIR VERSION PATHS_FILE CONFFILE...
"""
import glob
import os
import re
import shutil
import subprocess
import sys


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, check=False, **kw)


def man_paths(root):
    """Concrete absolute paths under /usr, /etc and /lib that the installed man pages set as
    file names (.I, .IR: FILES, SEE ALSO), not placeholders (NAME.toml) or commands' examples."""
    paths = set()
    for page in glob.glob(os.path.join(root, "usr/share/man/man*/*")):
        with open(page, encoding="utf-8") as f:
            text = "\n".join(line for line in f.read().replace("\\-", "-").splitlines()
                             if line.startswith((".I ", ".IR ")))
        for m in re.finditer(r"(?<![\w/.])(/(?:usr|etc|lib)/[A-Za-z0-9_./@-]*)", text):
            path = m.group(1).rstrip(".")
            if not re.search(r"[A-Z]", path):  # NAME.toml, TYPE.toml, ...
                paths.add((path, os.path.basename(page)))
    return sorted(paths)


def main(argv):
    if len(argv) < 6:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    cpack, config, scratch, version, paths_file = argv[1:6]
    conffiles = argv[6:]
    problems = []

    shutil.rmtree(scratch, ignore_errors=True)
    os.makedirs(scratch)
    proc = run([cpack, "-G", "DEB", "--config", config, "-B", scratch], timeout=120)
    if proc.returncode != 0:
        print(proc.stdout + proc.stderr)
        print(f"cpack exit {proc.returncode}")
        return 1
    arch = run(["dpkg", "--print-architecture"]).stdout.strip()
    debs = glob.glob(os.path.join(scratch, "*.deb"))
    name = f"drivebus_{version}_{arch}.deb"
    if [os.path.basename(d) for d in debs] != [name]:
        print(f"cpack made {[os.path.basename(d) for d in debs]}, not [{name}]")
        return 1
    deb = debs[0]

    info = run(["dpkg-deb", "--info", deb])
    contents = run(["dpkg-deb", "--contents", deb])
    for what, p in (("--info", info), ("--contents", contents)):
        if p.returncode != 0:
            problems.append(f"dpkg-deb {what}: exit {p.returncode}: {p.stderr.strip()}")
    for field in ("Package: drivebus", f"Version: {version}", "Maintainer: ", f"Architecture: {arch}", "Depends: "):
        if not re.search(rf"^ {re.escape(field)}", info.stdout, flags=re.M):
            problems.append(f"control: no '{field.strip()}'")
    if not re.search(r"^ Recommends:.*\biceoryx\b", info.stdout, flags=re.M):
        problems.append("control: iceoryx is not in Recommends")

    control = os.path.join(scratch, "control")
    root = os.path.join(scratch, "root")
    for cmd in (["dpkg-deb", "--control", deb, control], ["dpkg", "-x", deb, root]):
        p = run(cmd)
        if p.returncode != 0:
            problems.append(f"{' '.join(cmd[:2])}: exit {p.returncode}: {p.stderr.strip()}")
    listed = []
    if os.path.exists(os.path.join(control, "conffiles")):
        with open(os.path.join(control, "conffiles"), encoding="utf-8") as f:
            listed = f.read().split()
    for c in conffiles:
        if c not in listed:
            problems.append(f"conffiles: {c} missing (has {listed})")
    shared = glob.glob(os.path.join(root, "usr/lib/*/lib*.so.*")) if os.path.isdir(root) else []
    if shared:
        triggers = ""
        if os.path.exists(os.path.join(control, "triggers")):
            with open(os.path.join(control, "triggers"), encoding="utf-8") as f:
                triggers = f.read()
        if not re.search(r"^activate-noawait ldconfig$", triggers, flags=re.M):
            problems.append(f"{os.path.basename(shared[0])} is in the package, but no ldconfig trigger")
    for script in ("postinst", "prerm", "postrm"):
        path = os.path.join(control, script)
        if not os.path.exists(path):
            problems.append(f"no {script}")
            continue
        if not os.access(path, os.X_OK):
            problems.append(f"{script} is not executable")
        p = run(["sh", "-n", path])
        if p.returncode != 0:
            problems.append(f"{script}: sh -n: {p.stderr.strip()}")

    with open(paths_file, encoding="utf-8") as f:
        wanted = [(line.strip(), os.path.basename(paths_file)) for line in f if line.strip()]
    wanted += man_paths(root)
    for path, source in wanted:
        target = root + path
        found = glob.glob(target) if path.endswith("*") else ([target] if os.path.lexists(target) else [])
        if not found:
            problems.append(f"{path} (named by {source}) is not in the package")

    units = glob.glob(os.path.join(root, "lib/systemd/system/*.service"))
    units += glob.glob(os.path.join(root, "usr/lib/systemd/system/*.service"))
    if not units:
        problems.append("no systemd units in the package")
    for unit in units:
        with open(unit, encoding="utf-8") as f:
            for line in f:
                if not line.startswith("ExecStart="):
                    continue
                argv_ = line.split("=", 1)[1].split()
                program = argv_[0].lstrip("-@:+!")
                if "drivebus" in os.path.basename(program) and not os.path.exists(root + program):
                    problems.append(f"{os.path.basename(unit)}: ExecStart={program} is not in the package")
                for opt, value in zip(argv_, argv_[1:]):
                    if opt in ("--config", "-c") and "%" not in value and not os.path.exists(root + value):
                        problems.append(f"{os.path.basename(unit)}: {opt} {value} is not in the package")

    daemon = root + "/usr/sbin/drivebusd"
    if os.path.exists(daemon):
        with open(daemon, "rb") as f:
            if b"/usr/share/drivebus/profiles\0" not in f.read():
                problems.append("drivebusd does not look for profiles in /usr/share/drivebus/profiles "
                                "(built for another CMAKE_INSTALL_PREFIX than /usr?)")

    for p in problems:
        print(p)
    if problems:
        print(f"{name}: {len(problems)} problem(s)")
        return 1
    print(f"{name}: {len(wanted)} paths present, conffiles {', '.join(conffiles)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
