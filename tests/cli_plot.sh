# cli_plot.sh - `bsdfstack plot`: the values it prints against RADIANCE's hemispherical tables and
# against `query`, the physics of where the light goes, the PNG and SVG it writes, and its errors.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK

# Directional-hemispherical values printed with the plot against the reference tables (integrated
# by bsdfquery over 64 x 64 exit cells) at theta 0 and 60, both sides, T and R.  (The theta 30
# rows lie exactly on k = 5 cell boundaries, where the table's reader and ours may take
# neighbouring cells; the tables' README says so for the paper's directions.)
for f in S1_t4k5 L_blind45_t4k5 L_diffuser_t3k5; do
    awk -F'\t' 'NR > 2 && ($2 == 0 || $2 == 60) {print $1 "\t" $2 "\t" $3 "\t" $4 "\t" $5}' \
        "$ref/$f.hemi.tsv" > "$tmpdir/rows"
    bad=0 n=0
    while IFS=$'\t' read -r side th ph T R; do
        s=f; [ "${side#back}" != "$side" ] && s=b
        for c in T R; do
            want=$T; [ $c = R ] && want=$R
            got=$("$B" plot --size 64 --comp $c$s --incident "$th,$ph" -o "$tmpdir/h.png" "$ref/$f.xml" |
                  awk '/hemispherical/ {print $NF}')
            n=$((n + 1))
            awk -v a="$got" -v b="$want" 'BEGIN {exit !(a != "" && (a - b)^2 < 1e-6)}' ||
                { bad=$((bad + 1)); echo "  $f $c$s ($th, $ph): $got, table $want"; }
        done
    done < "$tmpdir/rows"
    [ "$bad" -eq 0 ] && [ "$n" -ge 12 ] && pass "$f: $n hemispherical values within 1e-3 of the table" ||
        fail "$f: $bad of $n hemispherical values off the table"
done

# The peak: its value is what query returns there; and where physics puts it.  S1's slats are
# mirrors: light travelling up at 45 degrees is turned to travel down (phi 270) at the same angle.
expect_status 0 "S1 Tf at (45, 90)" -- "$B" plot --incident 45,90 -o "$tmpdir/s1.png" "$ref/S1_t4k5.xml"
peak=$(awk '/^peak/ {print $3, $10, $11}' "$tmpdir/out" | tr -d '(),')
set -- $peak
awk -v t="$2" -v p="$3" 'BEGIN {exit !((t - 45)^2 < 9 && (p - 270)^2 < 25)}' &&
    pass "S1: the peak is the mirrored direction (theta $2, phi $3)" || fail "S1 peak at $peak"
# query reads the vector towards the source: propagation (45, 90) is in = (45, 270)
q=$(echo "45 270 $2 $3" | "$B" query --degrees Tf "$ref/S1_t4k5.xml")
awk -v a="$1" -v b="$q" 'BEGIN {exit !((a - b)^2 <= (1e-5 * b)^2)}' &&
    pass "S1: peak $1 1/sr = query $q" || fail "S1: peak $1, query $q"
# a clear pane: everything straight through
expect_status 0 "glass Tf at normal incidence" -- "$B" plot --incident 0,0 -o "$tmpdir/g.svg" "$ref/L_glass_t4k5.xml"
awk '/^peak/ {t = $10; gsub(/[(,]/, "", t); ok = t != "" && t + 0 < 3} END {exit !ok}' "$tmpdir/out" &&
    pass "glass: peak at the normal" || fail "glass: $(cat "$tmpdir/out")"

# The PNG: signature, an 8-bit palette image; the same bytes on standard output (summary on stderr)
sig=$(od -An -tx1 -N16 "$tmpdir/s1.png" | tr -d ' \n')
[ "$sig" = 89504e470d0a1a0a0000000d49484452 ] && pass "PNG signature and IHDR first" || fail "PNG starts $sig"
[ "$(od -An -tu1 -j24 -N2 "$tmpdir/s1.png" | tr -s ' ')" = " 8 3" ] && pass "PNG: 8-bit palette" ||
    fail "PNG depth/colour type $(od -An -tu1 -j24 -N2 "$tmpdir/s1.png")"
"$B" plot --incident 45,90 -o - "$ref/S1_t4k5.xml" > "$tmpdir/stdout.png" 2> "$tmpdir/err"
cmp -s "$tmpdir/stdout.png" "$tmpdir/s1.png" && grep -q '^peak' "$tmpdir/err" &&
    pass "-o - writes the same PNG, the summary to stderr" || fail "-o -: $(head -c 200 "$tmpdir/err")"

# The SVG: one polygon per cell of the file's basis (k = 5: 1024; Klems Full: 145), well formed
[ "$(grep -c '^<path fill' "$tmpdir/g.svg")" -eq 1024 ] && pass "SVG: 1024 cells for a k = 5 tree" ||
    fail "SVG cells: $(grep -c '^<path fill' "$tmpdir/g.svg")"
expect_status 0 "Klems SVG" -- "$B" plot --comp Rf --incident 30,0 --projection angle -o "$tmpdir/k.svg" "$ref/L_blind45_t4k5_klems.xml"
[ "$(grep -c '^<path fill' "$tmpdir/k.svg")" -eq 145 ] && pass "SVG: 145 patches for Klems Full" ||
    fail "SVG patches: $(grep -c '^<path fill' "$tmpdir/k.svg")"
if command -v xmllint > /dev/null; then
    xmllint --noout "$tmpdir/g.svg" "$tmpdir/k.svg" && pass "SVGs are well-formed XML" || fail "xmllint rejects an SVG"
fi

# DSF = BSDF cos(theta_out): the diffuser's peak DSF is below its peak BSDF, by at most cos(theta)
expect_status 0 "diffuser BSDF" -- "$B" plot --incident 30,0 -o "$tmpdir/d.png" "$ref/L_diffuser_t3k5.xml"
b=$(awk '/^peak/ {print $3}' "$tmpdir/out")
expect_status 0 "diffuser DSF" -- "$B" plot --dsf --incident 30,0 -o "$tmpdir/d.png" "$ref/L_diffuser_t3k5.xml"
d=$(awk '/^peak/ {print $3}' "$tmpdir/out")
awk -v b="$b" -v d="$d" 'BEGIN {exit !(d < b && d > 0.8 * b)}' && pass "DSF peak $d < BSDF peak $b" ||
    fail "DSF $d, BSDF $b"

# errors: one line, nothing left behind
expect_error "no output" "no output given" -- "$B" plot "$ref/L_glass_t4k5.xml"
expect_error "unknown extension" "name a .png or .svg" -- "$B" plot -o "$tmpdir/x.jpg" "$ref/L_glass_t4k5.xml"
expect_error "glass spec" "reads BSDF files" -- "$B" plot -o "$tmpdir/x.png" glass:clear-6mm
expect_error "missing file" "nothere.xml" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/nothere.xml"
printf '<WindowElement><Optical><Layer>\n' > "$tmpdir/trunc.xml"
expect_error "truncated file" "trunc.xml" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/trunc.xml"
expect_error "unknown channel" "no channel 'Solar'" -- "$B" plot --channel Solar -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "log scale from 0" "MIN > 0" -- "$B" plot --range 0,1 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "tiny image" "--size 10" -- "$B" plot --size 10 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "bad component" "--comp Tx" -- "$B" plot --comp Tx -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "grazing beyond 90" "--incident 95,0" -- "$B" plot --incident 95,0 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
[ -z "$(ls "$tmpdir" | grep -E '^x\.(png|jpg)')" ] && pass "no output file after the errors" ||
    fail "left behind: $(ls "$tmpdir")"
expect_status 0 "--help" -- "$B" plot --help
grep -q -- "--projection" "$tmpdir/out" && pass "--help lists the options" || fail "--help: $(head -3 "$tmpdir/out")"
finish
