# cli_query.sh - `bsdfstack query` on reference files: libBSDF's values, errors as one line.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}

# the first 40 rows of the glass and diffuser tables, through the program
for name in L_glass_t4k5 L_diffuser_t3k5_klems; do
    grep -v '^#' "$ref/$name.query.tsv" | sed 1d | head -40 > "$tmpdir/rows"
    cut -f3-8 "$tmpdir/rows" > "$tmpdir/in"
    if "$BSDFSTACK" query "$ref/$name.xml" < "$tmpdir/in" > "$tmpdir/got" 2>"$tmpdir/err"; then
        paste "$tmpdir/got" <(cut -f9 "$tmpdir/rows") | awk -v n="$name" '
            { d = $1 - $2; if (d < 0) d = -d; s = ($2 < 0 ? -$2 : $2); if (s < 1e-6) s = 1e-6;
              if (d / s > 3.5e-4) { print "row " NR ": " $1 " vs " $2; bad = 1 } }
            END { exit bad }' && pass "query $name matches libBSDF" || fail "query $name"
    else fail "query $name: $(cat "$tmpdir/err")"; fi
done
# degrees form: normal incidence through the clear pane = straight-through value
echo "0 0 0 0" | "$BSDFSTACK" query --degrees Tf "$ref/L_glass_t4k5.xml" > "$tmpdir/got"
awk '{ exit !($1 > 250 && $1 < 320) }' "$tmpdir/got" && pass "--degrees Tf at normal incidence" || fail "--degrees: $(cat "$tmpdir/got")"

# vectors of any finite, non-zero length give the value of the unit ones: 1e200 (whose squares
# overflowed: "must be finite and non-zero") and subnormal components (whose squares underflow)
printf '1 0 -1 0 0 1\n1e200 0 -1e200 0 0 1\n1e-310 0 -1e-310 0 0 4.9e-324\n-0.5 0.25 -0.75 0.25 0.5 0.75\n-5e-321 2.5e-321 -7.5e-321 2.5e300 5e300 7.5e300\n' > "$tmpdir/scaled"
expect_status 0 "query: huge and subnormal direction vectors" -- \
    sh -c '"$1" query "$2" < "$3"' sh "$BSDFSTACK" "$ref/L_blind45_t4k5.xml" "$tmpdir/scaled"
awk 'NR == 1 || NR == 4 { v = $1 } NR == 2 || NR == 3 || NR == 5 { if ($1 != v) bad = 1 } END { exit bad || NR != 5 }' \
    "$tmpdir/out" && pass "each scaled pair gives the unit pair's value" || fail "scaled vectors: $(cat "$tmpdir/out")"
echo "0 0 0 0 0 1" | expect_error "a zero vector" "line 1: .*finite and non-zero" -- "$BSDFSTACK" query "$ref/L_glass_t4k5.xml"

printf '<?xml version="1.0"?>\n<WindowElement><Optical>\n' > "$tmpdir/trunc.xml"
expect_error "truncated file" "trunc.xml: .*(malformed|truncated)" -- "$BSDFSTACK" query "$tmpdir/trunc.xml"
expect_error "missing file" "nothere.xml: cannot open" -- "$BSDFSTACK" query "$tmpdir/nothere.xml"
echo "1 2 3" | expect_error "short input line" "line 1: expected 6 numbers" -- "$BSDFSTACK" query "$ref/L_glass_t4k5.xml"
expect_error "unknown channel" "no channel 'Solar'" -- "$BSDFSTACK" query --channel Solar "$ref/L_glass_t4k5.xml"
expect_error "no file" "no file given" -- "$BSDFSTACK" query
finish
