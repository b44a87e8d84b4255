# cli_regress.sh - the program on every input that once broke a fuzz target (tests/fuzz/regress):
# `bsdfstack info` on each XML reproducer, `bsdfstack batch` on each batch file and `bsdfstack
# compare` on each table of combine --incident fail with one
# error line and a non-zero exit status, in well under a minute (the limit only catches hangs).
# Inputs listed in tests/fuzz/regress/OPEN (found, not fixed yet) are skipped.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
regress=$BST_SRCDIR/tests/fuzz/regress
is_open() { grep -q "^$1 " "$regress/OPEN" 2>/dev/null; }
n=0
for f in "$regress"/xml/* "$regress"/batch/* "$regress"/tsv/*; do
    [ -f "$f" ] || continue
    name=${f#"$regress"/}
    if is_open "$name"; then echo "skipped (open): $name"; continue; fi
    case $name in
    xml/*) expect_error "info $name" "^bsdfstack info: " -- timeout 60 "$BSDFSTACK" info "$f" ;;
    batch/*) expect_error "batch $name" "^bsdfstack batch: " -- timeout 60 "$BSDFSTACK" batch -k 1 "$f" ;;
    tsv/*) expect_error "compare $name" "^bsdfstack compare: " -- \
        timeout 60 "$BSDFSTACK" compare "$f" glass:clear-6mm ;;
    esac
    n=$((n + 1))
done
[ "$n" -gt 0 ] && pass "$n regression inputs" || fail "no regression inputs in $regress"
finish
