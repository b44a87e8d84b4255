# cli_glass.sh - `bsdfstack glass`: the catalogue, the angular table, errors.
. "${BST_SRCDIR:-.}/tests/clitest.sh"

expect_status 0 "glass --list" -- "$BSDFSTACK" glass --list
for p in clear-3mm clear-4mm clear-6mm clear-8mm clear-10mm clear-12mm lowiron-6mm nfrc-102 nfrc-103; do
    grep -q "^$p " "$tmpdir/out" || fail "catalogue lists $p"
done
expect_status 0 "glass clear-6mm" -- "$BSDFSTACK" glass clear-6mm
# 21 angles per channel, two channels; T + Rf + Af = 1 on every row; T = 0 at 90 degrees
awk -F'\t' 'NR > 2 { n++; s = $3 + $5 + $7; if (s < 0.999996 || s > 1.000004) bad = 1;
            if ($2 == 90 && $3 != 0) bad = 1 } END { exit bad || n != 42 }' "$tmpdir/out" \
    && pass "glass table complete and balanced" || fail "glass table: $(head -5 "$tmpdir/out")"
expect_status 0 "glass inline spec" -- "$BSDFSTACK" glass glass:d=4mm,n=1.5,tn=0.85
expect_error "unknown pane" "no such pane" -- "$BSDFSTACK" glass clear-7mm
expect_error "bad value" "tn=2 is not a valid value" -- "$BSDFSTACK" glass d=6mm,n=1.5,tn=2
finish
