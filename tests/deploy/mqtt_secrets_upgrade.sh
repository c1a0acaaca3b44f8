#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# debian/drivebus-mqtt.postinst on an upgrade from an installation that gave the bridge's
# secrets root:drivebus: run as dpkg would ("configure OLD-VERSION") against a root of its own
# (DPKG_ROOT) in a mount namespace whose /etc/group has the groups drivebus and drivebus-mqtt.
# Only the files mqtt.toml names as password_file or keyfile, root:drivebus with a group
# permission, change group; the rest is left as it was. Exit 77 (skipped) without root or
# unshare.
#   mqtt_secrets_upgrade.sh POSTINST
set -eu
postinst=$(realpath "$1")
[ "$(id -u)" = 0 ] || { echo "skipped: needs root (chgrp, a mount namespace)"; exit 77; }
command -v unshare >/dev/null || { echo "skipped: no unshare"; exit 77; }
unshare --mount true 2>/dev/null || { echo "skipped: no mount namespace here"; exit 77; }

work=$(mktemp -d "${TMPDIR:-/tmp}/drivebus-mqtt-upgrade.XXXXXX")
trap 'rm -rf "$work"' EXIT
# Two group numbers this system does not use.
free_gid() {
    g=$1
    while getent group "$g" >/dev/null || grep -q "^[^:]*:[^:]*:$g:" "$work/group" 2>/dev/null; do g=$((g + 1)); done
    echo "$g"
}
cp /etc/group "$work/group"
watchers=$(free_gid 64100)
echo "drivebus:x:$watchers:drivebus-gateway,alice" >>"$work/group"
own=$(free_gid 64100)
echo "drivebus-mqtt:x:$own:drivebus-mqtt" >>"$work/group"

etc=$work/root/etc/drivebus
mkdir -p "$etc"
cat >"$etc/mqtt.toml" <<TOML
node = "board-7"
[broker]
username = "board-7"
password_file = "/etc/drivebus/mqtt.password"
[broker.tls]
cafile = "/etc/drivebus/mqtt-ca.pem"
certfile = "/etc/drivebus/board-7.pem"
  keyfile='/etc/drivebus/board-7.key'
[[bus]]
name = "line1"
# keyfile = "/etc/drivebus/commented.key"
TOML
make() {  # name mode gid
    echo secret >"$etc/$1"
    chown "0:$3" "$etc/$1"
    chmod "$2" "$etc/$1"
}
make mqtt.password 0640 "$watchers"   # named, group-readable: moves
make board-7.key 0600 "$watchers"     # named, no group permission: stays
make mqtt-ca.pem 0644 "$watchers"     # a certificate, not a secret: stays
make board-7.pem 0644 "$watchers"
make commented.key 0640 "$watchers"   # named only in a comment: stays
make other.password 0640 "$watchers"  # not named: stays

out=$(DPKG_ROOT="$work/root" unshare --mount --propagation private \
    sh -c 'mount --bind "$1" /etc/group && sh "$2" configure 0.9.0' sh "$work/group" "$postinst" 2>&1) || {
    echo "FAIL: the postinst exited $?: $out"
    exit 1
}
echo "$out"

failed=0
expect() {  # name gid mode
    got=$(stat -c '%g %a' "$etc/$1")
    if [ "$got" = "$2 $3" ]; then
        echo "ok: $1: group $2, mode $3"
    else
        echo "FAIL: $1: group and mode $got, expected $2 $3"
        failed=1
    fi
}
expect mqtt.password "$own" 640
expect board-7.key "$watchers" 600
expect mqtt-ca.pem "$watchers" 644
expect board-7.pem "$watchers" 644
expect commented.key "$watchers" 640
expect other.password "$watchers" 640
case $out in
*"$etc/mqtt.password: group drivebus-mqtt, no longer drivebus"*) echo "ok: the change is said" ;;
*) echo "FAIL: the postinst did not say what it changed"; failed=1 ;;
esac

# Run again (dpkg-reconfigure, the next upgrade): nothing left to change, nothing said.
again=$(DPKG_ROOT="$work/root" unshare --mount --propagation private \
    sh -c 'mount --bind "$1" /etc/group && sh "$2" configure 0.9.1' sh "$work/group" "$postinst" 2>&1)
if [ -n "$again" ]; then
    echo "FAIL: the second run said: $again"
    failed=1
fi
expect mqtt.password "$own" 640

# No configuration, or no group drivebus-mqtt yet: nothing done, exit 0.
rm "$etc/mqtt.toml"
DPKG_ROOT="$work/root" sh "$postinst" configure 0.9.0 || { echo "FAIL: exit $? without mqtt.toml"; failed=1; }
exit $failed
