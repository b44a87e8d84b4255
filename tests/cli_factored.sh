# cli_factored.sh - layers held factored (issue #31) end to end: a depth-3 tree at k = 5 goes
# factored (-v says so, with its rank), writes the system --dense writes (compare: no
# directional-hemispherical difference, GA 100), with less memory; per channel and per
# wavelength alike; a reversed factored layer too; a matte venetian blind's stack written with one
# expanded component at a time.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK

expect_status 0 "a depth-3 TensorTree4" -- "$B" convert -k 3 --rank 4 --no-reduce -o "$tmpdir/d3.xml" \
    "$ref/L_blind0_t4k5.xml"
# the closing table of compare: every |hem A - hem B| 0.000000, every GA least 100.000
same() {
    awk '/^  comp  \|hem A - hem B\|/ {on = 1; next} on && NF >= 9 { n++; if ($2 + 0 > 1e-6 || $9 + 0 < 99.9995) bad++ }
         END { exit !(n == 4 && bad == 0) }' "$tmpdir/out"
}
for stack in "glass:clear-6mm $tmpdir/d3.xml glass:clear-6mm" "glass:nfrc-102 $tmpdir/d3.xml^ glass:nfrc-103"; do
    expect_status 0 "combine factored: $stack" -- "$B" combine -v -k 5 --no-reduce -o "$tmpdir/f.xml" $stack
    grep -q "layers 1-2 Visible Tf: factored rank 64" "$tmpdir/err" && pass "-v: factored, rank 64" ||
        fail "-v does not say factored: $(head -5 "$tmpdir/err")"
    f_peak=$(awk '/: combined, / { sub(/.*peak RSS /, ""); print $1 + 0 }' "$tmpdir/err")
    expect_status 0 "combine --dense" -- "$B" combine -v --dense -k 5 --no-reduce -o "$tmpdir/d.xml" $stack
    d_peak=$(awk '/: combined, / { sub(/.*peak RSS /, ""); print $1 + 0 }' "$tmpdir/err")
    expect_status 0 "compare" -- "$B" compare "$tmpdir/f.xml" "$tmpdir/d.xml"
    same && pass "the same system as --dense" || fail "factored and --dense differ: $(tail -6 "$tmpdir/out")"
    # the dense path holds the shade's four 1024 x 1024 components and the combination's work
    awk -v f="$f_peak" -v d="$d_peak" 'BEGIN { exit !(f > 0 && d > f + 40) }' &&
        pass "peak RSS while combining: factored $f_peak MiB, dense $d_peak MiB" ||
        fail "peak RSS: factored $f_peak MiB, dense $d_peak MiB"
done
# --rank3 native: a depth-3 TensorTree3 at k = 5 goes factored (rank 64) where exact makes it dense;
# a wrong value is one line naming the option, and nothing is written
expect_status 0 "a depth-3 TensorTree3" -- "$B" convert -k 3 --rank 3 --no-reduce -o "$tmpdir/i3.xml" \
    "$ref/L_diffuser_t3k5.xml"
expect_status 0 "combine --rank3 native" -- "$B" combine -v -k 5 --rank3 native -o "$tmpdir/n.xml" \
    glass:clear-6mm "$tmpdir/i3.xml" glass:clear-6mm
grep -q "layers 1-2 Visible Tf: factored rank 64" "$tmpdir/err" && pass "--rank3 native: factored, rank 64" ||
    fail "--rank3 native is not factored: $(head -5 "$tmpdir/err")"
expect_status 0 "combine --rank3 exact" -- "$B" combine -v -k 5 -o "$tmpdir/e.xml" \
    glass:clear-6mm "$tmpdir/i3.xml" glass:clear-6mm
grep -q "layers 1-2 Visible Tf: dense" "$tmpdir/err" && pass "--rank3 exact (default): dense" ||
    fail "the default is not the exact (dense) expansion: $(head -5 "$tmpdir/err")"
# a matte venetian blind's stack at k = 5 stays factored to the end: the writer expands one
# component of 1024^2 doubles (8 MiB) at a time, where a dense system of one channel holds four
# (32 MiB; the system here has two channels), so writing adds less than that to the peak of
# reading the layers (before the writer took one component at a time: 8 copies and more)
# (under make check-asan, AddressSanitizer's quarantine of freed memory, 256 MiB, would count as
# the program's: it is turned off for this run)
blind='venetian:width=16mm,spacing=14.5mm,tilt=45,r=0.7,t=0.05'
expect_status 0 "combine a matte blind factored" -- \
    env ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=0" \
    "$B" combine -v -k 5 -o "$tmpdir/v.xml" glass:clear-6mm "$blind" glass:clear-6mm
r_peak=$(awk '/: read 3 layers/ { sub(/.*peak RSS /, ""); print $1 + 0 }' "$tmpdir/err")
w_peak=$(awk '/: wrote / { sub(/.*peak RSS /, ""); print $1 + 0 }' "$tmpdir/err")
awk -v r="$r_peak" -v w="$w_peak" 'BEGIN { exit !(r > 0 && w > r && w - r < 32) }' &&
    pass "peak RSS: read $r_peak MiB, written $w_peak MiB (less than 4 components more)" ||
    fail "peak RSS: read $r_peak MiB, written $w_peak MiB: 4 expanded components or more"
# the blind samples each patch's reversed directions exactly reversed (venetian_layer.c), so its
# stack is reciprocal within the writer's 1e-6 and is written as genBSDF writes it: Tb of each
# channel, no Tf (read back from Tb; before: both, the blind 2e-3 off reciprocity)
[ "$(grep -c '<WavelengthDataDirection>Transmission Front<' "$tmpdir/v.xml")" = 0 ] &&
    [ "$(grep -c '<WavelengthDataDirection>Transmission Back<' "$tmpdir/v.xml")" = 2 ] &&
    pass "the matte blind's stack: Tb written, Tf left to reciprocity" ||
    fail "the matte blind's stack: Tf written beside Tb ($(grep -c WavelengthDataDirection "$tmpdir/v.xml") blocks)"
rm -f "$tmpdir/x.xml"
expect_status 2 "--rank3 foo" -- "$B" combine --rank3 foo -o "$tmpdir/x.xml" glass:clear-6mm "$tmpdir/i3.xml"
[ "$(wc -l < "$tmpdir/err")" -le 2 ] && grep -q -- "--rank3 foo" "$tmpdir/err" && [ ! -e "$tmpdir/x.xml" ] &&
    pass "--rank3 foo: one line naming it, nothing written" || fail "--rank3 foo: $(cat "$tmpdir/err")"
finish
