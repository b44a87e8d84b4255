#!/bin/sh
# cli_venetian.sh - venetian:SPEC (and perforated:SPEC) layers on the command line: a blind
# (flat, and curved) between two panes combined, converted and compared with the ray-traced
# reference; bad specs refused with one line naming the key, and no output file left behind.
. "${BST_SRCDIR:-.}/tests/clitest.sh"

blind=venetian:width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,roughness=0.02
out="$tmpdir/blind.xml"
expect_status 0 "convert a venetian layer (k = 3)" -- "$BSDFSTACK" convert -k 3 "$blind" -o "$out"
[ -s "$out" ] && pass "layer written" || fail "no layer file"
expect_status 0 "info on it" -- "$BSDFSTACK" info "$out"
expect_status 0 "glass + venetian + glass (k = 3)" -- \
    "$BSDFSTACK" combine -k 3 -o "$tmpdir/sys.xml" glass:clear-6mm "$blind" glass:clear-6mm
[ -s "$tmpdir/sys.xml" ] && pass "system written" || fail "no system file"
expect_status 0 "a vertical blind, reversed, Klems" -- \
    "$BSDFSTACK" combine --klems -o "$tmpdir/vert.xml" "venetian:width=25mm,spacing=20mm,tilt=30,vertical,r=0.5^"
expect_status 0 "curved slats (k = 3)" -- "$BSDFSTACK" combine -k 3 -o "$tmpdir/curved.xml" \
    glass:clear-6mm "venetian:width=25mm,spacing=22mm,tilt=30,curvature=40mm,rs=0.6,r=0.2,roughness=0.03"
[ -s "$tmpdir/curved.xml" ] && pass "system with curved slats written" || fail "no curved system"
expect_status 0 "dual-band slats beside a spectral pane" -- "$BSDFSTACK" combine -k 2 \
    -o "$tmpdir/dual.xml" glass:nfrc-102 "venetian:width=16mm,spacing=14.5mm,rs=0.765/0.7,r=0.085/0.1"
expect_status 0 "info on it" -- "$BSDFSTACK" info "$tmpdir/dual.xml"
grep -q "^channel   Solar" "$tmpdir/out" && grep -q "^channel   Visible" "$tmpdir/out" \
    && pass "Visible and Solar" || fail "channels: $(head -5 "$tmpdir/out")"
if [ -r "$BST_REFDIR/L_blind0_t4k5.xml" ]; then
    expect_status 0 "compare with the ray-traced blind" -- "$BSDFSTACK" compare -k 5 \
        venetian:width=16mm,spacing=14.5mm,tilt=0,rs=0.765,r=0.085,roughness=0.02 \
        "$BST_REFDIR/L_blind0_t4k5.xml" --incident 45,90
    # the Tf row of 45,90: GA >= 99
    awk '/^Tf/ { t = 1 } t && $1 == "45.00" && $2 == "90.00" { print $4; exit }' "$tmpdir/out" |
        awk '{ exit !($1 >= 99) }' && pass "GA >= 99 at (45, 90)" || fail "GA: $(cat "$tmpdir/out")"
fi

# convert --precision single: a dense blind (mirror and diffuse slats, 64 segments: a rank too
# large for the sparse + low-rank form) held in floats, made
# without a double copy (four 1024 x 1024 components: 16 MiB less than in double), written as the
# double one to 1e-5 in every directional-hemispherical value; a wrong value names the option
# (under make check-asan, AddressSanitizer's quarantine of freed memory would count as the
# program's: it is turned off for these runs)
dense=venetian:width=16mm,spacing=14.5mm,tilt=0,rs=0.765,r=0.085,roughness=0.02,samples=2,segments=64
for p in double single; do
    expect_status 0 "convert --precision $p (k = 5)" -- \
        env ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=0" \
        "$BSDFSTACK" convert -v -k 5 --channels Visible \
        --precision $p "$dense" -o "$tmpdir/p_$p.xml"
    eval "peak_$p=\$(awk '/: wrote / { sub(/.*peak RSS /, \"\"); print \$1 + 0 }' \"\$tmpdir/err\")"
done
awk -v s="$peak_single" -v d="$peak_double" 'BEGIN { exit !(s > 0 && d > s + 8) }' &&
    pass "peak RSS: single $peak_single MiB, double $peak_double MiB" ||
    fail "peak RSS: single $peak_single MiB, double $peak_double MiB"
expect_status 0 "compare single with double" -- "$BSDFSTACK" compare "$tmpdir/p_double.xml" "$tmpdir/p_single.xml"
awk '/^  comp  \|hem A - hem B\|/ {on = 1; next} on && NF >= 9 { n++; if ($2 + 0 > 1e-5) bad++ }
     END { exit !(n == 4 && bad == 0) }' "$tmpdir/out" && pass "single writes the double blind" ||
    fail "single and double differ: $(tail -6 "$tmpdir/out")"
expect_error "convert --precision half" "--precision half" -- "$BSDFSTACK" convert -k 3 --precision half \
    "$dense" -o "$tmpdir/half.xml"
[ ! -e "$tmpdir/half.xml" ] && pass "nothing written" || fail "half.xml written"

expect_status 0 "glass + perforated screen + glass (k = 3)" -- "$BSDFSTACK" combine -k 3 \
    -o "$tmpdir/perf.xml" glass:clear-6mm "perforated:x=5mm,y=5mm,radius=1.5mm,thickness=1mm,r=0.7" \
    glass:clear-6mm
[ -s "$tmpdir/perf.xml" ] && pass "system with a screen written" || fail "no screen system"
expect_status 0 "a woven fabric reversed (Klems)" -- "$BSDFSTACK" combine --klems \
    -o "$tmpdir/woven.xml" glass:clear-6mm "woven:diameter=0.5mm,spacing=2mm,r=0.6,t=0.1^"
[ -s "$tmpdir/woven.xml" ] && pass "system with a fabric written" || fail "no fabric system"
rm -f "$tmpdir/bad.xml"
expect_error "woven: a thread thicker than its spacing refused" "diameter" -- "$BSDFSTACK" combine \
    -k 2 -o "$tmpdir/bad.xml" "woven:diameter=3mm,spacing=2mm"
[ ! -e "$tmpdir/bad.xml" ] && pass "nothing written" || fail "a bad fabric left a file"
rm -f "$tmpdir/bad.xml"
expect_error "perforated: a radius past half the pitch refused" "radius" -- "$BSDFSTACK" combine \
    -k 2 -o "$tmpdir/bad.xml" glass:clear-6mm "perforated:x=5mm,y=5mm,radius=3mm"
[ ! -e "$tmpdir/bad.xml" ] && pass "nothing written" || fail "a bad screen left a file"

bad() { # bad KEY SPEC: one line naming KEY, no file
    rm -f "$tmpdir/bad.xml"
    expect_error "venetian:$2 refused" "$1" -- "$BSDFSTACK" combine -k 2 -o "$tmpdir/bad.xml" \
        glass:clear-6mm "venetian:$2"
    [ ! -e "$tmpdir/bad.xml" ] && pass "nothing written for $2" || fail "$2 left a file"
}
bad spacing width=16mm,spacing=0
bad spacing width=16mm,spacing=-1mm
bad rs width=16mm,spacing=14.5mm,rs=1.5
bad r-up width=16mm,spacing=14.5mm,r=0.6,t=0.5
bad r-down width=16mm,spacing=14.5mm,r-down=0.3,rs=0.8
bad curvature width=16mm,spacing=14.5mm,curvature=7mm
bad colour width=16mm,spacing=14.5mm,colour=red
bad width width=wide,spacing=14.5mm
bad tilt width=16mm,spacing=14.5mm,tilt=120
bad "rs \\(Solar\\)" width=16mm,spacing=14.5mm,rs=0.7/1.3
finish
