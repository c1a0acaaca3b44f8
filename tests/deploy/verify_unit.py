#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""`systemd-analyze verify` of a drivebus unit, strictly.

verify checks that ExecStart= names an executable, so the unit is copied into a scratch
directory with the drivebus program it runs (/usr/sbin/drivebusd, /usr/sbin/drivebus-gateway,
/usr/bin/drivebus-mqtt) replaced by the built binary given (a unit that runs another program,
drivebus-roudi.service's iox-roudi, is verified as it is). A template is verified as an
instance (drivebusd@verify.service) so that %i is expanded. systemd-analyze exits 0 on
unknown keys and unparsable values (it only logs "ignoring"), so any message about the unit
fails the test too.

usage: verify_unit.py SYSTEMD_ANALYZE PROGRAM UNIT
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile


def main(argv):
    if len(argv) != 4:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    analyze, binary, unit = argv[1:]
    name = os.path.basename(unit)
    if name.endswith("@.service"):
        name = name.replace("@.service", "@verify.service")
    with open(unit, encoding="utf-8") as f:
        text = f.read()
    text, count = re.subn(r"^(ExecStart=[-@:+!]*)/usr/s?bin/drivebus[-a-z]*(?=\s|$)", lambda m: m.group(1) + binary,
                          text, flags=re.M)
    if count == 0 and not re.search(r"^ExecStart=\S", text, flags=re.M):
        print(f"{unit}: no ExecStart=")
        return 1
    with tempfile.TemporaryDirectory(prefix="drivebus-verify-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        proc = subprocess.run([analyze, "verify", "--man=no", path], cwd=tmp,
                              capture_output=True, text=True, check=False)
    out = (proc.stdout + proc.stderr).strip()
    problems = [line for line in out.splitlines() if name in line or tmp in line]
    if out:
        print(out)
    if proc.returncode != 0 or problems:
        print(f"{unit}: systemd-analyze verify: exit {proc.returncode}, {len(problems)} message(s) about the unit")
        return 1
    print(f"{unit}: verified as {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
