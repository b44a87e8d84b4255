# cli_batch.sh - many stacks: the C batch example (examples/batch.c) runs 16 stacks and gets physical
# results; `bsdfstack batch` writes what `combine` writes for each line, checks everything first,
# and reports a failing line by number while the others go on.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
batch=$(dirname "$BSDFSTACK")/examples/batch
expect_status 0 "batch example" -- "$batch" "$BST_SRCDIR/examples/layers/diffuser_t3k5.xml" 3
[ "$(sed 1d "$tmpdir/out" | wc -l)" -eq 16 ] && pass "16 stacks" || fail "batch output: $(cat "$tmpdir/out")"
# a low-iron exterior pane lets more through than a 4 mm clear one, for the same interior pane
awk -F'\t' '$1 == "clear-4mm" && $2 == "clear-4mm" { a = $3 } $1 == "lowiron-6mm" && $2 == "clear-4mm" { b = $3 }
            END { exit !(b > a) }' "$tmpdir/out" && pass "low-iron transmits more" || fail "ordering: $(cat "$tmpdir/out")"
expect_error "missing shade" "cannot open" -- "$batch" "$tmpdir/none.xml"

B=$BSDFSTACK
ref=${BST_REFDIR:?}
cd "$tmpdir" || exit 99
cat > stacks.txt <<EOT
# pane + diffuser + pane, two pane pairs, and a spectral double glazing
a.xml glass:clear-6mm $BST_SRCDIR/examples/layers/diffuser_t3k5.xml glass:clear-6mm

b.xml glass:lowiron-6mm $BST_SRCDIR/examples/layers/diffuser_t3k5.xml glass:clear-6mm
c.xml glass:nfrc-102 glass:nfrc-103
EOT
expect_status 0 "batch of three stacks" -- "$B" batch -k 3 stacks.txt
[ "$(grep -c '^[abc]\.xml	T 0\.[0-9]*	R 0\.[0-9]*	' out)" -eq 3 ] && pass "one summary line per stack" || fail "summary: $(cat out)"
grep -q "batch: stacks.txt line 4" b.xml && pass "metadata names the batch line" || fail "metadata of b.xml"
# each output is what combine writes for the same stack
for x in a b c; do
    layers=$(awk -v o="$x.xml" '$1 == o { $1 = ""; print }' stacks.txt)
    expect_status 0 "combine $x" -- "$B" combine -k 3 -o "$x-c.xml" $layers
    expect_status 0 "compare $x" -- "$B" compare "$x.xml" "$x-c.xml"
    n=$(awk '$1 ~ /^[0-9]/ && NF == 7 && ($5 != "100.00" || $6 != $7)' out | wc -l)
    [ "$n" -eq 0 ] && pass "$x.xml equals combine's" || fail "$x.xml differs from combine's: $(cat out)"
done

# --strict: the blind's imbalance (back T + R 1.014 at 65 deg, k = 5) fails its line only
cat > strict.txt <<EOT
d.xml glass:clear-6mm glass:clear-6mm
e.xml glass:clear-6mm $ref/L_blind0_t4k5.xml^ glass:clear-6mm
f.xml glass:clear-6mm glass:lowiron-6mm
EOT
"$B" batch --strict -k 5 --only Tf strict.txt > out 2> err
st=$?
[ "$st" -eq 1 ] && pass "a failing stack: exit 1" || fail "--strict batch: exit $st"
grep -q "strict.txt:2: .*T + R = 1.01.*(--strict)" err && pass "the failing line is named, with the cause" || fail "stderr: $(cat err)"
grep -q "1 of 3 stacks failed" err && pass "the count of failures" || fail "stderr: $(cat err)"
[ -f d.xml ] && [ -f f.xml ] && [ ! -f e.xml ] && pass "the other stacks are written, the failed one is not" || fail "outputs: $(ls)"

# everything is checked before any work: nothing is written
rm -f d.xml f.xml
printf 'd.xml glass:clear-6mm\nf.xml glass:clear-6mm %s/none.xml\n' "$tmpdir" > missing.txt
expect_error "missing layer file" "none.xml: cannot open" -- "$B" batch missing.txt
[ ! -f d.xml ] && pass "nothing written" || fail "d.xml written although a layer is missing"
printf 'd.xml glass:clear-6mm\nlonely.xml\n' > bad.txt
expect_error "a line without layers" "bad.txt:2: no layers" -- "$B" batch bad.txt
printf 'd.xml glass:clear-6mm\nd.xml glass:lowiron-6mm\n' > dup.txt
expect_error "the same output twice" "dup.txt:2: 'd.xml' is written by line 1" -- "$B" batch dup.txt
printf '# nothing\n\n' > empty.txt
expect_error "no stacks" "no stacks" -- "$B" batch empty.txt
expect_error "no batch file" "cannot open" -- "$B" batch nothere.txt
expect_error "no argument" "no batch file given" -- "$B" batch
finish
