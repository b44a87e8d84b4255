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
# each pane's model and source in the header, numbered within its stack, as combine records them
expect_status 0 "info b.xml" -- "$B" info b.xml
grep -q "^ *layer 1 glass:lowiron-6mm: uncoated model (.*); source catalogue .*lowiron-6mm.glass" out &&
    grep -q "^ *layer 3 glass:clear-6mm: uncoated model" out && ! grep -q "^ *layer 2 " out &&
    pass "info b.xml: the panes' lines" || fail "info b.xml: $(head -6 out)"
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
expect_error "missing layer file" "^bsdfstack batch: missing\.txt:2: $tmpdir/none\.xml: cannot open" -- "$B" batch missing.txt
[ ! -f d.xml ] && pass "nothing written" || fail "d.xml written although a layer is missing"
# a bad layer is named with the line that first gives it, the spec once
printf '# panes
d.xml glass:clear-6mm

f.xml glass:clear-5mm
g.xml glass:clear-5mm
' > nopane.txt
expect_error "unknown pane, by line" "^bsdfstack batch: nopane\.txt:4: glass:clear-5mm: no such pane" -- "$B" batch nopane.txt
printf 'd.xml venetian:width=3
' > noshade.txt
expect_error "a shade's error, by line" "^bsdfstack batch: noshade\.txt:1: venetian:width=3: venetian: spacing missing" -- \
    "$B" batch -k 1 noshade.txt
printf 'd.xml glass:clear-6mm\nlonely.xml\n' > bad.txt
expect_error "a line without layers" "bad.txt:2: no layers" -- "$B" batch bad.txt
printf 'd.xml glass:clear-6mm\nd.xml glass:lowiron-6mm\n' > dup.txt
expect_error "the same output twice" "dup.txt:2: 'd.xml' is written by line 1" -- "$B" batch dup.txt
printf '# nothing\n\n' > empty.txt
expect_error "no stacks" "no stacks" -- "$B" batch empty.txt
expect_error "no batch file" "cannot open" -- "$B" batch nothere.txt
expect_error "no argument" "no batch file given" -- "$B" batch
expect_status 2 "an empty batch file name: a usage error" -- "$B" batch ''
grep -q "batch: the batch file '': an empty file name" "$tmpdir/err" && pass "it says so" || fail "batch '': $(cat "$tmpdir/err")"
expect_status 2 "--summary '': a usage error" -- "$B" batch --summary '' d.txt
expect_status 2 "--channels '': a usage error" -- "$B" batch --channels '' d.txt
grep -q "batch: --channels '': no channel named" "$tmpdir/err" && pass "it says so" || fail "batch --channels: $(cat "$tmpdir/err")"

# -j 2 writes the same files as -j 1, byte for byte: the header's date comes from
# SOURCE_DATE_EPOCH, and the recorded command leaves -j, --summary and --resume out
export SOURCE_DATE_EPOCH=1700000000
cat > par.txt <<EOT
p1.xml glass:clear-6mm $ref/L_diffuser_t3k5.xml glass:clear-6mm
p2.xml glass:lowiron-6mm $ref/L_diffuser_t3k5.xml glass:clear-6mm
# a comment between
p3.xml glass:nfrc-102 glass:nfrc-103
p4.xml glass:clear-6mm $ref/L_diffuser_t3k5.xml^
EOT
mkdir j1 j2 && cd j1 || exit 99
expect_status 0 "-j 1" -- "$B" batch -k 3 -j 1 --summary sum.tsv ../par.txt
cd ../j2 || exit 99
expect_status 0 "-j 2" -- "$B" batch -k 3 -j 2 --summary sum.tsv ../par.txt
[ "$(grep -c '^p[1-4]\.xml	T 0\.[0-9]*	R 0\.[0-9]*	' "$tmpdir/out")" -eq 4 ] && pass "-j 2: one stdout line per stack" || fail "-j 2 stdout: $(cat "$tmpdir/out")"
grep -q "stacks done" "$tmpdir/err" && fail "a progress line although stderr is not a terminal" || pass "no progress line off a terminal"
same=0
for x in p1 p2 p3 p4; do cmp -s "../j1/$x.xml" "$x.xml" && same=$((same + 1)); done
[ "$same" -eq 4 ] && pass "-j 2 outputs equal -j 1's byte for byte" || fail "-j 1 and -j 2 differ ($same of 4 equal)"
# the summary: a header, one row per stack in file order with its line number, per-channel T, R
awk -F'\t' 'NR == 1 { ok = $1 == "line" && $3 == "status" && $6 == "T_normal" && $8 == "warnings"; next }
            { n++; ok = ok && NF == 8 && $3 == "ok" && $4 >= 0 && $5 > 0 && $6 ~ /^Visible=0\.[0-9]+/ && $7 ~ /^Visible=0\.[0-9]+/ }
            END { exit !(ok && n == 4) }' sum.tsv && pass "summary rows" || fail "summary: $(cat sum.tsv)"
[ "$(cut -f1,2 sum.tsv | tr '\t\n' ' ')" = "line output 1 p1.xml 2 p2.xml 4 p3.xml 5 p4.xml " ] && pass "summary: line numbers in file order" || fail "summary order: $(cut -f1,2 sum.tsv)"
cut -f3- ../j1/sum.tsv | cut -f1,4,5 > s1 && cut -f3- sum.tsv | cut -f1,4,5 > s2 && cmp -s s1 s2 && pass "summary T and R equal under -j 1 and -j 2" || fail "summaries differ"

# --resume: a deleted and a truncated output are made again, nothing else; all equal the first run
rm p1.xml
head -c 1000 ../j1/p3.xml > p3.xml
expect_status 0 "--resume" -- "$B" batch -k 3 -j 2 --resume --summary resume.tsv ../par.txt
[ "$(cut -f2,3 resume.tsv | tr '\t\n' ' ')" = "output status p1.xml ok p2.xml skipped p3.xml ok p4.xml skipped " ] && pass "--resume: only the missing and the cut one are combined" || fail "resume summary: $(cut -f2,3 resume.tsv)"
grep -q "^p2.xml	skipped$" "$tmpdir/out" && pass "--resume: skipped on stdout" || fail "resume stdout: $(cat "$tmpdir/out")"
same=0
for x in p1 p2 p3 p4; do cmp -s "../j1/$x.xml" "$x.xml" && same=$((same + 1)); done
[ "$same" -eq 4 ] && pass "resumed outputs equal the uninterrupted run's" || fail "resumed outputs differ ($same of 4 equal)"
# another option, or a layer file changed, makes the stacks again
expect_status 0 "--resume, other options" -- "$B" batch -k 3 --drop-tol 1e-3 --resume --summary r2.tsv ../par.txt
[ "$(grep -c '	ok	' r2.tsv)" -eq 4 ] && pass "--resume: other options, all combined" || fail "r2: $(cut -f2,3 r2.tsv)"
cp "$ref/L_diffuser_t3k5.xml" d.xml
printf 'q1.xml glass:clear-6mm d.xml\nq2.xml glass:clear-6mm glass:clear-6mm\n' > q.txt
expect_status 0 "q batch" -- "$B" batch -k 3 q.txt
touch -d '2001-01-01' d.xml
expect_status 0 "--resume, a layer touched" -- "$B" batch -k 3 --resume --summary r3.tsv q.txt
[ "$(cut -f2,3 r3.tsv | tr '\t\n' ' ')" = "output status q1.xml ok q2.xml skipped " ] && pass "--resume: a changed layer file is seen" || fail "r3: $(cut -f2,3 r3.tsv)"
cd .. || exit 99

# a failing stack under -j 2 is named and the others go on; the summary says failed
"$B" batch --strict -k 5 --only Tf -j 2 --summary fail.tsv strict.txt > out 2> err
st=$?
[ "$st" -eq 1 ] && grep -q "strict.txt:2: .*(--strict)" err && grep -q "1 of 3 stacks failed" err && pass "-j 2: a failing line is named" || fail "-j 2 --strict: exit $st, $(cat err)"
[ "$(cut -f3 fail.tsv | tr '\n' ' ')" = "status ok failed ok " ] && pass "summary: failed" || fail "fail.tsv: $(cat fail.tsv)"

# on a terminal, a progress line on stderr
if script -qec true /dev/null > /dev/null 2>&1; then
    script -qec "'$B' batch -k 3 -j 2 par.txt" /dev/null > tty.txt 2>&1
    grep -aq "of 4 stacks done, 0 failed, .* elapsed, ~.* left" tty.txt && pass "progress line on a terminal" || fail "terminal: $(head -c 300 tty.txt)"
else
    pass "progress on a terminal: skipped (no script(1))"
fi
unset SOURCE_DATE_EPOCH
expect_error "-j 0" "-j 0: give a whole number" -- "$B" batch -j 0 par.txt
expect_error "--summary without a value" "needs a value" -- "$B" batch par.txt --summary
finish
