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

printf '<?xml version="1.0"?>\n<WindowElement><Optical>\n' > "$tmpdir/trunc.xml"
expect_error "truncated file" "trunc.xml: .*(malformed|truncated)" -- "$BSDFSTACK" query "$tmpdir/trunc.xml"
expect_error "missing file" "nothere.xml: cannot open" -- "$BSDFSTACK" query "$tmpdir/nothere.xml"
echo "1 2 3" | expect_error "short input line" "line 1: expected 6 numbers" -- "$BSDFSTACK" query "$ref/L_glass_t4k5.xml"
expect_error "unknown channel" "no channel 'Solar'" -- "$BSDFSTACK" query --channel Solar "$ref/L_glass_t4k5.xml"
expect_error "no file" "no file given" -- "$BSDFSTACK" query
finish
