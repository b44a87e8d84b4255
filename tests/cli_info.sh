# cli_info.sh - `bsdfstack info`: what it says of a file's components (stored, derived by
# reciprocity, absent), the energy and reciprocity lines where components are absent, a reversed
# layer (a trailing ^, as combine reads it) for files, panes and shades, and its argument errors.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK

# --- components: stored, derived, absent
expect_status 0 "combine --only Rb" -- "$B" combine -k 1 --only Rb -o "$tmpdir/rb.xml" glass:clear-6mm
expect_status 0 "info on a file holding Rb alone" -- "$B" info "$tmpdir/rb.xml"
cp "$tmpdir/out" "$tmpdir/rb.info"
grep -q '^channel   Visible: Tf(absent) Rf(absent) Tb(absent) Rb$' "$tmpdir/rb.info" \
    && pass "absent components are marked absent" || fail "channel line: $(grep '^channel' "$tmpdir/rb.info")"
grep -q 'derived' "$tmpdir/rb.info" && fail "absent components called derived: $(grep derived "$tmpdir/rb.info")" \
    || pass "nothing is called derived"
awk '$1 ~ /^[0-9]+$/ && NF == 6 { n++; if ($3 != "-" || $4 != "-" || $5 != "-" || $6 !~ /^0\.[0-9]+$/) bad = $0 }
    END { exit !(n > 0 && !bad) }' "$tmpdir/rb.info" \
    && pass "absent components print '-', Rb its values" || fail "table: $(grep -E '^ +[0-9]+ +[0-9]+ ' "$tmpdir/rb.info" | head -3)"
grep -q '^energy    front: not computed (neither Tf nor Rf is in the file)$' "$tmpdir/rb.info" \
    && pass "no T + R claimed for the front" || fail "front energy: $(grep '^energy' "$tmpdir/rb.info")"
grep -Eq '^energy    back : largest Rb = 0\.[0-9]+ at patch [0-9]+ \(theta [0-9.]+ deg; Tb absent\)$' \
    "$tmpdir/rb.info" && pass "the back's line gives Rb alone and names Tb missing" \
    || fail "back energy: $(grep '^energy' "$tmpdir/rb.info")"
grep -q '^reciprocity not computed (neither Tf nor Tb is in the file)$' "$tmpdir/rb.info" \
    && pass "no reciprocity claimed without transmissions" || fail "$(grep '^reciprocity' "$tmpdir/rb.info")"

expect_status 0 "combine --only Tf" -- "$B" combine -k 1 --only Tf -o "$tmpdir/tf.xml" glass:lowe-6mm
expect_status 0 "info on a file holding Tf alone" -- "$B" info "$tmpdir/tf.xml"
grep -q '^channel   Solar: Tf Rf(absent) Tb(derived) Rb(absent)$' "$tmpdir/out" \
    && pass "Tb derived, the reflections absent" || fail "channel line: $(grep '^channel' "$tmpdir/out")"
grep -Eq '^energy    front: largest Tf = 0\.[0-9]+ at patch [0-9]+ \(theta [0-9.]+ deg; Rf absent\)$' "$tmpdir/out" \
    && pass "the front's line gives Tf alone" || fail "energy: $(grep '^energy' "$tmpdir/out")"
grep -q '^reciprocity 0 (one transmission is derived from the other)$' "$tmpdir/out" \
    && pass "a derived Tb is reciprocal" || fail "$(grep '^reciprocity' "$tmpdir/out")"

# a whole file: the energy lines as before, nothing marked absent
expect_status 0 "combine a coated pane" -- "$B" combine -k 1 -o "$tmpdir/g.xml" glass:lowe-6mm
expect_status 0 "info on it" -- "$B" info "$tmpdir/g.xml"
cp "$tmpdir/out" "$tmpdir/g.info"
grep -q '^channel   Visible: Tf(derived) Rf Tb Rb$' "$tmpdir/g.info" && ! grep -q absent "$tmpdir/g.info" \
    && grep -Eq '^energy    front: largest T \+ R = 0\.[0-9]+ at patch' "$tmpdir/g.info" \
    && pass "a whole file: one derived transmission, T + R per side" || fail "info: $(head -12 "$tmpdir/g.info")"

# --- FILE^: the layer reversed, its back side to the exterior: the component marks and the columns
# swap sides (the pane is isotropic: at normal incidence front and back trade places exactly), and
# it is what combine makes of the same layer reversed
expect_status 0 "info FILE^" -- "$B" info "$tmpdir/g.xml^"
cp "$tmpdir/out" "$tmpdir/gr.info"
grep -q '^reversed  ' "$tmpdir/gr.info" && grep -q '^channel   Visible: Tf Rf Tb(derived) Rb$' "$tmpdir/gr.info" \
    && pass "FILE^ says it is reversed; its marks follow the sides" || fail "info FILE^: $(head -8 "$tmpdir/gr.info")"
normal() { awk '$1 == "0" && $2 == "0" { print $3, $4, $5, $6 }' "$1"; }
swapped=$(normal "$tmpdir/g.info" | awk '{ a = $1; b = $2; c = $3; d = $4; print c, d, a, b }')
[ -n "$swapped" ] && [ "$(normal "$tmpdir/gr.info")" = "$swapped" ] \
    && pass "FILE^: front and back values swapped" || fail "FILE^: $(normal "$tmpdir/gr.info") vs $swapped"
expect_status 0 "combine the pane reversed" -- "$B" combine -k 1 -o "$tmpdir/gc.xml" 'glass:lowe-6mm^'
expect_status 0 "info on it" -- "$B" info "$tmpdir/gc.xml"
[ "$(normal "$tmpdir/out")" = "$(normal "$tmpdir/gr.info")" ] \
    && pass "info FILE^ gives what combine makes of LAYER^" || fail "$(normal "$tmpdir/out") vs $(normal "$tmpdir/gr.info")"
expect_status 0 "info on Rb alone, reversed" -- "$B" info "$tmpdir/rb.xml^"
grep -q '^channel   Visible: Tf(absent) Rf Tb(absent) Rb(absent)$' "$tmpdir/out" \
    && grep -q '^energy    back : not computed' "$tmpdir/out" \
    && pass "absent components move with the sides" || fail "info: $(grep -E '^(channel|energy)' "$tmpdir/out")"
expect_error "info on a missing FILE^ names the file" "info: $tmpdir/none\\.xml: cannot open" -- \
    "$B" info "$tmpdir/none.xml^"

# glass:SPEC^: the pane's columns swapped
expect_status 0 "info glass:lowe-6mm" -- "$B" info glass:lowe-6mm
awk '/^Visible:/ { on = 1 } on && $1 == "45" { print $2, $3, $4, $5; exit }' "$tmpdir/out" > "$tmpdir/p45"
expect_status 0 "info glass:lowe-6mm^" -- "$B" info 'glass:lowe-6mm^'
awk '/^Visible:/ { on = 1 } on && $1 == "45" { print $4, $5, $2, $3; exit }' "$tmpdir/out" > "$tmpdir/r45"
grep -q '^reversed  ' "$tmpdir/out" && [ -s "$tmpdir/p45" ] && cmp -s "$tmpdir/p45" "$tmpdir/r45" \
    && pass "glass:SPEC^: front and back swapped" || fail "glass:SPEC^: $(cat "$tmpdir/p45") vs $(cat "$tmpdir/r45")"

# a shade's spec^: the model, with the ^ kept and said
v='venetian:width=16mm,spacing=14.5mm,tilt=45,r=0.3'
expect_status 0 "info venetian:...^" -- "$B" info "$v^"
grep -q '^model     venetian:.*,rs=0^$' "$tmpdir/out" && grep -q '^reversed  ' "$tmpdir/out" \
    && pass "a shade's ^ is kept and said" || fail "info $v^: $(cat "$tmpdir/out")"
expect_status 0 "info venetian:..." -- "$B" info "$v"
grep -q '\^\|^reversed' "$tmpdir/out" && fail "unreversed shade: $(cat "$tmpdir/out")" || pass "no ^ without one"

# --- arguments
expect_error "info -" "info: '-': reading standard input is not supported" -- "$B" info -
expect_status 2 "info - is a usage error" -- "$B" info -
expect_error "info with an unknown option" "info: unknown option '--bogus'" -- "$B" info --bogus
expect_error "info --reference without a value" "info: option '--reference' needs a value" -- "$B" info --reference
expect_error "info --max-memory SIZE and no file" "info: no file given" -- "$B" info --max-memory 1G
finish
