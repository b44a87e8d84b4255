# cli_mpi.sh - bsdfstack-mpi (batches over MPI ranks) against the serial `bsdfstack batch`: with 1,
# 2 and 4 ranks on this machine the outputs are the same bytes, the summary the same rows; a
# failing line in the middle is named and the others are written; a resumed run ends with the
# same files; with one working rank the stacks go most expensive first (the cost model of
# batch_mpi.c and bsdfstack-batch(1)); errors are printed once.  Skipped (77) without MPI.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
M=$(dirname "$B")/bsdfstack-mpi
if [ ! -x "$M" ] || ! command -v mpirun > /dev/null 2>&1; then
    echo "skipped: no bsdfstack-mpi (configure found no MPI) or no mpirun"
    exit 77
fi
ref=${BST_REFDIR:?}
# loopback only: shared memory between the ranks, no network probing (OpenMPI 4's MCA names);
# more ranks than cores is allowed; root may run it (containers, CI)
export OMPI_MCA_btl=self,vader OMPI_MCA_pml=ob1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMPI_MCA_oob_tcp_if_include=lo OMPI_MCA_rmaps_base_oversubscribe=1
export SOURCE_DATE_EPOCH=1700000000
root=
[ "$(id -u)" -eq 0 ] && root=--allow-run-as-root
run_mpi() { # run_mpi N ARGS...: N ranks
    local n=$1
    shift
    mpirun $root --oversubscribe -n "$n" "$M" "$@"
}
if ! run_mpi 1 --help > "$tmpdir/help" 2>&1; then
    echo "skipped: mpirun cannot start a job here: $(head -c 300 "$tmpdir/help")"
    exit 77
fi
cd "$tmpdir" || exit 99

# A: -k 3, dense (the diffuser), reversed, spectral panes
cat > a.txt <<EOT
p1.xml glass:clear-6mm $ref/L_diffuser_t3k5.xml glass:clear-6mm
# a comment between
p2.xml glass:nfrc-102 glass:nfrc-103
p3.xml glass:clear-6mm $ref/L_diffuser_t3k5.xml^

p4.xml glass:lowiron-6mm $ref/L_diffuser_t3k5.xml glass:clear-6mm
p5.xml glass:clear-6mm glass:lowiron-6mm
EOT
mkdir s && cd s || exit 99
expect_status 0 "serial batch A" -- "$B" batch -k 3 --summary sum.tsv ../a.txt
cp "$tmpdir/out" stdout
cd .. || exit 99
for n in 1 2 4; do
    mkdir "m$n" && cd "m$n" || exit 99
    expect_status 0 "$n rank(s): batch A" -- run_mpi "$n" -k 3 --summary sum.tsv ../a.txt
    cp "$tmpdir/out" stdout
    same=0
    for x in p1 p2 p3 p4 p5; do cmp -s "../s/$x.xml" "$x.xml" && same=$((same + 1)); done
    [ "$same" -eq 5 ] && pass "$n rank(s): outputs equal the serial batch's byte for byte" || fail "$n rank(s): $same of 5 outputs equal the serial's"
    # the summary: the same rows in file order but for seconds and memory
    cut -f1-3,6- ../s/sum.tsv > s.tsv && cut -f1-3,6- sum.tsv > m.tsv
    cmp -s s.tsv m.tsv && pass "$n rank(s): summary rows equal the serial's" || fail "$n rank(s): summary: $(cat sum.tsv)"
    # standard output: one line per stack, as the serial batch's but for the time and the order
    cut -f1-3 ../s/stdout | sort > s.out && cut -f1-3 stdout | sort > m.out
    cmp -s s.out m.out && pass "$n rank(s): stdout lines equal the serial's" || fail "$n rank(s): stdout: $(cat stdout)"
    cd .. || exit 99
done
# one working rank takes the stacks in order of cost: two dense steps (p1, p4), one (p3), then
# the panes (diagonal, p2, p5), ties by line
[ "$(cut -f1 m2/stdout | tr '\n' ' ')" = "p1.xml p4.xml p3.xml p2.xml p5.xml " ] && pass "most expensive first" || fail "order: $(cut -f1 m2/stdout | tr '\n' ' ')"

# --resume: a deleted and a cut output are made again, nothing else; all equal the serial's
cd m2 || exit 99
rm p1.xml
head -c 1000 ../s/p5.xml > p5.xml
expect_status 0 "2 ranks: --resume" -- run_mpi 2 -k 3 --resume --summary resume.tsv ../a.txt
[ "$(cut -f2,3 resume.tsv | tr '\t\n' ' ')" = "output status p1.xml ok p2.xml skipped p3.xml skipped p4.xml skipped p5.xml ok " ] && pass "--resume: only the missing and the cut one are combined" || fail "resume summary: $(cut -f2,3 resume.tsv)"
grep -q "^p2.xml	skipped$" "$tmpdir/out" && pass "--resume: skipped on stdout" || fail "resume stdout: $(cat "$tmpdir/out")"
same=0
for x in p1 p2 p3 p4 p5; do cmp -s "../s/$x.xml" "$x.xml" && same=$((same + 1)); done
[ "$same" -eq 5 ] && pass "resumed outputs equal the serial batch's" || fail "resumed outputs differ ($same of 5 equal)"
# a resumed serial batch skips what the ranks wrote: the same batch-key
expect_status 0 "serial --resume after MPI" -- "$B" batch -k 3 --resume --summary r2.tsv ../a.txt
[ "$(grep -c '	skipped	' r2.tsv)" -eq 5 ] && pass "the serial batch skips the ranks' outputs" || fail "r2: $(cut -f2,3 r2.tsv)"
cd .. || exit 99

# B: Klems files, no -k: the basis is the first Klems file's (the ranks make it themselves);
# --strict fails line 2 (the blind's front T + R = 1.094 at 50 degrees) and the others go on.
# One OpenBLAS thread everywhere: at Klems full the last bit of a product follows OpenBLAS's
# thread count (1 against 2 differ), and the ranks' count (cores / ranks) is not the serial's.
export OPENBLAS_NUM_THREADS=1
cat > b.txt <<EOT
k1.xml glass:clear-6mm $ref/L_diffuser_t3k5_klems.xml glass:clear-6mm
k2.xml $ref/L_blind45_t4k5_klems.xml $ref/L_diffuser_t3k5_klems.xml
k3.xml glass:clear-6mm glass:lowiron-6mm
EOT
mkdir bs && cd bs || exit 99
"$B" batch --strict --summary sum.tsv ../b.txt > out 2> err
st=$?
[ "$st" -eq 1 ] && [ -f k1.xml ] && [ -f k3.xml ] && [ ! -f k2.xml ] && pass "serial batch B: line 2 fails" || fail "serial B: exit $st, $(cat err)"
cd .. || exit 99
for n in 1 2 4; do
    mkdir "b$n" && cd "b$n" || exit 99
    run_mpi "$n" --strict --summary sum.tsv ../b.txt > out 2> err
    st=$?
    [ "$st" -eq 1 ] && pass "$n rank(s): a failing stack: exit 1" || fail "$n rank(s) B: exit $st"
    grep -q "b.txt:2: .*T + R = 1.094.*(--strict)" err && pass "$n rank(s): the failing line is named, with the cause" || fail "$n rank(s) B stderr: $(cat err)"
    grep -q "1 of 3 stacks failed (line 2; reported above)" err && pass "$n rank(s): the count names the line" || fail "$n rank(s) B stderr: $(cat err)"
    [ "$(grep -c 'T + R = 1.094' err)" -eq 1 ] && pass "$n rank(s): the failure is reported once" || fail "$n rank(s) B: $(cat err)"
    [ ! -f k2.xml ] && cmp -s ../bs/k1.xml k1.xml && cmp -s ../bs/k3.xml k3.xml && pass "$n rank(s): the others written, equal to the serial's" || fail "$n rank(s) B outputs: $(ls)"
    [ "$(cut -f3 sum.tsv | tr '\n' ' ')" = "status ok failed ok " ] && pass "$n rank(s): summary says failed" || fail "$n rank(s) B summary: $(cat sum.tsv)"
    cd .. || exit 99
done

# errors: printed once (by rank 0), nothing written
mkdir e && cd e || exit 99
printf 'd.xml glass:clear-6mm\nf.xml glass:clear-6mm %s/none.xml\n' "$tmpdir" > missing.txt
run_mpi 2 missing.txt > out 2> err
st=$?
[ "$st" -eq 1 ] && [ "$(grep -c 'none.xml: cannot open' err)" -eq 1 ] && [ ! -f d.xml ] && pass "a missing layer: one error line, nothing written" || fail "missing layer: exit $st, $(cat err)"
grep -q "missing\.txt:2: $tmpdir/none\.xml: cannot open" err && pass "it names the batch line" || fail "missing layer: $(cat err)"
run_mpi 2 -j 2 ../a.txt > out 2> err
st=$?
[ "$st" -eq 2 ] && [ "$(grep -c 'mpirun -n N' err)" -eq 1 ] && pass "-j is refused once" || fail "-j: exit $st, $(cat err)"
printf 'd.xml glass:clear-6mm\nlonely.xml\n' > bad.txt
run_mpi 2 bad.txt > out 2> err
[ "$(grep -c 'bad.txt:2: no layers' err)" -eq 1 ] && pass "a bad line: one error line" || fail "bad line: $(cat err)"
printf 'd.xml glass:clear-6mm\n./d.xml glass:clear-6mm\n' > alias.txt
run_mpi 2 alias.txt > out 2> err
st=$?
[ "$st" -eq 1 ] && [ "$(grep -c "alias.txt:2: './d.xml' is the file line 1 writes already" err)" -eq 1 ] &&
    [ ! -f d.xml ] && pass "two outputs that are one file: one error line, nothing written" ||
    fail "aliased outputs: exit $st, $(cat err)"
run_mpi 2 --help > out 2> err
[ "$(grep -c '^Usage: mpirun -n N bsdfstack-mpi' out)" -eq 1 ] && pass "--help printed once" || fail "--help: $(cat out)"
cd .. || exit 99
finish
