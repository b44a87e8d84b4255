# cli_varres.sh - variable resolution (`combine --fine-incident`, `--sun-path`) and `compare` on
# the TSV of `combine --incident` (issue 19): a pane + blind + pane stack at k = 4 over k = 2.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK
stack="glass:clear-6mm $ref/L_blind0_t4k5.xml glass:clear-6mm"

# rows of compare's table: "theta phi patch GA FA hemA hemB" under component $1
rows() { awk -v c="$1" '$1 == c {on = 1; next} /^$/ {on = 0} on && $1 ~ /^[0-9]/' "$tmpdir/out"; }

# the file: fine columns at two directions over the coarse system; the full systems at 4 and 2
expect_status 0 "variable resolution k = 4 over 2" -- "$B" combine -k 4 --coarse-k 2 --no-reduce \
    --fine-incident 30,270 --fine-incident 50,200 -o "$tmpdir/vr.xml" $stack
grep -q "Visible Tf: fine columns' hemispherical value minus their coarse patch's" "$tmpdir/err" \
    && pass "the consistency check speaks (a blind over a 4 x 4 grid differs)" || fail "no check: $(cat "$tmpdir/err")"
expect_status 0 "full k = 4" -- "$B" combine -k 4 --no-reduce -o "$tmpdir/full4.xml" $stack
expect_status 0 "full k = 2" -- "$B" combine -k 2 --no-reduce -o "$tmpdir/full2.xml" $stack
expect_status 0 "info reads it at k = 4" -- "$B" info "$tmpdir/vr.xml"
grep -q "order k = 4" "$tmpdir/out" && pass "order 4" || fail "info: $(head -3 "$tmpdir/out")"

# fine directions: Tf and Rf are the full k = 4 system's; Tb and Rb the k = 2 system's
expect_status 0 "fine columns against the full k = 4 system" -- "$B" compare --only Tf,Rf \
    --incident 30,270 --incident 50,200 "$tmpdir/vr.xml" "$tmpdir/full4.xml"
n=$( (rows Tf; rows Rf) | awk '$4 == "100.000" && $6 == $7' | wc -l)
[ "$n" -eq 4 ] && pass "fine columns: GA 100, equal hemispherical values" || fail "fine: $(cat "$tmpdir/out")"
expect_status 0 "the same columns against the k = 2 system" -- "$B" compare -k 4 --only Tf \
    --incident 30,270 --incident 50,200 "$tmpdir/vr.xml" "$tmpdir/full2.xml"
n=$(rows Tf | awk '$4 < 99' | wc -l)
[ "$n" -eq 2 ] && pass "fine columns differ from the coarse system" || fail "fine vs coarse: $(rows Tf)"
expect_status 0 "elsewhere: the k = 2 system" -- "$B" compare -k 4 --incident 10,10 --incident 70,45 \
    --incident 30,270 "$tmpdir/vr.xml" "$tmpdir/full2.xml"
n=$( (rows Tf; rows Rf; rows Tb; rows Rb) | awk '$4 == "100.000" && $6 == $7' | wc -l)
[ "$n" -eq 10 ] && pass "coarse patches and Tb, Rb: GA 100 against k = 2" || fail "coarse: $(cat "$tmpdir/out")"

# the sun path: a year at 40 N, 105 W, hourly; a south window sees more of it than a north one
expect_status 0 "sun path, south window" -- "$B" combine -k 3 --coarse-k 2 --sun-path 40,105,105 -v \
    -o "$tmpdir/sun.xml" $stack
south=$(sed -n 's/.*: \([0-9]*\) sun positions of a year.*/\1/p' "$tmpdir/err")
expect_status 0 "sun path, north window" -- "$B" combine -k 3 --coarse-k 2 --sun-path 40,105,105 \
    --azimuth 180 -v -o "$tmpdir/sun_n.xml" $stack
north=$(sed -n 's/.*: \([0-9]*\) sun positions of a year.*/\1/p' "$tmpdir/err")
[ -n "$south" ] && [ -n "$north" ] && [ "$south" -gt 1500 ] && [ "$north" -gt 0 ] && [ "$north" -lt "$south" ] \
    && pass "sun positions: $south facing south, $north facing north" || fail "sun positions '$south' '$north'"

# errors: one line, non-zero, no output file
for bad in "--sun-path 95,0,0|latitude 95" "--sun-path 40,105,105 --azimuth south|--azimuth south" \
    "--fine-incident 120,0|behind the window" "--fine-incident 30,0 --coarse-k 5|--coarse-k 5 must be below -k 4" \
    "--azimuth 10 --fine-incident 30,0|--azimuth and --sun-step go with --sun-path" \
    "--fine-incident 30,0 --incident 20,0|do not go with --incident"; do
    opt=${bad%|*} pat=${bad#*|}
    # shellcheck disable=SC2086
    expect_error "combine -k 4 $opt" "$pat" -- "$B" combine -k 4 $opt -o "$tmpdir/bad.xml" $stack
    [ ! -e "$tmpdir/bad.xml" ] && pass "no output after '$opt'" || fail "output left after '$opt'"
done
expect_error "no -k" "need -k K" -- "$B" combine --fine-incident 30,0 -o "$tmpdir/bad.xml" $stack

# compare on the TSV of combine --incident: the same table as the file-vs-file compare of the same
# columns (the TSV holds the full k = 4 system's columns)
expect_status 0 "columns TSV" -- "$B" combine -k 4 --incident 30,270 --incident 50,200 -o "$tmpdir/c.tsv" $stack
expect_status 0 "files" -- "$B" compare -k 4 --incident 30,270 --incident 50,200 "$tmpdir/full4.xml" "$tmpdir/full2.xml"
for c in Tf Rf Tb Rb; do rows "$c"; done > "$tmpdir/files.rows"
expect_status 0 "TSV against a file" -- "$B" compare "$tmpdir/c.tsv" "$tmpdir/full2.xml"
for c in Tf Rf Tb Rb; do rows "$c"; done > "$tmpdir/tsv.rows"
[ -s "$tmpdir/tsv.rows" ] && [ "$(wc -l < "$tmpdir/tsv.rows")" -eq 8 ] && cmp -s "$tmpdir/files.rows" "$tmpdir/tsv.rows" \
    && pass "TSV vs file: GA, FA and hemispherical values as file vs file" \
    || fail "TSV vs file: $(cat "$tmpdir/tsv.rows") / files: $(cat "$tmpdir/files.rows")"
awk '$4 < 99.9' "$tmpdir/tsv.rows" | grep -q . && pass "(and not trivially 100)" || fail "all 100: $(cat "$tmpdir/tsv.rows")"
expect_status 0 "file against TSV, one direction" -- "$B" compare --only Rf --incident 50,200 "$tmpdir/full2.xml" "$tmpdir/c.tsv"
expect_status 0 "files, swapped" -- "$B" compare -k 4 --only Rf --incident 50,200 "$tmpdir/full2.xml" "$tmpdir/full4.xml"
rows Rf > "$tmpdir/f.rows"
expect_status 0 "file against TSV, again" -- "$B" compare --only Rf --incident 50,200 "$tmpdir/full2.xml" "$tmpdir/c.tsv"
rows Rf | cmp -s - "$tmpdir/f.rows" && pass "file vs TSV as file vs file" || fail "file vs TSV: $(rows Rf)"
# two TSVs: the columns of two stacks, as the files of the two stacks
expect_status 0 "second TSV" -- "$B" combine -k 4 --incident 30,270 --incident 50,200 -o "$tmpdir/d.tsv" \
    glass:clear-6mm "$ref/L_blind0_t4k5.xml"
expect_status 0 "second file" -- "$B" combine -k 4 --no-reduce -o "$tmpdir/two.xml" glass:clear-6mm "$ref/L_blind0_t4k5.xml"
expect_status 0 "TSV vs TSV" -- "$B" compare "$tmpdir/c.tsv" "$tmpdir/d.tsv"
for c in Tf Rf Tb Rb; do rows "$c"; done > "$tmpdir/tt.rows"
expect_status 0 "the stacks' files" -- "$B" compare --incident 30,270 --incident 50,200 "$tmpdir/full4.xml" "$tmpdir/two.xml"
for c in Tf Rf Tb Rb; do rows "$c"; done | awk '{ printf "%s %s %s %s %.1f %.3f %.3f\n", $1, $2, $3, $4, $5, $6, $7 }' > "$tmpdir/ff.rows"
awk '{ printf "%s %s %s %s %.1f %.3f %.3f\n", $1, $2, $3, $4, $5, $6, $7 }' "$tmpdir/tt.rows" | cmp -s - "$tmpdir/ff.rows" \
    && pass "TSV vs TSV as the files (to the files' single precision)" || fail "TSV vs TSV: $(cat "$tmpdir/tt.rows") / $(cat "$tmpdir/ff.rows")"
# a TSV edited or of another kind: one line
awk 'BEGIN { FS = OFS = "\t" } NR == 3 { $7 = "12.0000" } { print }' "$tmpdir/c.tsv" > "$tmpdir/bad.tsv"
expect_error "an exit direction off its patch" "bad.tsv:3: exit direction" -- "$B" compare "$tmpdir/bad.tsv" "$tmpdir/full2.xml"
expect_error "a TSV with -k" "keeps its basis" -- "$B" compare -k 3 "$tmpdir/c.tsv" "$tmpdir/full2.xml"
expect_error "a direction the TSV lacks" "no Visible Tf column at \\(10, 10\\)" -- "$B" compare --only Tf --incident 10,10 "$tmpdir/c.tsv" "$tmpdir/full2.xml"

# a spectral stack (spectral panes around a band-value layer: a pane written with Solar and Visible
# channels) is combined per wavelength in both parts of a variable-resolution file and in the TSV of
# --incident, as the full combination is: its fine columns equal the full spectral system's, not the
# band-value one's (solar T(0) 0.530 against 0.513)
expect_status 0 "a band-value layer" -- "$B" combine -k 3 --no-reduce -o "$tmpdir/band.xml" glass:clear-6mm
sstack="glass:nfrc-102 $tmpdir/band.xml glass:nfrc-103"
expect_status 0 "spectral variable resolution" -- "$B" combine -v -k 3 --coarse-k 2 --no-reduce \
    --fine-incident 0,0 --fine-incident 30,270 -o "$tmpdir/svr.xml" $sstack
grep -q "spectral: combined wavelength by wavelength" "$tmpdir/svr.xml" && pass "varres metadata: per wavelength" \
    || fail "varres metadata: $(grep -i spectral "$tmpdir/svr.xml")"
expect_status 0 "full spectral k = 3" -- "$B" combine -k 3 --no-reduce -o "$tmpdir/sfull.xml" $sstack
expect_status 0 "full per channel k = 3" -- "$B" combine -k 3 --no-reduce --per-channel -o "$tmpdir/pfull.xml" $sstack
expect_status 0 "spectral columns TSV" -- "$B" combine -k 3 --incident 0,0 --incident 30,270 -o "$tmpdir/s.tsv" $sstack
for a in svr.xml s.tsv; do
    expect_status 0 "$a against the full spectral system" -- "$B" compare --channel Solar --only Tf,Rf \
        --incident 0,0 --incident 30,270 "$tmpdir/$a" "$tmpdir/sfull.xml"
    n=$( (rows Tf; rows Rf) | awk '$4 == "100.000" && $6 == $7' | wc -l)
    [ "$n" -eq 4 ] && pass "$a: GA 100, hemispherical values equal the spectral system's" || fail "$a: $(cat "$tmpdir/out")"
    expect_status 0 "$a against the band-value system" -- "$B" compare --channel Solar --only Tf \
        --incident 0,0 "$tmpdir/$a" "$tmpdir/pfull.xml"
    rows Tf | awk '{ d = $6 - $7; exit !(d > 0.005 || d < -0.005) }' && pass "$a: solar T(0) differs from the band-value one" \
        || fail "$a vs band values: $(rows Tf)"
done
finish
