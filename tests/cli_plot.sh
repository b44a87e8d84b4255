# cli_plot.sh - `bsdfstack plot`: the values it prints against RADIANCE's hemispherical tables and
# against `query`, the physics of where the light goes, the PNG and SVG it writes, and its errors.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK

# Directional-hemispherical values printed with the plot against the reference tables (integrated
# by bsdfquery over 64 x 64 exit cells) at theta 0 and 60, both sides, T and R.  Every row lies on
# a cell boundary (theta 0 on the corner of four k = 5 cells, phi 0, 90 and 270 on an edge of two),
# where the cell is a tie rule: plot takes info's, bsdfquery the one the rounding of the vector
# picks, or for a transmission the file stores only for the other side the mirrored one.  So the
# table must hold plot's value for one of the cells meeting there: at the row's direction, or
# moved 0.01 degrees into each neighbour.  (The theta 30 rows lie on k = 5 ring boundaries too.)
for f in S1_t4k5 L_blind45_t4k5 L_diffuser_t3k5; do
    awk -F'\t' 'NR > 2 && ($2 == 0 || $2 == 60) {print $1 "\t" $2 "\t" $3 "\t" $4 "\t" $5}' \
        "$ref/$f.hemi.tsv" > "$tmpdir/rows"
    bad=0 n=0
    while IFS=$'\t' read -r side th ph T R; do
        s=f; [ "${side#back}" != "$side" ] && s=b
        near="$th,$ph"
        if [ "$th" = 0 ]; then near="$near 0.01,45 0.01,135 0.01,225 0.01,315"
        else near="$near $(awk -v t="$th" -v p="$ph" 'BEGIN {print t "," p - 0.01, t "," p + 0.01}')"; fi
        for c in T R; do
            want=$T; [ $c = R ] && want=$R
            n=$((n + 1)) got=
            for inc in $near; do
                v=$("$B" plot --size 64 --comp $c$s --incident "$inc" -o "$tmpdir/h.png" "$ref/$f.xml" |
                    awk '/hemispherical/ {print $NF}')
                got="$got $v"
                awk -v a="$v" -v b="$want" 'BEGIN {exit !(a != "" && (a - b)^2 < 1e-6)}' && continue 2
            done
            bad=$((bad + 1)); echo "  $f $c$s ($th, $ph): $got, table $want"
        done
    done < "$tmpdir/rows"
    [ "$bad" -eq 0 ] && [ "$n" -ge 12 ] && pass "$f: $n hemispherical values within 1e-3 of the table" ||
        fail "$f: $bad of $n hemispherical values off the table"
done

# The incident cell is info's: plot's hemispherical value equals info's table (4 decimals, one unit
# of the last for the order of summing) at each of its directions, all four components.  Most lie
# on a cell boundary; where a tree stores only Tb (genBSDF's TensorTree4), Tf is Tb with in and out
# exchanged, and plot once took the boundary, exchanged, to the cell mirrored through the normal
# (0,0 gave 0.7062 for L_blind45, info 0.7315).  The Klems file has its band limit at 45 degrees.
for f in L_blind45_t4k5 S1_t4k5 L_blind45_t4k5_klems; do
    "$B" info "$ref/$f.xml" | awk '/directional-hemispherical/ {blocks++}
        blocks == 1 && NF == 6 && $1 ~ /^[0-9]+$/ {print}' > "$tmpdir/info"
    bad=0 n=0
    while read -r th ph Tf Rf Tb Rb; do
        for c in Tf Rf Tb Rb; do
            eval want=\$$c
            got=$("$B" plot --size 64 --comp $c --incident "$th,$ph" -o "$tmpdir/h.png" "$ref/$f.xml" |
                  awk '/hemispherical/ {print $NF}')
            n=$((n + 1))
            awk -v a="$got" -v b="$want" 'BEGIN {exit !(a != "" && (a - b)^2 <= 1.01e-4^2)}' ||
                { bad=$((bad + 1)); echo "  $f $c ($th, $ph): plot $got, info $want"; }
        done
    done < "$tmpdir/info"
    [ "$bad" -eq 0 ] && [ "$n" -eq 44 ] && pass "$f: plot's $n hemispherical values are info's" ||
        fail "$f: $bad of $n hemispherical values differ from info's"
done

# The peak: its value is what query returns there; and where physics puts it.  S1's slats are
# mirrors: light travelling up at 45 degrees is turned to travel down (phi 270) at the same angle.
expect_status 0 "S1 Tf at (45, 90)" -- "$B" plot --incident 45,90 -o "$tmpdir/s1.png" "$ref/S1_t4k5.xml"
peak=$(awk '/^peak/ {print $3, $10, $11}' "$tmpdir/out" | tr -d '(),')
set -- $peak
awk -v t="$2" -v p="$3" 'BEGIN {exit !((t - 45)^2 < 9 && (p - 270)^2 < 25)}' &&
    pass "S1: the peak is the mirrored direction (theta $2, phi $3)" || fail "S1 peak at $peak"
# query reads the vector towards the source: propagation (45, 90) is in = (45, 270), on a cell
# edge; plot takes the cell on its +x side (info's), where in = (45, 269.99) lies
q=$(echo "45 269.99 $2 $3" | "$B" query --degrees Tf "$ref/S1_t4k5.xml")
awk -v a="$1" -v b="$q" 'BEGIN {exit !((a - b)^2 <= (1e-5 * b)^2)}' &&
    pass "S1: peak $1 1/sr = query $q" || fail "S1: peak $1, query $q"
# a clear pane: everything straight through
expect_status 0 "glass Tf at normal incidence" -- "$B" plot --incident 0,0 -o "$tmpdir/g.svg" "$ref/L_glass_t4k5.xml"
awk '/^peak/ {t = $10; gsub(/[(,]/, "", t); ok = t != "" && t + 0 < 3} END {exit !ok}' "$tmpdir/out" &&
    pass "glass: peak at the normal" || fail "glass: $(cat "$tmpdir/out")"

# The PNG: signature, decoded by cairo (tests/pngprobe) at the size plot says; the same bytes on
# standard output (summary on stderr)
probe=$(dirname "$B")/tests/pngprobe
sig=$(od -An -tx1 -N16 "$tmpdir/s1.png" | tr -d ' \n')
[ "$sig" = 89504e470d0a1a0a0000000d49484452 ] && pass "PNG signature and IHDR first" || fail "PNG starts $sig"
"$B" plot --incident 45,90 -o "$tmpdir/s1.png" "$ref/S1_t4k5.xml" > "$tmpdir/out"
want=$(awk '/^image/ {print $2, $4}' "$tmpdir/out")
got=$("$probe" "$tmpdir/s1.png" size)
[ -n "$want" ] && [ "$got" = "$want" ] && pass "cairo reads the PNG back, $got pixels" || fail "PNG size '$got', plot says '$want'"
"$B" plot --incident 45,90 -o - "$ref/S1_t4k5.xml" > "$tmpdir/stdout.png" 2> "$tmpdir/err"
cmp -s "$tmpdir/stdout.png" "$tmpdir/s1.png" && grep -q '^peak' "$tmpdir/err" &&
    pass "-o - writes the same PNG, the summary to stderr" || fail "-o -: $(head -c 200 "$tmpdir/err")"

# The hottest pixel of a glass pair's map lies where the projection puts the specular direction:
# transmission continues the light, reflection mirrors it, both at the propagation direction's
# x, y: radius sin(theta) ("disk") or theta / 90 degrees ("angle") of the disk plot prints, phi
# from +x (right) towards +y (up), image y downwards.  Tolerance: 1.5 k = 6 cells (the peak fills
# its cell; the ring marks the direction inside it).  Computed here, not by the plotting code.
"$B" combine -k 6 -o "$tmpdir/g2.xml" glass:clear-6mm glass:clear-6mm > /dev/null 2>&1 &&
"$B" combine -k 6 --incident 40,30 -o "$tmpdir/g2.tsv" glass:clear-6mm glass:clear-6mm > /dev/null 2>&1 ||
    fail "combining the glass pair"
specular() { # DESCRIPTION FILE COMP PROJECTION
    "$B" plot --comp "$3" --incident 40,30 --projection "$4" -o "$tmpdir/spec.png" "$2" > "$tmpdir/out" 2>&1 ||
        { fail "$1: $(cat "$tmpdir/out")"; return; }
    set -- "$1" $(awk '/^image/ {gsub(/[(),]/, " "); print $8, $9, $11}' "$tmpdir/out") "$4"
    local hot
    hot=$("$probe" "$tmpdir/spec.png" hottest "$2" "$3" "$(awk -v r="$4" 'BEGIN {print r - 2}')")
    awk -v c="$2 $3 $4" -v h="$hot" -v proj="$5" 'BEGIN {
        split(c, g, " "); split(h, p, " "); pi = atan2(0, -1); t = 40 * pi / 180; f = 30 * pi / 180
        rho = proj == "disk" ? g[3] * sin(t) : g[3] * 40 / 90
        x = g[1] + rho * cos(f); y = g[2] - rho * sin(f)
        d = sqrt((p[1] - x)^2 + (p[2] - y)^2); tol = 1.5 * g[3] * sqrt(pi / 4096)
        printf "hottest pixel (%s, %s), luma %s, expected (%.1f, %.1f): %.1f px off (tolerance %.1f)\n", \
            p[1], p[2], p[3], x, y, d, tol
        exit !(d <= tol && p[3] > 240)}' > "$tmpdir/where" &&
        pass "$1: $(cat "$tmpdir/where")" || fail "$1: $(cat "$tmpdir/where")"
    # the disk is where plot says: white just outside its rim at phi 45, the map just inside
    local o i
    o=$("$probe" "$tmpdir/spec.png" pixel $(awk -v c="$2 $3 $4" 'BEGIN {split(c, g, " ");
        printf "%d %d", g[1] + (g[3] + 4) * 0.7071, g[2] - (g[3] + 4) * 0.7071}'))
    i=$("$probe" "$tmpdir/spec.png" pixel $(awk -v c="$2 $3 $4" 'BEGIN {split(c, g, " ");
        printf "%d %d", g[1] + (g[3] - 4) * 0.7071, g[2] - (g[3] - 4) * 0.7071}'))
    [ "$o" = "255 255 255" ] && [ "$i" != "255 255 255" ] && pass "$1: the disk's rim where plot says" ||
        fail "$1: outside the rim '$o', inside '$i'"
}
specular "glass pair Tf, disk" "$tmpdir/g2.xml" Tf disk
specular "glass pair Rf, angle" "$tmpdir/g2.xml" Rf angle
specular "glass pair Tb, disk" "$tmpdir/g2.xml" Tb disk
specular "combine --incident's Tf column, disk" "$tmpdir/g2.tsv" Tf disk

# A column of combine --incident's TSV: the hemispherical value and the peak plot prints are the
# column's own sum of BSDF x Lambda (pi / 4096 at k = 6) and largest value, summed here by awk
expect_status 0 "TSV column Rf" -- "$B" plot --comp Rf -o "$tmpdir/t.png" "$tmpdir/g2.tsv"
awk -F'\t' '$2 == "Rf" && $1 == "Visible" {s += $9 * atan2(0, -1) / 4096; if ($9 > m) m = $9}
    END {printf "%.4f %.6g\n", s, m}' "$tmpdir/g2.tsv" > "$tmpdir/want"
awk '/^peak/ {print $NF, $3}' "$tmpdir/out" > "$tmpdir/got"
cmp -s "$tmpdir/want" "$tmpdir/got" && pass "TSV: hemispherical and peak $(cat "$tmpdir/got") = the column's" ||
    fail "TSV: plot $(cat "$tmpdir/got"), the column $(cat "$tmpdir/want")"
# S1 from its layers' columns: the slats still send light travelling up at 45 degrees down
"$B" combine -k 5 --incident 45,90 --only Tf -o "$tmpdir/s1.tsv" glass:clear-6mm "$ref/S1_t4k5.xml" > /dev/null 2>&1
"$B" combine -k 4 --incident 45,90 --only Rf -o "$tmpdir/s1.tsv.rf" glass:clear-6mm "$ref/S1_t4k5.xml" > /dev/null 2>&1
expect_status 0 "S1 layers' Tf column at (45, 90)" -- "$B" plot --incident 45,90 -o "$tmpdir/s1t.svg" "$tmpdir/s1.tsv"
set -- $(awk '/^peak/ {print $10, $11}' "$tmpdir/out" | tr -d '(),')
awk -v t="${1:-0}" -v p="${2:-0}" 'BEGIN {exit !((t - 45)^2 < 9 && (p - 270)^2 < 25)}' &&
    pass "TSV S1: the peak is the mirrored direction (theta $1, phi $2)" || fail "TSV S1 peak: $(cat "$tmpdir/out")"

# SVG and PDF: one polygon per cell of the file's basis (the cells' hairline outlines are the only
# round-joined paths), well formed; a PDF from %PDF to %%EOF
expect_status 0 "glass SVG" -- "$B" plot --incident 0,0 -o "$tmpdir/g.svg" "$ref/L_glass_t4k5.xml"
[ "$(grep -c 'stroke-linejoin:round' "$tmpdir/g.svg")" -eq 1024 ] && pass "SVG: 1024 cells for a k = 5 tree" ||
    fail "SVG cells: $(grep -c 'stroke-linejoin:round' "$tmpdir/g.svg")"
expect_status 0 "Klems SVG" -- "$B" plot --comp Rf --incident 30,0 --projection angle -o "$tmpdir/k.svg" "$ref/L_blind45_t4k5_klems.xml"
[ "$(grep -c 'stroke-linejoin:round' "$tmpdir/k.svg")" -eq 145 ] && pass "SVG: 145 patches for Klems Full" ||
    fail "SVG patches: $(grep -c 'stroke-linejoin:round' "$tmpdir/k.svg")"
expect_status 0 "PDF by extension" -- "$B" plot --incident 30,0 -o "$tmpdir/k.pdf" "$ref/L_blind45_t4k5_klems.xml"
expect_status 0 "PDF by --format" -- "$B" plot --format pdf --incident 30,0 -o "$tmpdir/k.out" "$ref/L_blind45_t4k5_klems.xml"
ispdf() { [ "$(head -c 5 "$1")" = "%PDF-" ] && [ "$(tail -c 7 "$1" | tr -d '\n\r')" = "%%EOF" ]; }
ispdf "$tmpdir/k.pdf" && ispdf "$tmpdir/k.out" && pass "PDFs run from %PDF- to %%EOF" ||
    fail "PDF: $(head -c 8 "$tmpdir/k.pdf" | od -c | head -1)"
if command -v xmllint > /dev/null; then
    xmllint --noout "$tmpdir/g.svg" "$tmpdir/k.svg" "$tmpdir/s1t.svg" && pass "SVGs are well-formed XML" ||
        fail "xmllint rejects an SVG"
fi

# DSF = BSDF cos(theta_out): the diffuser's peak DSF is below its peak BSDF, by at most cos(theta)
expect_status 0 "diffuser BSDF" -- "$B" plot --incident 30,0 -o "$tmpdir/d.png" "$ref/L_diffuser_t3k5.xml"
b=$(awk '/^peak/ {print $3}' "$tmpdir/out")
expect_status 0 "diffuser DSF" -- "$B" plot --dsf --incident 30,0 -o "$tmpdir/d.png" "$ref/L_diffuser_t3k5.xml"
d=$(awk '/^peak/ {print $3}' "$tmpdir/out")
awk -v b="$b" -v d="$d" 'BEGIN {exit !(d < b && d > 0.8 * b)}' && pass "DSF peak $d < BSDF peak $b" ||
    fail "DSF $d, BSDF $b"

# --curve: the steps against info's table (the same hemispherical values at the same incident
# patches, info printing 4 decimals), both sides, T and R, in the planes phi = 0 and 90, for a
# tensor tree, a Klems file and an isotropic (TensorTree3) file.  At a theta within 1e-6 degrees
# of a step's end either neighbour is accepted.
for f in S1_t4k5 L_blind45_t4k5_klems L_diffuser_t3k5; do
    "$B" info "$ref/$f.xml" > "$tmpdir/info" 2>&1 || fail "info $f"
    for phi in 0 90; do
        "$B" plot --curve --comp Tf,Rf,Tb,Rb --phi $phi --tsv "$tmpdir/c.tsv" -o "$tmpdir/c.png" \
            "$ref/$f.xml" > "$tmpdir/out" 2>&1 || { fail "--curve $f: $(cat "$tmpdir/out")"; continue; }
        awk -F'\t' -v phi=$phi 'FNR == NR { if (FNR > 1) { n[$3]++; a[$3, n[$3]] = $5; b[$3, n[$3]] = $6; v[$3, n[$3]] = $8 }; next }
            /directional-hemispherical/ { blocks++ }
            blocks == 1 && NF >= 6 && $1 ~ /^[0-9]+$/ && $2 == phi {
                split("Tf Rf Tb Rb", comp, " ")
                for (c = 1; c <= 4; c++) {
                    want = $(c + 2); ok = 0
                    for (i = 1; i <= n[comp[c]]; i++)
                        if ($1 >= a[comp[c], i] - 1e-6 && $1 < b[comp[c], i] + 1e-6 && (v[comp[c], i] - want)^2 <= 5.1e-5^2) ok = 1
                    checked++
                    if (!ok) { bad++; printf "theta %s %s: table %s\n", $1, comp[c], want }
                }
            }
            END { printf "%d of %d values", checked - bad, checked; exit !(bad == 0 && checked >= 16) }' \
            "$tmpdir/c.tsv" FS=' ' "$tmpdir/info" > "$tmpdir/cmp" &&
            pass "--curve $f, phi $phi: $(tail -1 "$tmpdir/cmp") equal info's table" ||
            fail "--curve $f, phi $phi: $(tr '\n' ';' < "$tmpdir/cmp")"
    done
done

# The steps' ends in closed form: in the plane phi = 0 a Klems Full file changes patch at the band
# limits 5, 15, .., 75 degrees (9 steps); a Shirley-Chiu tree of order k where sin(theta) crosses
# a cell edge of the concentric map, j / 2^(k-1) (k = 5: 16 steps); every curve runs from 0 to 90
# without a gap.
"$B" plot --curve --tsv "$tmpdir/c.tsv" -o "$tmpdir/c.svg" "$ref/L_blind45_t4k5_klems.xml" "$ref/S1_t4k5.xml" > /dev/null 2>&1
awk -F'\t' 'NR > 1 { k = $1 ~ /klems/; i = ++n[k]
        want = k ? (i == 1 ? 0 : 5 + 10 * (i - 2)) : (i == 1 ? 0 : atan2((i - 1) / 16, sqrt(1 - ((i - 1) / 16)^2)) * 180 / atan2(0, -1))
        if (($5 - want)^2 > 1e-12 || (i > 1 && $5 != last[k])) { bad++; print $1, i, $5, want }
        last[k] = $6 }
    END { exit !(bad == 0 && n[1] == 9 && n[0] == 16 && last[0] == 90 && last[1] == 90) }' "$tmpdir/c.tsv" > "$tmpdir/cmp" &&
    pass "--curve: 9 Klems steps at the band limits, 16 k = 5 steps at asin(j / 16), 0 to 90" ||
    fail "--curve steps: $(head -5 "$tmpdir/cmp")"
xmllint --noout "$tmpdir/c.svg" 2> /dev/null && pass "--curve SVG is well-formed XML" || fail "--curve SVG"
expect_status 0 "--curve PDF, two channels" -- "$B" plot --curve --comp Tf,Rf -o "$tmpdir/c.pdf" "$tmpdir/g2.xml" "$ref/L_glass_t4k5.xml"
ispdf "$tmpdir/c.pdf" && pass "--curve PDF runs from %PDF- to %%EOF" || fail "--curve PDF"
[ "$(grep -c 'steps in the plane' "$tmpdir/out")" -eq 6 ] && pass "--curve: 6 curves (Visible and Solar of the pair, Visible of the pane)" ||
    fail "--curve summary: $(cat "$tmpdir/out")"
"$B" plot --curve -o "$tmpdir/c.png" "$tmpdir/g2.xml" > /dev/null && "$probe" "$tmpdir/c.png" size > /dev/null &&
    pass "--curve PNG reads back" || fail "--curve PNG"

# errors: one line, nothing left behind
expect_error "no output" "no output given" -- "$B" plot "$ref/L_glass_t4k5.xml"
expect_error "unknown extension" "name a .png, .svg or .pdf" -- "$B" plot -o "$tmpdir/x.jpg" "$ref/L_glass_t4k5.xml"
expect_error "unknown format" "--format bmp" -- "$B" plot --format bmp -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "unwritable path" "nodir/x.png" -- "$B" plot -o "$tmpdir/nodir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "unwritable path, --curve" "nodir/x.pdf" -- "$B" plot --curve -o "$tmpdir/nodir/x.pdf" "$ref/L_glass_t4k5.xml"
expect_error "unwritable --tsv" "nodir/x.tsv" -- "$B" plot --curve --tsv "$tmpdir/nodir/x.tsv" -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "glass spec" "reads BSDF files" -- "$B" plot -o "$tmpdir/x.png" glass:clear-6mm
expect_error "glass spec, --curve" "reads BSDF files" -- "$B" plot --curve -o "$tmpdir/x.png" glass:clear-6mm
expect_error "missing file" "nothere.xml" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/nothere.xml"
printf '<WindowElement><Optical><Layer>\n' > "$tmpdir/trunc.xml"
expect_error "truncated file" "trunc.xml" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/trunc.xml"
printf 'theta\tT\n0\t0.8\n' > "$tmpdir/notbsdf.xml"
expect_error "not a BSDF" "notbsdf.xml" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/notbsdf.xml"
expect_error "not a BSDF, --curve" "notbsdf.xml" -- "$B" plot --curve -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml" "$tmpdir/notbsdf.xml"
# tables that are not combine --incident's: another header, a row short of columns, a text where a
# number belongs, a column missing a row, a column of exit patches that are not the basis's
printf 'theta\tT\n0\t0.8\n' > "$tmpdir/other.tsv"
expect_error "TSV, other header" "other.tsv:1: not a 'combine --incident' table" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/other.tsv"
awk 'NR == 3 {sub(/\t[^\t]*\t[^\t]*$/, "")} {print}' "$tmpdir/g2.tsv" > "$tmpdir/short.tsv"
expect_error "TSV, a row of 8 columns" "short.tsv:3: 8 tab-separated columns, expected 10" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/short.tsv"
awk -F'\t' -v OFS='\t' 'NR == 5 {$9 = "n/a"} {print}' "$tmpdir/g2.tsv" > "$tmpdir/text.tsv"
expect_error "TSV, text for a number" "text.tsv:5: columns 3 to 10 must be numbers" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/text.tsv"
awk 'NR != 7' "$tmpdir/g2.tsv" > "$tmpdir/gap.tsv"
expect_error "TSV, a row missing" "4095 exit patches" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/gap.tsv"
awk -F'\t' -v OFS='\t' 'NR > 1 {$7 = 90 - $7} {print}' "$tmpdir/g2.tsv" > "$tmpdir/moved.tsv"
expect_error "TSV, patches not the basis's" "not a column of that basis" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/moved.tsv"
expect_error "TSV, no such direction" "no Tf column at incidence \(10, 0\)" -- "$B" plot --incident 10,0 -o "$tmpdir/x.png" "$tmpdir/g2.tsv"
expect_error "TSV, no such component" "no Tf column .* has Rf" -- "$B" plot -o "$tmpdir/x.png" "$tmpdir/s1.tsv.rf"
expect_error "unknown channel" "no channel 'Solar'" -- "$B" plot --channel Solar -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "log scale from 0" "MIN > 0" -- "$B" plot --range 0,1 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "tiny image" "--size 10" -- "$B" plot --size 10 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "bad component" "--comp Tx" -- "$B" plot --comp Tx -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "a map of two components" "one component" -- "$B" plot --comp Tf,Rf -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "grazing beyond 90" "--incident 95,0" -- "$B" plot --incident 95,0 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "--curve with a map's option" "--incident draws a map" -- "$B" plot --curve --incident 30,0 -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "--tsv without --curve" "--tsv goes with --curve" -- "$B" plot --tsv "$tmpdir/x.tsv" -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml"
expect_error "two files without --curve" "one file expected" -- "$B" plot -o "$tmpdir/x.png" "$ref/L_glass_t4k5.xml" "$ref/S1_t4k5.xml"
[ -z "$(ls "$tmpdir" | grep -E '^x\.|^nodir')" ] && pass "no output file after the errors" ||
    fail "left behind: $(ls "$tmpdir")"
expect_status 0 "--help" -- "$B" plot --help
grep -q -- "--projection" "$tmpdir/out" && grep -q -- "--curve" "$tmpdir/out" && pass "--help lists the options" ||
    fail "--help: $(head -3 "$tmpdir/out")"
finish
