#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# shellcheck disable=SC2317  # stop_sim, finish and show_sim_log run from the EXIT trap
# Runs one peer (an independent Modbus master) against a fresh drivebus-sim.
#
#   sim_harness.sh SIM_BINARY PEER_COMMAND [ARGS...]
#
# Starts SIM_BINARY in a new temporary directory with an Altivar 21 at address 1 and an
# Altivar 58 at address 2 (19200 8N1), waits (with a deadline) for its pty link and control
# socket, then runs the peer with these variables in its environment:
#   SIM_LINK     the tty a master opens
#   SIM_CONTROL  the simulator's control socket
#   SIM_DIR      the temporary directory (removed afterwards)
# The simulator is always stopped (SIGTERM) on the way out, and must exit with status 0.
# Exit status: the peer's when it failed, 1 when the simulator misbehaved, 77 (skip) when
# the peer exits 77 (a tool it needs is missing), 0 otherwise.
set -uo pipefail

readonly start_deadline_s=10   # for the link and control socket to appear
readonly stop_deadline_s=5     # for the simulator to exit after SIGTERM
readonly peer_deadline_s=${PEER_TIMEOUT:-45}

if (($# < 2)); then
    echo "usage: sim_harness.sh SIM_BINARY PEER_COMMAND [ARGS...]" >&2
    exit 2
fi
sim=$1
shift
if [[ ! -x $sim ]]; then
    echo "sim_harness: simulator '$sim' is not an executable file (build the drivebus-sim target)" >&2
    exit 1
fi

dir=$(mktemp -d "${TMPDIR:-/tmp}/drivebus-peers-XXXXXX") || exit 1
link=$dir/tty
control=$dir/ctl
log=$dir/sim.log
sim_pid=
peer_status=0
sim_failed=0

log_says() { echo "sim_harness: $*" >&2; }

show_sim_log() {
    [[ -s $log ]] && sed 's/^/  sim| /' "$log" >&2
}

# Stops the simulator (if it is running) and checks that it exits 0 within the deadline.
stop_sim() {
    [[ -n $sim_pid ]] || return 0
    local pid=$sim_pid status
    sim_pid=
    if kill -0 "$pid" 2>/dev/null; then
        kill -TERM "$pid" 2>/dev/null
        local deadline=$((SECONDS + stop_deadline_s))
        while kill -0 "$pid" 2>/dev/null && ((SECONDS < deadline)); do
            sleep 0.02
        done
        if kill -0 "$pid" 2>/dev/null; then
            log_says "FAIL: the simulator (pid $pid) did not stop within ${stop_deadline_s} s of SIGTERM; killing it"
            kill -KILL "$pid" 2>/dev/null
            wait "$pid" 2>/dev/null
            sim_failed=1
            return
        fi
    fi
    wait "$pid"
    status=$?
    if ((status != 0)); then
        log_says "FAIL: the simulator exited with status $status (expected 0)"
        sim_failed=1
    elif ! grep -q 'drivebus-sim: stopped;' "$log"; then
        log_says "FAIL: the simulator exited 0 without its 'stopped;' line"
        sim_failed=1
    fi
}

finish() {
    local status=$?
    trap - EXIT INT TERM
    stop_sim
    if ((sim_failed)) || ((peer_status != 0 && peer_status != 77)); then
        show_sim_log
    fi
    rm -rf "$dir"
    if ((peer_status != 0 && peer_status != 77)); then
        exit "$peer_status"
    fi
    if ((sim_failed)); then
        exit 1
    fi
    if ((peer_status == 77)); then
        exit 77
    fi
    exit "$status"
}
trap finish EXIT
trap 'log_says "interrupted"; peer_status=130; exit 130' INT TERM

# The simulator dies with the harness even if the harness is killed outright.
launcher=()
if setpriv --help 2>/dev/null | grep -q -- --pdeathsig; then
    launcher=(setpriv --pdeathsig TERM --)
fi
"${launcher[@]}" "$sim" --link "$link" --drive 1:atv21 --drive 2:atv58 --control "$control" \
    --parity none >"$log" 2>&1 &
sim_pid=$!

deadline=$((SECONDS + start_deadline_s))
until [[ -L $link && -e $link && -S $control ]]; do
    if ! kill -0 "$sim_pid" 2>/dev/null; then
        wait "$sim_pid"
        log_says "FAIL: the simulator exited (status $?) before it was ready"
        sim_pid=
        sim_failed=1
        exit 1
    fi
    if ((SECONDS >= deadline)); then
        log_says "FAIL: no link $link and control socket $control within ${start_deadline_s} s"
        sim_failed=1
        exit 1
    fi
    sleep 0.02
done

export SIM_LINK=$link SIM_CONTROL=$control SIM_DIR=$dir
timeout --kill-after=2 "$peer_deadline_s" "$@"
peer_status=$?
case $peer_status in
    0) ;;
    77) log_says "peer skipped: $*" ;;
    124 | 137) log_says "FAIL: the peer did not finish within ${peer_deadline_s} s: $*" ;;
    *) log_says "FAIL: the peer exited with status $peer_status: $*" ;;
esac
exit "$peer_status"
