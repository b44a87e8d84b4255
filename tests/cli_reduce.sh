# cli_reduce.sh - the bounded tree reduction end to end (issue #30): combine, batch and convert
# write files whose hemispherical T and R stay within --reduce-tol of the unreduced file's, as
# `compare --fail-hem` and `info --reference` report it; the percentile alone does not, and
# compare says so; bad values are refused in one line with no file written.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
stack="glass:clear-6mm $ref/L_diffuser_t3k5.xml glass:clear-6mm"

# the shipped example's stack at k = 4: default, unreduced, and the percentile alone
# shellcheck disable=SC2086 # $stack: three layer specs
expect_status 0 "combine, default reduction" -- "$BSDFSTACK" combine -k 4 -o "$tmpdir/d.xml" $stack
# shellcheck disable=SC2086
expect_status 0 "combine --no-reduce" -- "$BSDFSTACK" combine -k 4 --no-reduce -o "$tmpdir/x.xml" $stack
# shellcheck disable=SC2086
expect_status 0 "combine --reduce-tol none" -- "$BSDFSTACK" combine -k 4 --reduce-tol none -o "$tmpdir/n.xml" $stack
grep -q "stay within 0.002 of the unreduced values" "$tmpdir/d.xml" || fail "the file's header states the tolerance"
grep -q "no bound on hemispherical values" "$tmpdir/n.xml" || fail "the header says when there is no bound"

expect_status 0 "compare --fail-hem 0.002: default against unreduced" -- \
    "$BSDFSTACK" compare -k 4 --fail-hem 0.002 "$tmpdir/x.xml" "$tmpdir/d.xml"
# the closing table: four components, each within 0.002, FA printed
awk '/^Over every incident patch/ { t = 1; next } t && $1 ~ /^[TR][fb]$/ { n++; if ($2 > 0.002 || $2 < 0) bad = 1; if ($8 !~ /^[0-9.]+$/) bad = 1 }
     END { exit !(n == 4 && !bad) }' "$tmpdir/out" && pass "compare's closing table: four components within 0.002" \
    || fail "compare's closing table: $(cat "$tmpdir/out" | tail -6)"
expect_error "compare --fail-hem 0.002: the percentile alone exceeds it" 'Tf: the hemispherical values differ by 0\.0[1-9][0-9]* at patch [0-9]+, more than 0\.002' -- \
    "$BSDFSTACK" compare -k 4 --fail-hem 0.002 "$tmpdir/x.xml" "$tmpdir/n.xml"

# info --reference: the same numbers per channel and component
expect_status 0 "info --reference" -- "$BSDFSTACK" info --reference "$tmpdir/x.xml" "$tmpdir/d.xml"
awk '/^against/ { t = 1; next } t && $1 ~ /^[TR][fb]$/ { n++; if ($2 > 0.002) bad = 1 } END { exit !(n == 4 && !bad) }' "$tmpdir/out" \
    && pass "info --reference: four components within 0.002" || fail "info --reference: $(tail -6 "$tmpdir/out")"
expect_status 0 "info --reference, the percentile alone" -- "$BSDFSTACK" info --reference "$tmpdir/x.xml" "$tmpdir/n.xml"
awk '/^against/ { t = 1; next } t && $1 == "Tf" && $2 > 0.01 { f = 1 } END { exit !f }' "$tmpdir/out" \
    && pass "info --reference shows the percentile alone's change" || fail "info --reference (none): $(tail -6 "$tmpdir/out")"
expect_error "info --reference to a missing file" 'info: .*missing\.xml: cannot open' -- \
    "$BSDFSTACK" info --reference "$tmpdir/missing.xml" "$tmpdir/d.xml"

# convert at a looser tolerance: within it, and smaller than the default
expect_status 0 "convert --reduce-tol 0.01" -- "$BSDFSTACK" convert --reduce-tol 0.01 -o "$tmpdir/c.xml" "$tmpdir/x.xml"
expect_status 0 "convert's file within 0.01" -- "$BSDFSTACK" compare --fail-hem 0.01 "$tmpdir/x.xml" "$tmpdir/c.xml"
[ "$(stat -c %s "$tmpdir/c.xml")" -lt "$(stat -c %s "$tmpdir/d.xml")" ] && pass "a looser tolerance writes less" \
    || fail "0.01: $(stat -c %s "$tmpdir/c.xml") bytes, 0.002: $(stat -c %s "$tmpdir/d.xml")"
expect_status 0 "convert --digits exact (reduced)" -- "$BSDFSTACK" convert --digits exact -o "$tmpdir/e.xml" "$tmpdir/x.xml"
expect_status 0 "its file within 0.002" -- "$BSDFSTACK" compare --fail-hem 0.002 "$tmpdir/x.xml" "$tmpdir/e.xml"
[ "$(stat -c %s "$tmpdir/e.xml")" -gt "$(stat -c %s "$tmpdir/d.xml")" ] && pass "exact digits write more than five" \
    || fail "exact: $(stat -c %s "$tmpdir/e.xml") bytes, five digits: $(stat -c %s "$tmpdir/d.xml")"

# a tolerance too tight for five digits: combine (which has no --digits) writes as many as it
# needs, and the file keeps it (five digits moved a total by 1.3e-5 here before)
# shellcheck disable=SC2086
expect_status 0 "combine --reduce-tol 0.000005" -- "$BSDFSTACK" combine -k 4 --reduce-tol 0.000005 -o "$tmpdir/t.xml" $stack
expect_status 0 "its file within 0.000005" -- "$BSDFSTACK" compare --fail-hem 0.000005 "$tmpdir/x.xml" "$tmpdir/t.xml"

# batch takes the option too
printf '%s %s\n' "$tmpdir/b.xml" "$stack" > "$tmpdir/batch.txt"
expect_status 0 "batch --reduce-tol 0.005" -- "$BSDFSTACK" batch -k 4 --reduce-tol 0.005 "$tmpdir/batch.txt"
expect_status 0 "batch's file within 0.005" -- "$BSDFSTACK" compare --fail-hem 0.005 "$tmpdir/x.xml" "$tmpdir/b.xml"
grep -q "stay within 0.005 of the unreduced values" "$tmpdir/b.xml" || fail "batch's header states its tolerance"

# bad values: one line, nothing written
for bad in -1 abc nan inf 1e400; do
    # shellcheck disable=SC2086
    expect_error "combine --reduce-tol $bad" "reduce-tol $bad: a directional-hemispherical change >= 0" -- \
        "$BSDFSTACK" combine -k 2 --reduce-tol "$bad" -o "$tmpdir/bad.xml" $stack
    [ -e "$tmpdir/bad.xml" ] && fail "combine --reduce-tol $bad left a file"
    expect_error "convert --reduce-tol $bad" "reduce-tol $bad" -- \
        "$BSDFSTACK" convert --reduce-tol "$bad" -o "$tmpdir/bad.xml" "$tmpdir/x.xml"
done
expect_error "convert --digits 0" "digits 0: use 1 to 17, or exact" -- \
    "$BSDFSTACK" convert --digits 0 -o "$tmpdir/bad.xml" "$tmpdir/x.xml"
expect_error "compare --fail-hem -1" "fail-hem -1" -- "$BSDFSTACK" compare --fail-hem -1 "$tmpdir/x.xml" "$tmpdir/d.xml"
[ -e "$tmpdir/bad.xml" ] && fail "a refused command left a file"
finish
