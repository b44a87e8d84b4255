# cli_signals.sh - SIGINT, SIGTERM and SIGHUP during a k = 6 combine and a `batch -j 2`, at points
# before and during the write (issue #34): whenever the signal lands, the program dies of it or has
# finished, leaves no temporary (OUT.tmpXXXXXX) and no worker behind, and an existing output is
# either its old content or a whole new file.  `batch --resume` and a batch whose worker was
# killed remove what a killed writer left; a temporary a live writer holds stays.
# Property checks: where a signal lands depends on the machine's speed, what must hold does not.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
ref=${BST_REFDIR:?}
blind=$ref/L_blind0_t4k5.xml
[ -f "$blind" ] || { echo "skipped: $blind not found"; exit 77; }
cd "$tmpdir" || exit 99

# no_temporaries WHAT: no *.tmp?????? in the current directory (those found are removed, so that
# one failure is not counted again by the checks after it)
no_temporaries() {
    local left
    left=$(ls -a | grep '\.tmp......$')
    [ -z "$left" ] && pass "$1: no temporary left" || { fail "$1: temporaries left: $left"; rm -f $left; }
}
# whole FILE WHAT: FILE is old.xml's copy or a complete BSDF file
whole() {
    if cmp -s "$1" old.xml || { tail -n 1 "$1" | grep -q '</WindowElement>' && "$B" info "$1" > /dev/null 2>&1; }; then
        pass "$2: $1 old or whole"
    else
        fail "$2: $1 damaged ($(wc -c < "$1") bytes)"
    fi
}
# wait_temporary PID: until a temporary appears or PID ends (polled every 10 ms)
wait_temporary() {
    local i
    for i in $(seq 3000); do
        ls -a | grep -q '\.tmp......$' && return 0
        kill -0 "$1" 2> /dev/null || return 1
        sleep 0.01
    done
}
# gone PID...: each has ended (waits up to 20 s: a worker finishes its cleanup)
gone() {
    local p i
    for p in "$@"; do
        for i in $(seq 200); do
            [ -z "$(ps -o stat= -p "$p" 2> /dev/null | grep -v Z)" ] && break
            sleep 0.1
        done
        [ -n "$(ps -o stat= -p "$p" 2> /dev/null | grep -v Z)" ] && return 1
    done
    return 0
}
# ended_by SIG STATUS WHAT: STATUS is death by SIG, or 0 (the command finished first)
ended_by() {
    local want=$((128 + $(kill -l "$1")))
    [ "$2" -eq "$want" ] || [ "$2" -eq 0 ] && pass "$3: exit $2" || fail "$3: exit $2, expected $want or 0"
}

"$B" combine -k 1 glass:clear-6mm -o old.xml 2> /dev/null || fail "the old output"

# --- combine at k = 6: a signal while combining (after 1 s) and one during the write
for sig in INT TERM HUP; do
    for at in compute write; do
        cp old.xml sys.xml
        # a background job's SIGINT is ignored unless reset (and a signal ignored at the start
        # stays ignored in bsdfstack)
        env --default-signal="$sig" "$B" combine -k 6 "$blind" glass:clear-6mm -o sys.xml 2> /dev/null &
        p=$!
        if [ "$at" = compute ]; then sleep 1; else wait_temporary "$p"; fi
        kill -s "$sig" "$p" 2> /dev/null
        wait "$p"
        ended_by "$sig" $? "combine, SIG$sig while it is at its $at"
        no_temporaries "combine, SIG$sig at $at"
        whole sys.xml "combine, SIG$sig at $at"
    done
done

# --- batch -j 2 (k = 5): the batch's PID gets the signal during a write; its workers pass on too
for i in 1 2 3 4 5 6 7 8; do echo "o$i.xml $blind glass:clear-6mm"; done > j.batch
for sig in INT TERM KILL; do
    rm -f o?.xml
    env --default-signal=INT "$B" batch -k 5 -j 2 j.batch > /dev/null 2>&1 &
    p=$!
    wait_temporary "$p"
    kids=$(ps -o pid= --ppid "$p")
    kill -s "$sig" "$p" 2> /dev/null
    wait "$p"
    ended_by "$sig" $? "batch -j 2, SIG$sig to its PID"
    # SIGKILL cannot be passed on: the workers get SIGTERM as their parent dies (PR_SET_PDEATHSIG)
    gone $kids && pass "batch -j 2, SIG$sig: no worker left" || fail "batch -j 2, SIG$sig: workers $kids alive"
    no_temporaries "batch -j 2, SIG$sig"
    for o in o?.xml; do [ -e "$o" ] && whole "$o" "batch -j 2, SIG$sig"; done
done

# --- a worker killed (SIGKILL, as for memory) during its write: the batch reports its stack and
# removes its temporary; the other stacks go on
rm -f o?.xml
"$B" batch -k 5 -j 2 j.batch > /dev/null 2> err &
p=$!
if wait_temporary "$p"; then
    kill -s KILL $(ps -o pid= --ppid "$p") 2> /dev/null
    wait "$p"
    st=$?
    { [ "$st" -eq 1 ] && grep -q "ended by signal 9" err; } || [ "$st" -eq 0 ] &&
        pass "a killed worker's stack is reported" || fail "killed worker: exit $st, $(cat err)"
else
    wait "$p"
fi
no_temporaries "killed workers"

# --- --resume removes what a killed writer left beside an output, not what a live one holds
rm -f o?.xml
: > o1.xml.tmpDEAD01
: > o2.xml.tmpLIVE01
flock o2.xml.tmpLIVE01 sleep 30 &
holder=$!
sleep 0.2
expect_status 0 "batch --resume" -- "$B" batch -k 1 --resume j.batch
[ ! -e o1.xml.tmpDEAD01 ] && pass "--resume removes a dead writer's temporary" || fail "o1.xml.tmpDEAD01 left"
[ -e o2.xml.tmpLIVE01 ] && pass "--resume keeps a live writer's temporary" || fail "o2.xml.tmpLIVE01 removed"
grep -q "removed 1 temporary" "$tmpdir/err" && pass "--resume says so" || fail "--resume stderr: $(cat "$tmpdir/err")"
kill "$holder" 2> /dev/null
wait "$holder" 2> /dev/null
rm -f o2.xml.tmpLIVE01
finish
