# cli_batch.sh - the C batch example (examples/batch.c) runs 16 stacks and gets physical results.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
batch=$(dirname "$BSDFSTACK")/examples/batch
expect_status 0 "batch example" -- "$batch" "$BST_SRCDIR/examples/layers/diffuser_t3k5.xml" 3
[ "$(sed 1d "$tmpdir/out" | wc -l)" -eq 16 ] && pass "16 stacks" || fail "batch output: $(cat "$tmpdir/out")"
# a low-iron exterior pane lets more through than a 4 mm clear one, for the same interior pane
awk -F'\t' '$1 == "clear-4mm" && $2 == "clear-4mm" { a = $3 } $1 == "lowiron-6mm" && $2 == "clear-4mm" { b = $3 }
            END { exit !(b > a) }' "$tmpdir/out" && pass "low-iron transmits more" || fail "ordering: $(cat "$tmpdir/out")"
expect_error "missing shade" "cannot open" -- "$batch" "$tmpdir/none.xml"
finish
