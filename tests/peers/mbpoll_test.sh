#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# mbpoll, an independent Modbus RTU master (libmodbus), against drivebus-sim: an Altivar 21 at
# address 1 and an Altivar 58 at address 2, 19200 8N1. Run through sim_harness.sh, which
# provides SIM_LINK (the tty) and SIM_CONTROL (the control socket, reached with socat).
# Every case compares what mbpoll printed with the expected values; the exit status is the
# 1 when a check failed, 77 when a tool is missing (ctest counts that as a failure too).
set -uo pipefail

for tool in mbpoll socat; do
    if ! command -v "$tool" >/dev/null; then
        echo "mbpoll_test: SKIP: $tool is not installed (scripts/setup installs it)"
        exit 77
    fi
done
if [[ -z ${SIM_LINK:-} || -z ${SIM_CONTROL:-} ]]; then
    echo "mbpoll_test: SIM_LINK and SIM_CONTROL must be set (run it through sim_harness.sh)" >&2
    exit 2
fi

checks=0
failures=0
requests_sent=0      # Modbus requests mbpoll sent (one per run: -1, no retries)
exceptions_expected=0
case_name=setup

fail() {
    echo "FAIL [$case_name]: $*" >&2
    checks=$((checks + 1))
    failures=$((failures + 1))
}
pass() { checks=$((checks + 1)); }

# expect_eq WHAT ACTUAL EXPECTED
expect_eq() {
    if [[ $2 == "$3" ]]; then
        pass
    else
        fail "$1: got '$2', expected '$3'"
    fi
}

# ctl COMMAND...: one control command; the answer without its "ok" goes to CTL (0), else fails (1).
ctl() {
    local answer
    answer=$(printf '%s\n' "$*" | socat -t 2 -T 5 - "UNIX-CONNECT:$SIM_CONTROL" 2>&1)
    if [[ $answer == ok || $answer == "ok "* ]]; then
        CTL=${answer#ok}
        CTL=${CTL# }
        return 0
    fi
    fail "control command '$*' answered '$answer'"
    CTL=
    return 1
}

# ctl_get ADDR REG: the register's value as the simulator holds it, in CTL.
ctl_get() { ctl get "$1" "$2"; }

# counter NAME: the counter NAME from the last `stats` answer (in CTL).
counter() { sed -n "s/.*\\b$1=\\([0-9]\\+\\).*/\\1/p" <<<"$CTL"; }

# mb ARGS... [-- VALUES...]: one mbpoll run; output (stdout and stderr) in MB_OUT, status in MB_RC.
mb() {
    local options=() values=()
    while (($#)) && [[ $1 != -- ]]; do
        options+=("$1")
        shift
    done
    (($#)) && shift
    values=("$@")
    MB_OUT=$(mbpoll -m rtu -b 19200 -d 8 -s 1 -P none -0 -1 -o 1 "${options[@]}" "$SIM_LINK" "${values[@]}" 2>&1)
    MB_RC=$?
    requests_sent=$((requests_sent + 1))
}

# What matters in mbpoll's output (its error message comes first: stderr is not buffered).
mb_tail() {
    local lines
    lines=$(grep -E 'failed|[Ee]rror|[Tt]imed out|^\[[0-9]+\]:|^Written' <<<"$MB_OUT")
    [[ -n $lines ]] || lines=$(grep -v '^$' <<<"$MB_OUT" | tail -n 3)
    tr '\n' '|' <<<"$lines"
}

# mb_read ADDR REF COUNT: FC03; the values (unsigned, in order) in MB_VALUES. Fails and
# returns 1 when mbpoll fails or prints other references or another number of values.
mb_read() {
    local addr=$1 ref=$(($2)) count=$3 r v next
    MB_VALUES=()
    mb -a "$addr" -r "$ref" -c "$count" -t 4
    if ((MB_RC != 0)); then
        fail "mbpoll FC03 slave $addr ref $ref x$count exited $MB_RC: $(mb_tail)"
        return 1
    fi
    next=$ref
    while read -r r v; do
        if ((r != next)); then
            fail "mbpoll FC03 slave $addr ref $ref x$count: value for reference $r where $next was expected"
            return 1
        fi
        MB_VALUES+=("$v")
        next=$((next + 1))
    done < <(sed -n 's/^\[\([0-9]\+\)\]:[[:space:]]*\([0-9]\+\).*/\1 \2/p' <<<"$MB_OUT")
    if ((${#MB_VALUES[@]} != count)); then
        fail "mbpoll FC03 slave $addr ref $ref x$count printed ${#MB_VALUES[@]} values, expected $count: $(mb_tail)"
        return 1
    fi
    pass
}

# mb_write ADDR REF VALUE: FC06 (mbpoll writes a single value with FC06).
mb_write() {
    local addr=$1 ref=$(($2)) value=$3
    mb -a "$addr" -r "$ref" -t 4 -- "$value"
    if ((MB_RC != 0)) || ! grep -q '^Written 1 references' <<<"$MB_OUT"; then
        fail "mbpoll FC06 slave $addr ref $ref = $value: status $MB_RC, output: $(mb_tail)"
        return 1
    fi
    pass
}

# expect_exception TEXT CODE MBPOLL-ARGS...: the request must fail with that exception message.
expect_exception() {
    local text=$1 code=$2
    shift 2
    mb "$@"
    exceptions_expected=$((exceptions_expected + 1))
    if ((MB_RC == 0)); then
        fail "expected exception $code ($text), but mbpoll exited 0: $(mb_tail)"
    elif ! grep -q "failed: $text\$" <<<"$MB_OUT"; then
        fail "expected exception $code ('$text') in mbpoll's output, status $MB_RC: $(mb_tail)"
    elif grep -q '^\[[0-9]\+\]:' <<<"$MB_OUT"; then
        fail "mbpoll reported exception $code but also printed values: $(mb_tail)"
    else
        pass
    fi
}

# ---- setup -----------------------------------------------------------------------------------
# No Modbus time-out on the Altivar 21 (F803 = 0): its status must not change to a fault
# between two reads of this test.
ctl set 1 F803 0
# Distinct values in W450..W459 of the Altivar 58 (some above 32767: read unsigned).
w45x=()
for i in {0..9}; do
    w45x+=($((450 + i * 7001)))
    ctl set 2 "W45$i" "${w45x[i]}"
done
ctl set 1 FA01 0
ctl stats
requests_before=$(counter requests)
replies_before=$(counter replies)
exceptions_before=$(counter exceptions)
broken_before=$(counter broken)
if [[ -z $requests_before || -z $replies_before || -z $exceptions_before || -z $broken_before ]]; then
    fail "cannot read the counters in '$CTL'"
fi

# ---- ATV21: FD00 and FD01 ----------------------------------------------------------------------
case_name="ATV21 read FD00"
if mb_read 1 0xFD00 1; then
    ctl_get 1 FD00 && expect_eq "FD00 (output frequency) read by mbpoll vs the simulator's" "${MB_VALUES[0]}" "$CTL"
fi

case_name="ATV21 read FD01"
if mb_read 1 0xFD01 1; then
    ctl_get 1 FD01 && expect_eq "FD01 (status) read by mbpoll vs the simulator's" "${MB_VALUES[0]}" "$CTL"
fi

# ---- ATV21: FC06 FA01 = 6000 and read back ----------------------------------------------------
case_name="ATV21 FC06 FA01=6000"
if mb_write 1 0xFA01 6000; then
    mb_read 1 0xFA01 1 && expect_eq "FA01 read back" "${MB_VALUES[0]}" 6000
    ctl_get 1 FA01 && expect_eq "FA01 in the simulator" "$CTL" 6000
fi

# ---- ATV21: read indirect block ----------------------------------------------------------------
case_name="ATV21 indirect block 0x1875 x5, in effect after a power cycle"
for i in 1 2 3 4 5; do
    reg=$((0x0874 + i))
    if mb_write 1 "$reg" "$i"; then
        ctl_get 1 "F87$((4 + i))" && expect_eq "F87$((4 + i)) after the FC06 write" "$CTL" "$i"
    fi
done
# F875-F879 take effect after a reset (guide section 6): until then the block selects nothing.
if mb_read 1 0x1875 5; then
    expect_eq "block before a reset" "${MB_VALUES[*]}" "0 0 0 0 0"
fi
ctl power 1
fd00='' fd01=''
mb_read 1 0xFD00 1 && fd00=${MB_VALUES[0]}
mb_read 1 0xFD01 1 && fd01=${MB_VALUES[0]}
if mb_read 1 0x1875 5; then
    block=("${MB_VALUES[@]}")
    expect_eq "block word 1 (F875=1: FD01) vs FD01 read alone" "${block[0]}" "$fd01"
    expect_eq "block word 2 (F876=2: FD00) vs FD00 read alone" "${block[1]}" "$fd00"
    ctl_get 1 FE03 && expect_eq "block word 3 (F877=3: FE03)" "${block[2]}" "$CTL"
    ctl_get 1 FE05 && expect_eq "block word 4 (F878=4: FE05)" "${block[3]}" "$CTL"
    ctl_get 1 FC91 && expect_eq "block word 5 (F879=5: FC91)" "${block[4]}" "$CTL"
fi

# ---- ATV21: exceptions -------------------------------------------------------------------------
case_name="ATV21 FC03 FD00 x2 -> exception 3"
expect_exception "Illegal data value" 3 -a 1 -r $((0xFD00)) -c 2 -t 4

case_name="ATV21 FC06 0xFFFF -> exception 2"
expect_exception "Illegal data address" 2 -a 1 -r $((0xFFFF)) -t 4 -- 0

# ---- ATV58 -------------------------------------------------------------------------------------
case_name="ATV58 read W450..W459"
if mb_read 2 450 10; then
    expect_eq "W450..W459" "${MB_VALUES[*]}" "${w45x[*]}"
fi

case_name="ATV58 FC03 x33 -> exception 3"
expect_exception "Illegal data value" 3 -a 2 -r 450 -c 33 -t 4

# ---- the simulator's counters ------------------------------------------------------------------
case_name="control stats"
if ctl stats; then
    expect_eq "requests counted" "$(counter requests)" $((requests_before + requests_sent))
    expect_eq "replies counted" "$(counter replies)" $((replies_before + requests_sent))
    expect_eq "exception replies counted" "$(counter exceptions)" $((exceptions_before + exceptions_expected))
    expect_eq "broken frames counted" "$(counter broken)" "$broken_before"
fi

echo "mbpoll_test: $((checks - failures))/$checks checks passed, $failures failed ($requests_sent Modbus requests)"
((failures == 0)) || exit 1
