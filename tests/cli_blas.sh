# cli_blas.sh - the dense algebra's kernels (src/cli/cli.c, cli_blas_kernels).  Where OpenBLAS
# picks kernels without AVX2 on a CPU that has AVX2 and FMA (0.3.21 takes Prescott's for an
# AVX-512 Xeon it does not know: DGEMM 21 against 146 GFLOP/s), the program runs itself again with
# OPENBLAS_CORETYPE set to SkylakeX (AVX-512) or Haswell; a user's OPENBLAS_CORETYPE stands; and
# the system is the same either way to rounding.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
cd "$tmpdir" || exit 99
stack="glass:clear-6mm $BST_REFDIR/L_blind0_t4k5.xml glass:clear-6mm"
old='^(prescott|core2|penryn|dunnington|nehalem|atom|sandybridge)$'
core() { sed -n "s/.*dense algebra: OpenBLAS's \([A-Za-z0-9_]*\) kernels.*/\1/p" "$1"; }
has() { grep -m1 '^flags' /proc/cpuinfo 2>/dev/null | tr ' ' '\n' | grep -qx "$1"; }

# the user's choice is kept, and named
# shellcheck disable=SC2086
OPENBLAS_CORETYPE=Prescott "$B" combine -v -k 4 $stack -o p.xml 2>perr >/dev/null ||
    fail "combine with OPENBLAS_CORETYPE=Prescott: $(cat perr)"
[ "$(core perr)" = Prescott ] && ! grep -q "it picked" perr &&
    pass "OPENBLAS_CORETYPE=Prescott kept" || fail "OPENBLAS_CORETYPE=Prescott: $(grep 'dense algebra' perr)"

# shellcheck disable=SC2086
env -u OPENBLAS_CORETYPE -u BSDFSTACK_OPENBLAS_PICKED "$B" combine -v -k 4 $stack -o d.xml \
    2>derr >/dev/null || fail "combine: $(cat derr)"
c=$(core derr)
if [ -z "$c" ]; then
    fail "-v names no kernels: $(head -3 derr)"
elif has avx2 && has fma; then
    if echo "$c" | grep -qiE "$old"; then
        fail "AVX2 and FMA here, yet OpenBLAS's $c kernels: $(grep 'dense algebra' derr)"
    else
        pass "kernels with AVX2 on a CPU that has it: $c"
    fi
    if grep -q "it picked" derr && has avx512f && has avx512cd && has avx512bw && has avx512dq &&
        has avx512vl; then
        [ "$c" = SkylakeX ] && pass "OpenBLAS's pick overruled by SkylakeX on AVX-512" ||
            fail "AVX-512 here, overruled by $c"
    fi
else
    ! grep -q "it picked" derr && pass "no AVX2 here: OpenBLAS's pick ($c) stands" ||
        fail "no AVX2 here, yet: $(grep 'dense algebra' derr)"
fi

# the same system from either kernels (k = 4: the blind dense, 256 patches, GEMMs on all threads)
"$B" compare --fail-below 99.99999 --fail-hem 1e-6 d.xml p.xml >cmp 2>&1 &&
    pass "the system from either kernels agrees" || fail "kernels differ: $(tail -6 cmp)"
finish
