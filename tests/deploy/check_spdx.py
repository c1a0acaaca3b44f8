#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Every source file of the tree says its licence in its first lines: an SPDX identifier,
Apache-2.0 (LICENSE). Test inputs (fuzz seeds, the deliberately broken files of the deploy
checks) and documentation are left out.

usage: check_spdx.py [--all] DIR
  --all  check every file of DIR that looks like a source (the self-test's broken inputs)
"""
import os
import re
import subprocess
import sys

TAG = "SPDX-License-Identifier: Apache-2.0"
SOURCE = re.compile(
    r"(\.(cpp|hpp|h|c|py|sh|cmake|in|service|rules|conf|toml|map|[1-8])|CMakeLists\.txt|"
    r"^scripts/[a-z-]+|^\.ci/run|^debian/rules|^debian/[a-z0-9.-]+\.(preinst|postinst|prerm|postrm))$")
LEFT_OUT = re.compile(r"^(tests/fuzz/corpus/|tests/deploy/bad/)")
# Directories that builds and packaging make inside the tree (build/, build-asan/, ...,
# debian/<package>/, debian/.debhelper/): not sources. `.git` neither.
BUILT = re.compile(r"^(build[^/]*|\.git|debian/\.debhelper|debian/tmp|debian/(drivebus[a-z-]*|libdrivebus[a-z0-9-]*|python3-drivebus))$")


def files_of(root, every):
    try:
        listed = subprocess.run(["git", "-C", root, "ls-files"], capture_output=True, text=True, check=True)
        names = listed.stdout.splitlines()
    except (OSError, subprocess.CalledProcessError):
        # No git (a release tarball): the tree on disk, less what builds put there.
        names = []
        for d, dirs, fs in os.walk(root):
            rel = os.path.relpath(d, root)
            dirs[:] = [x for x in dirs if not BUILT.match(x if rel == "." else os.path.join(rel, x))]
            names += [os.path.normpath(os.path.join(rel, f)) for f in fs]
    for name in sorted(names):
        if SOURCE.search(name) and (every or not LEFT_OUT.search(name)):
            yield name


def main(argv):
    every = "--all" in argv
    args = [a for a in argv if a != "--all"]
    if len(args) != 1:
        sys.exit(__doc__)
    root = args[0]
    checked, missing = 0, []
    for name in files_of(root, every):
        checked += 1
        with open(os.path.join(root, name), encoding="utf-8", errors="replace") as f:
            head = [f.readline() for _ in range(3)]
        if not any(TAG in line for line in head):
            missing.append(name)
    for name in missing:
        print(f"{name}: no '{TAG}' in its first three lines")
    if checked == 0:
        print("no source file found")
        return 1
    print(f"{checked} file(s) checked, {len(missing)} without the licence")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
