# clitest.sh - sourced by the CLI test scripts: runs the real program and checks its behaviour.
# $BSDFSTACK is the program, $BST_REFDIR the reference data, $BST_SRCDIR the source tree.
set -u
: "${BSDFSTACK:?BSDFSTACK must name the bsdfstack program}"
fails=0
tmpdir=$(mktemp -d) || exit 99
trap 'rm -rf "$tmpdir"' EXIT

fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
pass() { echo "ok: $*"; }

# expect_status CODE DESCRIPTION -- COMMAND...: runs COMMAND, stderr to $tmpdir/err.
expect_status() {
    local want=$1 what=$2; shift 3
    "$@" >"$tmpdir/out" 2>"$tmpdir/err"
    local got=$?
    if [ "$got" -eq "$want" ]; then pass "$what"; else
        fail "$what: exit $got, expected $want; stderr: $(head -c 300 "$tmpdir/err")"; fi
}

# expect_one_line_error DESCRIPTION PATTERN -- COMMAND...: non-zero exit, exactly one stderr line
# (a usage error may add the "Try ... --help" line), matching PATTERN (grep -E).
expect_error() {
    local what=$1 pat=$2; shift 3
    "$@" >"$tmpdir/out" 2>"$tmpdir/err"
    local got=$?
    local lines
    lines=$(grep -vc "^Try 'bsdfstack" "$tmpdir/err")
    if [ "$got" -eq 0 ]; then fail "$what: exit 0, expected failure"
    elif [ "$lines" -ne 1 ]; then fail "$what: $lines error lines: $(cat "$tmpdir/err")"
    elif ! grep -Eq -- "$pat" "$tmpdir/err"; then fail "$what: message '$(cat "$tmpdir/err")' lacks /$pat/"
    else pass "$what"; fi
}

finish() {
    if [ "$fails" -ne 0 ]; then echo "$fails check(s) failed"; exit 1; fi
    exit 0
}
