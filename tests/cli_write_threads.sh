# cli_write_threads.sh - `--threads N` of convert and combine: 1, 2 and 3 threads write the same
# bytes (a blind as TensorTree4, reduced and not; a diffuser as TensorTree3; a combined stack),
# the recorded command line aside, which leaves --threads out (checked); a bad count is one usage
# line; convert -v reports the write.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
export SOURCE_DATE_EPOCH=0

# same_bytes WHAT NAME: t1/NAME, t2/NAME and t3/NAME equal but for the date convert writes
same_bytes() {
    grep -v 'Written by bsdfstack' "$tmpdir/t1/$2" > "$tmpdir/a"
    for t in 2 3; do
        grep -v 'Written by bsdfstack' "$tmpdir/t$t/$2" > "$tmpdir/b"
        cmp -s "$tmpdir/a" "$tmpdir/b" || { fail "$1: t$t/$2 differs from t1/$2"; return; }
    done
    pass "$1"
}

# each thread count in a folder of its own, the same -o OUT: the recorded command lines match
for t in 1 2 3; do
    mkdir "$tmpdir/t$t"
    cd "$tmpdir/t$t" || exit 99
    expect_status 0 "convert blind, $t threads" -- "$BSDFSTACK" convert --threads $t -k 4 \
        "$ref/L_blind0_t4k5.xml" -o b.xml
    expect_status 0 "convert blind --no-reduce, $t threads" -- "$BSDFSTACK" convert --threads $t \
        --no-reduce "$ref/L_blind0_t4k5.xml" -o bn.xml
    expect_status 0 "convert diffuser, $t threads" -- "$BSDFSTACK" convert --threads=$t \
        "$ref/L_diffuser_t3k5.xml" -o d.xml
    expect_status 0 "combine pane + blind + pane, $t threads" -- "$BSDFSTACK" combine --threads $t \
        -k 4 -o s.xml glass:clear-6mm "$ref/L_blind0_t4k5.xml" glass:clear-6mm
done
cd "$tmpdir" || exit 99
grep -q '<IncidentDataStructure>TensorTree4</IncidentDataStructure>' t1/b.xml || fail "the blind is a TensorTree4"
grep -q '<IncidentDataStructure>TensorTree3</IncidentDataStructure>' t1/d.xml || fail "the diffuser is a TensorTree3"
grep -q 'threads' t2/b.xml t2/d.xml t2/s.xml && fail "--threads is recorded in a file" || pass "--threads is not recorded"
same_bytes "blind, reduced: same bytes with 1, 2, 3 threads" b.xml
same_bytes "blind, lossless: same bytes with 1, 2, 3 threads" bn.xml
same_bytes "diffuser: same bytes with 1, 2, 3 threads" d.xml
same_bytes "combined stack: same bytes with 1, 2, 3 threads" s.xml

expect_error "convert --threads -1" "--threads -1" -- "$BSDFSTACK" convert --threads -1 "$ref/L_glass_t4k5.xml" -o "$tmpdir/x.xml"
expect_error "combine --threads two" "--threads two" -- "$BSDFSTACK" combine --threads two -o "$tmpdir/x.xml" glass:clear-6mm
[ ! -e "$tmpdir/x.xml" ] && pass "no output after a usage error" || fail "output left after a usage error"
expect_status 0 "convert -v" -- "$BSDFSTACK" convert -v --threads 2 "$ref/L_glass_t4k5.xml" -o "$tmpdir/g.xml"
grep -Eq '^bsdfstack convert: wrote [0-9.]+ MB: [0-9.]+ s, [0-9.]+ CPU-s, peak RSS [0-9.]+ MiB$' "$tmpdir/err" \
    && pass "convert -v reports the write" || fail "convert -v write line: $(tail -1 "$tmpdir/err")"
finish
