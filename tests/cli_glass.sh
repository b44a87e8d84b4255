# cli_glass.sh - `bsdfstack glass`: the catalogue, the angular table, channels, inline and spectral
# specs, the catalogue directory override, and errors (exit 1 with one line; usage errors exit 2).
. "${BST_SRCDIR:-.}/tests/clitest.sh"

# expect_exit CODE DESCRIPTION PATTERN -- COMMAND...: one error line matching PATTERN and exit CODE.
expect_exit() {
    local code=$1; shift
    expect_error "$@"
    shift 3
    "$@" >/dev/null 2>&1
    local got=$?
    [ "$got" -eq "$code" ] && pass "exit status $code" || fail "exit $got, expected $code: $*"
}

# rows_ok FILE NCHANNELS: 21 angles per channel; T + R + A = 1 per side; 90 deg gives T = 0, R = 1;
# T falls with angle; 89.9 finite.
rows_ok() {
    awk -F'\t' -v nch="$2" '/^#/ || $1 == "channel" { next }
        { n++; for (i = 3; i <= 8; i++) if ($i !~ /^-?[0-9.]+$/) bad = "not a number: " $0
          if ($3 + $5 + $7 < 0.999996 || $3 + $5 + $7 > 1.000004) bad = "front balance: " $0
          if ($4 + $6 + $8 < 0.999996 || $4 + $6 + $8 > 1.000004) bad = "back balance: " $0
          if ($2 == 90 && ($3 != 0 || $5 != 1)) bad = "90 deg: " $0
          if ($1 == prev && $3 > last + 1e-6) bad = "T rises: " $0
          prev = $1; last = $3 }
        END { if (n != 21 * nch) bad = bad " rows " n; if (bad) { print bad; exit 1 } }' "$1"
}

expect_status 0 "glass --list" -- "$BSDFSTACK" glass --list
for p in clear-3mm clear-4mm clear-6mm clear-8mm clear-10mm clear-12mm lowiron-6mm nfrc-102 nfrc-103 \
    lowe-6mm solarcontrol-6mm laminated-6.4mm; do
    grep -q "^$p " "$tmpdir/out" || fail "catalogue lists $p"
done
sort -c "$tmpdir/out" 2>/dev/null && pass "catalogue sorted" || fail "catalogue not sorted"

expect_status 0 "glass clear-6mm" -- "$BSDFSTACK" glass clear-6mm
msg=$(rows_ok "$tmpdir/out" 2) && pass "clear-6mm table complete and balanced" || fail "clear-6mm: $msg"
grep -q "^# Solar: n 1.5200" "$tmpdir/out" && pass "slab described" || fail "no n line: $(head -3 "$tmpdir/out")"
# T(0) is the catalogue's tn for each channel
awk -F'\t' '$1 == "Visible" && $2 == 0 { v = $3 } $1 == "Solar" && $2 == 0 { s = $3 }
    END { exit !(v == "0.890000" && s == "0.790000") }' "$tmpdir/out" \
    && pass "T(0) = tn" || fail "T(0) differs from the catalogue's tn"

expect_status 0 "glass nfrc-102 with colour bands" -- "$BSDFSTACK" glass --channels Solar,CIE-X,CIE-Y,CIE-Z,Visible glass:nfrc-102
msg=$(rows_ok "$tmpdir/out" 5) && pass "nfrc-102 table complete and balanced" || fail "nfrc-102: $msg"
# WCE's NFRC 102 band values at normal incidence (glass_angular_averaged_wce.tsv), 1e-6
ref="$BST_REFDIR/wce/glass/glass_angular_averaged_wce.tsv"
if [ -r "$ref" ]; then
    awk -F'\t' 'NR == FNR { if ($1 == "NFRC_102" && $3 == 0) want[$2] = $4; next }
        $2 == 0 && ($1 == "Solar" || $1 == "Visible") { b = tolower($1); d = $3 - want[b]
            if (d < -1.5e-6 || d > 1.5e-6) bad = 1; n++ }
        END { exit bad || n != 2 }' "$ref" "$tmpdir/out" \
        && pass "nfrc-102 T(0) matches WCE" || fail "nfrc-102 T(0) differs from WCE"
    # CIE-Y is Visible
    awk -F'\t' '$1 == "CIE-Y" { y[$2] = $3 } $1 == "Visible" { v[$2] = $3 }
        END { for (a in v) if (v[a] != y[a]) exit 1 }' "$tmpdir/out" \
        && pass "CIE-Y = Visible" || fail "CIE-Y differs from Visible"
fi

expect_status 0 "glass inline tn spec" -- "$BSDFSTACK" glass glass:d=4mm,n=1.5,tn=0.85
msg=$(rows_ok "$tmpdir/out" 2) && pass "inline tn table" || fail "inline tn: $msg"
expect_status 0 "glass inline k spec" -- "$BSDFSTACK" glass d=6mm,n=1.52,k=25/m
grep -q "tau0 0.8607" "$tmpdir/out" && pass "tau0 = exp(-k d)" || fail "tau0: $(grep '^#' "$tmpdir/out")"
expect_status 0 "glass t0/r0 spec" -- "$BSDFSTACK" glass t0=0.8,r0=0.08,r0b=0.1
awk -F'\t' '$2 == 0 && $1 == "Visible" { exit !($5 == "0.080000" && $6 == "0.100000") }' "$tmpdir/out" \
    && pass "asymmetric pane" || fail "asymmetric pane: $(grep -m1 '^Visible' "$tmpdir/out")"

# SPEC^ (and glass:SPEC^): the pane reversed as combine installs it, its back side to the exterior:
# Tf <-> Tb, Rf <-> Rb, Af <-> Ab in every row, the slab's sides swapped in the # lines
expect_status 0 "glass t0/r0 spec reversed" -- "$BSDFSTACK" glass 't0=0.8,r0=0.08,r0b=0.1^'
awk -F'\t' '$2 == 0 && $1 == "Visible" { exit !($5 == "0.100000" && $6 == "0.080000") }' "$tmpdir/out" \
    && grep -q '^# reversed (^)' "$tmpdir/out" \
    && grep -q '^# Visible: n 1.6356, tau0 0.8994 (front); n 1.5533, tau0 0.8793 (back)$' "$tmpdir/out" \
    && pass "asymmetric pane reversed, its slab's sides too" || fail "asymmetric pane reversed: $(head -6 "$tmpdir/out")"
for spec in lowe-6mm glass:solarcontrol-6mm; do
    "$BSDFSTACK" glass "$spec" | awk -F'\t' '!/^#/ && $1 != "channel"' > "$tmpdir/plain"
    expect_status 0 "glass $spec^" -- "$BSDFSTACK" glass "$spec^"
    awk -F'\t' -v OFS='\t' '!/^#/ && $1 != "channel" { print $1, $2, $4, $3, $6, $5, $8, $7 }' "$tmpdir/out" \
        | cmp -s - "$tmpdir/plain" && [ "$(wc -l < "$tmpdir/plain")" -eq 42 ] \
        && pass "$spec^: sides swapped in every row" || fail "$spec^: $(head -12 "$tmpdir/out")"
done

# a spectral file by path, and a catalogue directory of one's own
mkdir "$tmpdir/cat"
cp "$BSDFSTACK_GLASS_DIR"/*.tsv "$tmpdir/cat/"
printf '# my pane\nwavelength Tf Tb Rf Rb\n0.3 0.8 0.8 0.08 0.08\n2.5 0.8 0.8 0.08 0.08\n' > "$tmpdir/cat/grey.tsv"
printf 'description my grey pane\nspectral grey.tsv Visible Solar CIE-X\n' > "$tmpdir/cat/grey.glass"
expect_status 0 "spectral file by path" -- "$BSDFSTACK" glass "$tmpdir/cat/grey.tsv"
msg=$(rows_ok "$tmpdir/out" 2) && pass "spectral path table" || fail "spectral path: $msg"
expect_status 0 "BSDFSTACK_GLASS_DIR" -- env BSDFSTACK_GLASS_DIR="$tmpdir/cat" "$BSDFSTACK" glass grey
grep -q "my grey pane" "$tmpdir/out" && msg=$(rows_ok "$tmpdir/out" 3) && pass "own catalogue" \
    || fail "own catalogue: $msg $(head -3 "$tmpdir/out")"
expect_status 0 "own catalogue listed" -- env BSDFSTACK_GLASS_DIR="$tmpdir/cat" "$BSDFSTACK" glass --list
[ "$(cut -c1-5 "$tmpdir/out")" = "grey " ] && pass "only the own pane listed" || fail "list: $(cat "$tmpdir/out")"

# errors: one line, exit 1; usage errors exit 2
expect_exit 1 "unknown pane" "no such pane" -- "$BSDFSTACK" glass clear-7mm
expect_exit 1 "bad value" "tn=2 is not a valid value" -- "$BSDFSTACK" glass d=6mm,n=1.5,tn=2
expect_exit 1 "NaN index" "n=nan is not a valid value" -- "$BSDFSTACK" glass d=6mm,n=nan,tn=0.8
# R0 = 1 (a perfect mirror) would need an infinite index: the message gives the range as it is
# (it said "r0, r0b: 0..1", a range holding 1); just below 1 the model holds, with no NaN
expect_exit 1 "r0=1" "r0=1 is not a valid value \(.*r0, r0b: in \[0, 1\), as a slab reflecting all" -- \
    "$BSDFSTACK" glass t0=0,r0=1
expect_exit 1 "r0b=1" "r0b=1 is not a valid value .*; n: in \(1, 5\); tn, t0: in \[0, 1\];" -- \
    "$BSDFSTACK" glass t0=0,r0=0.5,r0b=1
expect_status 0 "r0=0.999999" -- "$BSDFSTACK" glass t0=0,r0=0.999999
msg=$(rows_ok "$tmpdir/out" 2) && ! grep -qi nan "$tmpdir/out" && pass "a near-mirror's table" || fail "near-mirror: $msg"
expect_exit 1 "negative thickness" "d=-6mm" -- "$BSDFSTACK" glass d=-6mm,n=1.5,k=20
expect_exit 1 "malformed spec" "not key=value" -- "$BSDFSTACK" glass d=6mm,n
expect_exit 1 "missing file" "cannot open" -- "$BSDFSTACK" glass "$tmpdir/none.tsv"
printf '0.4 0.8 0.8 0.08\n0.5 0.8 0.8 0.08 0.08\n' > "$tmpdir/short.tsv"
expect_exit 1 "malformed spectral file" "short.tsv: line 1: column 5" -- "$BSDFSTACK" glass "$tmpdir/short.tsv"
printf '300 0.8 0.8 0.08 0.08\n400 0.8 0.8 0.08 0.08\n' > "$tmpdir/nm.tsv"
expect_exit 1 "nanometres" "micrometres" -- "$BSDFSTACK" glass "$tmpdir/nm.tsv"
# a table short of a band it is averaged over: one line naming the file, the range it covers and the
# band's, exit 1, and no output file (NFRC 103 cut at 0.78 um gave Solar T 0.8425 for 0.7707 and cut
# below 0.6 um Visible 0.8690 for 0.8836, silently)
awk '!/^[0-9]/ || $1 <= 0.78' "$BSDFSTACK_GLASS_DIR/spectral_NFRC_103.tsv" > "$tmpdir/partial2.tsv"
awk '!/^[0-9]/ || $1 >= 0.6' "$BSDFSTACK_GLASS_DIR/spectral_NFRC_103.tsv" > "$tmpdir/partial6.tsv"
expect_exit 1 "table short of the Solar band" \
    "^bsdfstack glass: .*/partial2\.tsv: the data cover 0\.3\.\.0\.78 um; the Solar band needs 0\.3\.\.2\.5 um$" \
    -- "$BSDFSTACK" glass "glass:$tmpdir/partial2.tsv"
expect_exit 1 "table short of the Visible band" \
    "/partial6\.tsv: the data cover 0\.6\.\.2\.5 um; the Visible band needs 0\.38\.\.0\.78 um$" \
    -- "$BSDFSTACK" glass "glass:$tmpdir/partial6.tsv"
expect_exit 1 "combine: a table short of the Solar band" "/partial2\.tsv: the data cover 0\.3\.\.0\.78 um" \
    -- "$BSDFSTACK" combine -k 2 -o "$tmpdir/partial.xml" "glass:$tmpdir/partial2.tsv" glass:nfrc-103
[ ! -e "$tmpdir/partial.xml" ] && pass "combine: no output file" || fail "combine wrote $tmpdir/partial.xml"
# data that cover the visible only serve what asks for the visible only (--channels), and are
# refused where Solar is wanted, asked for or by default
awk '!/^[0-9]/ || ($1 >= 0.38 && $1 <= 0.78)' "$BSDFSTACK_GLASS_DIR/spectral_NFRC_103.tsv" > "$tmpdir/vis.tsv"
expect_status 0 "--channels Visible: visible-only data" -- "$BSDFSTACK" glass --channels Visible "glass:$tmpdir/vis.tsv"
"$BSDFSTACK" glass --channels Visible nfrc-103 > "$tmpdir/full-vis"
cmp -s <(grep -v '^#' "$tmpdir/out") <(grep -v '^#' "$tmpdir/full-vis") && pass "the visible-only table's Visible is NFRC 103's" || fail "visible-only data: Visible differs from NFRC 103's"
expect_exit 1 "glass: visible-only data, Solar by default" "/vis\.tsv: the data cover 0\.38\.\.0\.78 um; the Solar band needs" -- "$BSDFSTACK" glass "glass:$tmpdir/vis.tsv"
expect_exit 1 "glass: visible-only data, Solar asked" "the Solar band needs" -- "$BSDFSTACK" glass --channels Visible,Solar "glass:$tmpdir/vis.tsv"
expect_status 0 "combine --channels Visible: visible-only data" -- "$BSDFSTACK" combine -k 2 --channels Visible -o "$tmpdir/vis.xml" "glass:$tmpdir/vis.tsv" glass:clear-6mm
expect_exit 1 "combine: visible-only data, Solar by default" "the Solar band needs" -- "$BSDFSTACK" combine -k 2 -o "$tmpdir/vis2.xml" "glass:$tmpdir/vis.tsv" glass:clear-6mm
[ ! -e "$tmpdir/vis2.xml" ] && pass "combine: no output file" || fail "combine wrote $tmpdir/vis2.xml"
expect_exit 1 "unknown channel" "no channel NIR" -- "$BSDFSTACK" glass --channels NIR clear-6mm
expect_exit 1 "missing catalogue" "cannot open the glass catalogue" -- env BSDFSTACK_GLASS_DIR="$tmpdir/none" "$BSDFSTACK" glass --list
# From the build tree, with no BSDFSTACK_GLASS_DIR, the program finds the source tree's catalogue
# (bst_glass_catalogue_dir): the README's commands work right after ./quickstart (#16).
expect_status 0 "catalogue found without BSDFSTACK_GLASS_DIR" -- env -u BSDFSTACK_GLASS_DIR "$BSDFSTACK" glass clear-6mm
grep -q "clear float glass, 6 mm" "$tmpdir/out" && pass "its clear-6mm" || fail "clear-6mm without the variable: $(head -c 200 "$tmpdir/out")"
expect_status 0 "combine with a catalogue pane without BSDFSTACK_GLASS_DIR" -- env -u BSDFSTACK_GLASS_DIR "$BSDFSTACK" combine -k 2 -o "$tmpdir/g.xml" glass:clear-6mm glass:nfrc-102
expect_exit 2 "no pane" "no pane given" -- "$BSDFSTACK" glass
expect_exit 2 "two panes" "one pane expected" -- "$BSDFSTACK" glass clear-6mm clear-4mm
expect_exit 2 "unknown option" "unknown option" -- "$BSDFSTACK" glass --frobnicate clear-6mm
finish
