# cli_robust.sh - bad input and a hostile environment (issue #18): what output paths name (devices,
# FIFOs, symbolic links, directories, a file's mode), write errors on files and on standard output,
# read errors on standard input, query's angle range, and short messages for absurd values.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK
d=$tmpdir/o
mkdir "$d" || exit 99
umask 022

# helpers for expect_status/expect_error, which redirect stdout themselves: a command ...
to_full() { "$@" > /dev/full; }                          # ... writing to a full device
from() { local f=$1; shift; "$@" < "$f"; }               # ... reading FILE
stdin_closed() { "$@" <&-; }                             # ... with no standard input
stdout_closed() { "$@" >&-; }                            # ... with no standard output
fsize_limited() ( trap '' XFSZ; ulimit -f 1; "$@" )      # ... whose files stop at 1 KiB (EFBIG)
# no_leftovers DESCRIPTION: no temporary is left in $d
no_leftovers() {
    if ls "$d" | grep -q '\.tmp'; then fail "$1: temporaries left: $(ls "$d")"; else pass "$1"; fi
}

# a cheap output: a clear pane at k = 1 (4 patches)
pane() { "$B" combine -k 1 "$@" glass:clear-6mm; }

expect_status 0 "a plain output file" -- pane -o "$d/a.xml"
f=$d/a.xml

# --- query --degrees: theta within [0, 90]
for bad in "91 0 0 0" "-1 0 0 0" "0 0 90.5 0" "0 0 -0.1 0"; do
    echo "$bad" > "$d/angles"
    expect_error "query --degrees '$bad'" "line 1: theta .* out of range.*\[0, 90\]" -- \
        from "$d/angles" "$B" query --degrees Tf "$f"
done
printf '0 0 0 0\n90 0 90 0\n' > "$d/angles"
expect_status 0 "query --degrees at 0 and 90" -- from "$d/angles" "$B" query --degrees Tf "$f"

# --- an absurd value gives a short warning, not 300 digits
sed '0,/<ScatteringData>/!{0,/^0 /s/^0 /1e300 /}' "$ref/examples/klems_TF.xml" > "$d/huge.xml"
grep -q '^1e300 ' "$d/huge.xml" || fail "the huge test file lacks its 1e300"
expect_status 0 "combine a layer holding 1e300" -- "$B" combine -o "$d/hc.xml" "$d/huge.xml"
line=$(grep 'T + R' "$tmpdir/err")
[ -n "$line" ] && [ "${#line}" -lt 200 ] && echo "$line" | grep -Eq 'T \+ R = [0-9.]+e\+[0-9]+ > 1' \
    && pass "the energy warning is short: $line" || fail "energy warning: $(head -c 300 "$tmpdir/err")"
expect_status 0 "info on a layer holding 1e300" -- "$B" info "$d/huge.xml"
[ "$(awk '!/^file/ { if (length($0) > m) m = length($0) } END { print m }' "$tmpdir/out")" -lt 100 ] \
    && grep -Eq 'largest T \+ R = [0-9.]+e\+[0-9]+' "$tmpdir/out" && pass "info prints 1e300 briefly" \
    || fail "info: $(head -c 300 "$tmpdir/out")"
finish
