# cli_combine.sh - `bsdfstack combine` and `convert` end to end: written files read back, closed
# forms, errors without partial output.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK

# glass + glass at k = 3: the written tree holds the double-glazing closed form at normal incidence
expect_status 0 "combine two panes" -- "$B" combine -k 3 --no-reduce -o "$tmpdir/dg.xml" glass:clear-6mm glass:lowiron-6mm
expect_status 0 "query the result" -- sh -c "echo '0 0 -1 0 0 1' | '$B' query '$tmpdir/dg.xml'"
got=$(cat "$tmpdir/out")
expect_status 0 "pane table" -- "$B" glass clear-6mm
t1=$(awk -F'\t' '$1=="Visible" && $2==0 {print $3}' "$tmpdir/out"); r1=$(awk -F'\t' '$1=="Visible" && $2==0 {print $6}' "$tmpdir/out")
expect_status 0 "pane table 2" -- "$B" glass lowiron-6mm
t2=$(awk -F'\t' '$1=="Visible" && $2==0 {print $3}' "$tmpdir/out"); r2=$(awk -F'\t' '$1=="Visible" && $2==0 {print $5}' "$tmpdir/out")
# the central k = 3 patch averages 0..~10 degrees: compare with 2e-3
awk -v g="$got" -v t1="$t1" -v t2="$t2" -v r1="$r1" -v r2="$r2" 'BEGIN {
    t = t1 * t2 / (1 - r1 * r2); v = g * 3.14159265358979 / 64; d = v - t; if (d < 0) d = -d;
    exit !(d < 2e-3) }' && pass "double glazing T(0) = T1 T2 / (1 - R1 R2)" || fail "double glazing: $got vs $t1 $t2 $r1 $r2"

# spectral panes: combined per wavelength (WCE's NFRC 102 / 103 solar T at normal incidence 0.652314)
# unless --per-channel (band values: 0.645986); Klems quarter, whose polar patch spans 0..9 degrees
expect_status 0 "combine two spectral panes" -- "$B" combine --klems=quarter -o "$tmpdir/sp.xml" glass:nfrc-102 glass:nfrc-103
grep -q "spectral: combined wavelength by wavelength" "$tmpdir/sp.xml" && pass "metadata: per wavelength" || fail "metadata of a spectral stack"
expect_status 0 "query Solar" -- sh -c "echo '0 0 -1 0 0 1' | '$B' query --channel Solar '$tmpdir/sp.xml'"
tsp=$(cat "$tmpdir/out")
expect_status 0 "combine per channel" -- "$B" combine --klems=quarter --per-channel -o "$tmpdir/pc.xml" glass:nfrc-102 glass:nfrc-103
grep -q "spectral: band values combined per channel" "$tmpdir/pc.xml" && pass "metadata: per channel" || fail "metadata of --per-channel"
expect_status 0 "query Solar per channel" -- sh -c "echo '0 0 -1 0 0 1' | '$B' query --channel Solar '$tmpdir/pc.xml'"
tpc=$(cat "$tmpdir/out")
awk -v a="$tsp" -v b="$tpc" 'BEGIN { l = 0.0768802444241; x = a * l - 0.652314; y = b * l - 0.645986;
    exit !(x < 1e-3 && x > -1e-3 && y < 1e-3 && y > -1e-3) }' \
    && pass "solar T(0): per wavelength 0.6523, per channel 0.6460" || fail "solar T(0): $tsp / $tpc (x Lambda 0.07688)"
expect_status 0 "a pane without spectral data" -- "$B" combine -k 2 -o "$tmpdir/mx.xml" glass:nfrc-102 glass:clear-6mm
grep -q "layer 2, glass:clear-6mm, has no spectral data" "$tmpdir/mx.xml" && pass "metadata names the band-only layer" || fail "metadata of a mixed stack"

# a layer known by band values (a file with Solar and Visible channels: here a pane written as Klems
# XML) between spectral panes enters per wavelength as WINDOW's dual-band material; -v says why,
# --per-channel keeps band values; the balance T + R + sum A = 1 holds per patch (to the TSV's 8 digits)
expect_status 0 "a band-value layer as Klems XML" -- "$B" combine --klems=quarter --no-reduce -o "$tmpdir/band.xml" glass:clear-6mm
expect_status 0 "pane + dual-band layer + pane" -- "$B" combine -v --klems=quarter --absorptance "$tmpdir/dab.tsv" \
    -o "$tmpdir/db.xml" glass:nfrc-102 "$tmpdir/band.xml" glass:nfrc-103
grep -q "spectral: combined wavelength by wavelength" "$tmpdir/db.xml" && grep -q "as WINDOW's dual-band material" "$tmpdir/db.xml" \
    && pass "metadata: dual-band layer per wavelength" || fail "metadata of a stack with a dual-band layer"
grep -q "^bsdfstack combine: spectral: combined wavelength by wavelength" "$tmpdir/err" && pass "-v says why" || fail "-v reason"
grep -q "^bsdfstack combine: per wavelength: [1-9][0-9]* steps over the groups of wavelengths, least rcond 0\.[0-9]" "$tmpdir/err" &&
    ! grep -q "layers 1-" "$tmpdir/err" && pass "-v: one line for the groups' steps" || fail "-v per wavelength: $(cat "$tmpdir/err")"
awk -F'\t' 'NR > 1 { n++; d = $6 + $7 + $8 + $9 + $10 - 1; if (d < 0) d = -d; if (d > m) m = d }
    END { exit !(n == 164 && m < 5e-8) }' "$tmpdir/dab.tsv" && pass "dual-band stack: T + R + sum A = 1" || fail "dual-band balance"
# --spectral-tol: 0 (every distinct wavelength) and the default 0.004 agree within the man page's
# 5.1e-5 in T, R and A; the default does group (the files differ); a bad value is a usage error
expect_status 0 "--spectral-tol 0" -- "$B" combine --klems=quarter --spectral-tol 0 --absorptance "$tmpdir/dab0.tsv" \
    -o "$tmpdir/db0.xml" glass:nfrc-102 "$tmpdir/band.xml" glass:nfrc-103
paste "$tmpdir/dab.tsv" "$tmpdir/dab0.tsv" | awk -F'\t' 'NR > 1 { for (i = 6; i <= 10; i++) { d = $i - $(i + 10);
    if (d < 0) d = -d; if (d > m) m = d } } END { exit !(NR == 165 && m > 0 && m < 5.1e-5) }' \
    && pass "--spectral-tol 0 vs the default: within 5.1e-5, not equal" || fail "--spectral-tol 0 vs the default"
expect_error "--spectral-tol out of range" "--spectral-tol -1: a number in \\[0, 1\\]" -- "$B" combine --spectral-tol -1 -o "$tmpdir/x.xml" glass:nfrc-102
# --glass-rule centre (WINDOW's) vs the default patch average, per wavelength and per channel:
# they differ in the Klems 75-90 degree ring (by up to 0.063 in T for NFRC 102 + 103; columns 8
# and 17: T in each file) and agree to
# 1.5e-4 within 10 degrees of the normal
for how in "" --per-channel; do
    for rule in average centre; do
        expect_status 0 "--glass-rule $rule $how" -- "$B" combine --klems --glass-rule $rule $how \
            --absorptance "$tmpdir/gr_$rule.tsv" -o "$tmpdir/gr.xml" glass:nfrc-102 glass:nfrc-103
    done
    paste "$tmpdir/gr_average.tsv" "$tmpdir/gr_centre.tsv" | awk -F'\t' 'NR > 1 { d = $8 - $17; if (d < 0) d = -d;
        if ($4 > 75 && d > ring) ring = d; if ($4 < 10 && d > near) near = d }
        END { exit !(ring > 0.05 && near < 1.5e-4) }' \
        && pass "--glass-rule $how: centre and average differ in the outer ring, agree near normal" \
        || fail "--glass-rule $how: centre vs average"
done
expect_error "--glass-rule unknown" "--glass-rule middle: use average or centre" -- "$B" combine --glass-rule middle -o "$tmpdir/x.xml" glass:nfrc-102
expect_status 0 "the same per channel" -- "$B" combine -v --per-channel --klems=quarter -o "$tmpdir/dpc.xml" glass:nfrc-102 "$tmpdir/band.xml" glass:nfrc-103
grep -q "spectral: band values combined per channel (as asked" "$tmpdir/dpc.xml" && pass "metadata: --per-channel" || fail "metadata of --per-channel with a dual-band layer"

# a reference blind between panes, reduced output, reads back
expect_status 0 "combine glass + blind + glass (k = 4)" -- "$B" combine -k 4 -o "$tmpdir/s.xml" glass:clear-6mm "$ref/L_blind0_t4k5.xml" glass:clear-6mm
expect_status 0 "result reads back" -- sh -c "echo '0 0 -1 0 0 1' | '$B' query '$tmpdir/s.xml'"
expect_status 0 "--only Tf, Klems" -- "$B" combine --klems --only Tf -o "$tmpdir/tf.xml" glass:clear-6mm "$ref/L_blind45_t4k5_klems.xml"
grep -q "Transmission Front" "$tmpdir/tf.xml" && ! grep -q "Reflection Back" "$tmpdir/tf.xml" \
    && pass "--only Tf writes Tf alone" || fail "--only Tf"
expect_status 0 "reversed layer" -- "$B" combine -k 3 -o "$tmpdir/r.xml" "$ref/L_blind45_t4k5.xml^"

# absorptance: T + R + sum of A = 1 for analytic panes (which conserve energy)
expect_status 0 "combine --absorptance" -- "$B" combine -k 3 --absorptance "$tmpdir/abs.tsv" -o "$tmpdir/a3.xml" glass:clear-6mm glass:nfrc-103 glass:lowiron-6mm
awk -F'\t' 'NR == 1 { ok = ($6 == "A1" && $9 == "T"); next } { n++; s = $6 + $7 + $8 + $9 + $10;
    if (s < 1 - 1e-6 || s > 1 + 1e-6 || $6 < 0) bad = 1 } END { exit !(ok && !bad && n == 2 * 2 * 64) }' "$tmpdir/abs.tsv" \
    && pass "absorptance rows balance T + R + A = 1" || fail "absorptance file: $(head -3 "$tmpdir/abs.tsv")"

# errors: one line, non-zero exit, no output file left behind
expect_error "unknown layer file" "nothere.xml: cannot open" -- "$B" combine -o "$tmpdir/x.xml" glass:clear-6mm "$tmpdir/nothere.xml"
[ ! -e "$tmpdir/x.xml" ] && ! ls "$tmpdir"/x.xml.tmp* >/dev/null 2>&1 && pass "no partial output" || fail "partial output left"
expect_error "unknown pane" "^bsdfstack combine: glass:clear-5mm: no such pane" -- "$B" combine -o "$tmpdir/x.xml" glass:clear-5mm glass:clear-6mm
expect_error "k out of range" "-k 9" -- "$B" combine -k 9 -o "$tmpdir/x.xml" glass:clear-6mm
expect_error "no output" "no output file" -- "$B" combine glass:clear-6mm
expect_error "bad component" "unknown component 'Tx'" -- "$B" combine --only Tx -o "$tmpdir/x.xml" glass:clear-6mm
expect_error "unwritable directory" "cannot create output file" -- "$B" combine -o /nonexistent/dir/x.xml glass:clear-6mm

# info: the glass reference file's hemispherical T at normal incidence (libBSDF: 0.8817)
expect_status 0 "info" -- "$B" info "$ref/L_glass_t4k5.xml"
awk '$1 == 0 && $2 == 0 { d = $3 - 0.8817; if (d < 0) d = -d; ok = d < 2e-3 } END { exit !ok }' "$tmpdir/out" \
    && pass "info: T(0) of the clear pane" || fail "info: $(cat "$tmpdir/out")"
# info's reciprocity line: 0 where one transmission is derived from the other, the Monte Carlo
# noise of the Klems blind's two stored transmissions (0.068) otherwise
grep -q '^reciprocity 0 (one transmission is derived from the other)$' "$tmpdir/out" \
    && pass "info: reciprocity of a derived transmission" || fail "info: $(grep reciprocity "$tmpdir/out")"
expect_status 0 "info of a Klems file" -- "$B" info "$ref/L_blind0_t4k5_klems.xml"
awk '$1 == "reciprocity" { v = $2 + 0 } END { exit !(v > 0.01 && v < 0.1) }' "$tmpdir/out" \
    && pass "info: reciprocity of stored transmissions" || fail "info: $(grep reciprocity "$tmpdir/out")"
expect_error "info of a missing file" "cannot open" -- "$B" info "$tmpdir/none.xml"

# convert: unreduced round trip is exact
expect_status 0 "convert --no-reduce" -- "$B" convert --no-reduce -o "$tmpdir/g.xml" "$ref/L_glass_t4k5.xml"
grep -v '^#' "$ref/L_glass_t4k5.query.tsv" | sed 1d | cut -f3-8 > "$tmpdir/q"
"$B" query "$ref/L_glass_t4k5.xml" < "$tmpdir/q" > "$tmpdir/a"
"$B" query "$tmpdir/g.xml" < "$tmpdir/q" > "$tmpdir/b"
cmp -s "$tmpdir/a" "$tmpdir/b" && pass "convert round trip is exact" || fail "convert round trip differs"
expect_status 0 "convert to Klems" -- "$B" convert --klems -o "$tmpdir/k.xml" "$ref/L_glass_t4k5.xml"
grep -q "LBNL/Klems Full" "$tmpdir/k.xml" && pass "Klems output names its basis" || fail "Klems output"

# -v: reading (with the plan's reason for the basis), each step and component, writing; each with
# a time and the peak memory
expect_status 0 "combine -v" -- "$B" combine -v -k 3 -o "$tmpdir/v.xml" glass:clear-6mm "$ref/L_diffuser_t3k5.xml" glass:clear-6mm
n_read=$(grep -c 'read 3 layers onto 64 patches (Shirley-Chiu k = 3, as asked): [0-9.]* s, peak RSS' "$tmpdir/err")
n_step=$(grep -c 'layers 1-[23] Visible \(Tf\|Rf\|Tb\|Rb\): .* s, [0-9.e+-]* GFLOP, rcond .*, peak RSS' "$tmpdir/err")
n_write=$(grep -c 'wrote [0-9.]* MB: [0-9.]* s, peak RSS' "$tmpdir/err")
[ "$n_read" -eq 1 ] && [ "$n_step" -eq 8 ] && [ "$n_write" -eq 1 ] && pass "-v: read, 8 step lines, write" ||
    fail "-v: $n_read read, $n_step step, $n_write write lines: $(cat "$tmpdir/err")"
# the combination's GFLOP is the sum of its steps' (each printed to 3 digits)
awk '/GFLOP, rcond/ { for (i = 1; i < NF; i++) if ($(i + 1) == "GFLOP,") s += $i }
     /combined, [0-9.e+-]* GFLOP in dense kernels/ { t = $4; n++ }
     END { d = s - t; if (d < 0) d = -d; exit !(n == 1 && t > 0 && d <= 2e-3 * t) }' "$tmpdir/err" &&
    pass "-v: the combination's GFLOP sums its steps'" || fail "-v: GFLOP lines: $(grep GFLOP "$tmpdir/err")"
# --incident: the iterated Tf and Tb columns at normal incidence and at (45, 90) sum to the full
# system's hemispherical T of each side as `info` prints it (4 digits); 1024 rows per component
# and direction; --only; usage errors
export BSDFSTACK_GLASS_DIR="${BSDFSTACK_GLASS_DIR:-${BST_SRCDIR:-.}/layers/glass}"
expect_status 0 "combine --incident" -- "$BSDFSTACK" combine -k 5 --incident 0,0 --incident 45,90 \
    glass:clear-6mm "$ref/L_blind0_t4k5.xml" glass:clear-6mm -o "$tmpdir/cols.tsv"
expect_status 0 "combine the whole system" -- "$BSDFSTACK" combine -k 5 --no-reduce \
    glass:clear-6mm "$ref/L_blind0_t4k5.xml" glass:clear-6mm -o "$tmpdir/full.xml"
[ "$(wc -l < "$tmpdir/cols.tsv")" -eq 8193 ] && pass "--incident: 8 x 1024 rows" || fail "--incident rows: $(wc -l < "$tmpdir/cols.tsv")"
"$BSDFSTACK" info "$tmpdir/full.xml" > "$tmpdir/info"
for d in "0 0 Tf 3" "45 90 Tf 3" "0 0 Tb 5" "45 90 Tb 5"; do
    set -- $d
    got=$(awk -F'\t' -v t="$1" -v c="$3" '$2 == c && $3 == t { s += $9 * 3.14159265358979 / 1024 } END { printf "%.4f", s }' "$tmpdir/cols.tsv")
    want=$(awk -v t="$1" -v p="$2" -v f="$4" '$1 == t && $2 == p { print $f; exit }' "$tmpdir/info")
    [ "$got" = "$want" ] && pass "--incident $1,$2 $3: $got as the whole system" || fail "--incident $1,$2 $3: $got vs $want"
done
expect_status 0 "combine --incident --only Rb" -- "$BSDFSTACK" combine -k 3 --incident 0,0 --only Rb \
    glass:clear-6mm glass:clear-6mm -o "$tmpdir/rb.tsv"
[ "$(cut -f2 "$tmpdir/rb.tsv" | sort -u | tr '\n' ' ')" = "Rb comp " ] && pass "--only Rb: only Rb rows" || fail "--only Rb: $(cut -f2 "$tmpdir/rb.tsv" | sort -u)"
expect_error "--incident with --absorptance" "do not go together" -- "$BSDFSTACK" combine --incident 0,0 \
    --absorptance "$tmpdir/a.tsv" glass:clear-6mm -o "$tmpdir/x.tsv"
expect_error "--incident out of range" "incident" -- "$BSDFSTACK" combine --incident 95,0 glass:clear-6mm -o "$tmpdir/x.tsv"
[ ! -e "$tmpdir/x.tsv" ] && pass "no output after a usage error" || fail "output left after a usage error"
# --incident-file: 70 directions (two batches of columns), the same rows as --incident gives for
# the first of them; a bad line is named by file and line, and nothing is written
{ echo "# theta phi"; for i in $(seq 0 69); do echo "$((i % 85)) $((i * 5))"; done; } > "$tmpdir/dirs.txt"
expect_status 0 "combine --incident-file" -- "$BSDFSTACK" combine -k 2 --only Tf --incident-file "$tmpdir/dirs.txt" \
    glass:clear-6mm glass:lowiron-6mm -o "$tmpdir/many.tsv"
[ "$(wc -l < "$tmpdir/many.tsv")" -eq $((2 * 70 * 16 + 1)) ] && pass "--incident-file: 2 channels x 70 x 16 rows" || fail "--incident-file rows: $(wc -l < "$tmpdir/many.tsv")"
"$BSDFSTACK" combine -k 2 --only Tf --incident 1,5 glass:clear-6mm glass:lowiron-6mm -o "$tmpdir/one.tsv"
[ "$(sed -n 2,17p "$tmpdir/one.tsv")" = "$(sed -n 18,33p "$tmpdir/many.tsv")" ] && pass "--incident-file row block = --incident" || fail "--incident-file rows differ from --incident"
printf '10 20\n95 0\n' > "$tmpdir/bad.txt"
expect_error "--incident-file bad line" "bad.txt:2: give THETA PHI" -- "$BSDFSTACK" combine --incident-file "$tmpdir/bad.txt" \
    glass:clear-6mm -o "$tmpdir/y.tsv"
[ ! -e "$tmpdir/y.tsv" ] && pass "no output after a bad direction file" || fail "output left after a bad direction file"
# Two facing Lambertian layers with T = 0.001, R = 1 (T + R = 1.001, inside the input tolerance):
# the inter-reflection multiplies the excess (T = 12.4 at k = 3).  A warning naming the system's
# T + R, an error under --strict with no output.
lambertian() { # T R FILE: a rank-3 tree of order 1 whose four components are Lambertian
    awk -v t="$1" -v r="$2" 'BEGIN {
        pi = 3.14159265358979323846
        print "<?xml version=\"1.0\" encoding=\"UTF-8\"?>"
        print "<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>"
        print "<DataDefinition><IncidentDataStructure>TensorTree3</IncidentDataStructure></DataDefinition>"
        split("Transmission Front,Reflection Front,Transmission Back,Reflection Back", dir, ",")
        for (i = 1; i <= 4; i++) {
            v = sprintf("%.17g", (i % 2 ? t : r) / pi)
            printf "<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength><WavelengthDataBlock>"
            printf "<WavelengthDataDirection>%s</WavelengthDataDirection>", dir[i]
            printf "<AngleBasis>LBNL/Shirley-Chiu</AngleBasis><ScatteringData>{"
            for (k = 0; k < 8; k++) printf " %s", v
            print " }</ScatteringData></WavelengthDataBlock></WavelengthData>"
        }
        print "</Layer></Optical></WindowElement>"
    }' > "$3"
}
lambertian 0.001 1.0 "$tmpdir/mirror.xml"
expect_status 0 "facing near-mirrors combine" -- "$BSDFSTACK" combine -k 3 "$tmpdir/mirror.xml" "$tmpdir/mirror.xml" -o "$tmpdir/mm.xml"
grep -Eq "warning: .*system's front T \+ R, channel Visible, is [0-9.]+ > 1" "$tmpdir/err" && pass "the system's energy excess is a warning" \
    || fail "no warning on the system's T + R: $(cat "$tmpdir/err")"
expect_error "facing near-mirrors under --strict" "T \+ R, channel Visible, is [0-9.]+ > 1 .*\(--strict\)" -- \
    "$BSDFSTACK" combine --strict -k 3 "$tmpdir/mirror.xml" "$tmpdir/mirror.xml" -o "$tmpdir/mm2.xml"
[ ! -e "$tmpdir/mm2.xml" ] && pass "no output under --strict" || fail "output written under --strict"
lambertian 0.001 0.99 "$tmpdir/good.xml"
expect_status 0 "facing 0.99 reflectors" -- "$BSDFSTACK" combine -k 3 "$tmpdir/good.xml" "$tmpdir/good.xml" -o "$tmpdir/gg.xml"
[ ! -s "$tmpdir/err" ] && pass "no warning when energy is conserved" || fail "spurious warning: $(cat "$tmpdir/err")"
# The memory guard: an estimate beyond --max-memory is refused before any work, in one line
# naming the need and the limit, with no output; a generous limit changes nothing.
expect_error "--max-memory below the need" "k = 4 needs about [0-9.]+ GiB \(4 dense components of [0-9.]+ GiB and the combination's work\), more than the 0.00781 GiB --max-memory allows: use a lower -k, --precision single or fewer --channels" -- \
    "$BSDFSTACK" combine -k 4 --max-memory 8M glass:clear-6mm "$ref/L_diffuser_t3k5.xml" -o "$tmpdir/mem.xml"
[ ! -e "$tmpdir/mem.xml" ] && pass "no output when refused for memory" || fail "output written though refused for memory"
expect_status 0 "--max-memory above the need" -- \
    "$BSDFSTACK" combine -k 3 --max-memory 2GiB glass:clear-6mm "$ref/L_diffuser_t3k5.xml" -o "$tmpdir/mem.xml"
expect_error "--max-memory with a bad size" "--max-memory 12x: give a size such as 16G" -- \
    "$BSDFSTACK" combine -k 3 --max-memory 12x glass:clear-6mm -o "$tmpdir/mem2.xml"
# a specular tree is counted sparse: the three reference layers at k = 5 need 4 dense components
# (the blind's), 4 + 3 (the combination's work) times 8 MiB and 64.5 MiB for the rest: 0.118 GiB
# and the two panes' few sparse values (the panes counted dense: 0.181 GiB)
"$BSDFSTACK" combine -k 5 --max-memory 1M "$ref/L_glass_t4k5.xml" "$ref/L_blind0_t4k5.xml" \
    "$ref/L_glass_t4k5.xml" -o "$tmpdir/mem3.xml" 2>"$tmpdir/err"
grep -q "k = 5 needs about 0.11[0-9]* GiB (4 dense components of 0.00781 GiB" "$tmpdir/err" \
    && pass "specular trees are counted sparse" || fail "memory estimate of S1: $(cat "$tmpdir/err")"

# Layers that are all rank-4 trees of order 3, combined at -k 4: a warning that the system is the
# order-3 one repeated (not at -k 3, and not with a pane, which is exact at any order; the blind's
# order-3 average exceeds T + R = 1 by 3 %, which is warned about too); and it
# is: the -k 4 system equals the -k 3 system read at order 4 (GA 100 and FA 100 at every patch)
expect_status 0 "convert the blind to order 3" -- "$BSDFSTACK" convert -k 3 -o "$tmpdir/b3.xml" "$ref/L_blind0_t4k5.xml"
expect_status 0 "convert the pane to order 3" -- "$BSDFSTACK" convert -k 3 -o "$tmpdir/g3.xml" "$ref/L_glass_t4k5.xml"
"$BSDFSTACK" combine -k 4 --no-reduce -o "$tmpdir/s34.xml" "$tmpdir/g3.xml" "$tmpdir/b3.xml" "$tmpdir/g3.xml" 2>"$tmpdir/err"
grep -q "warning: every layer is a rank-4 tensor tree of order 3 or less: -k 4 gives their order-3 system, each patch's values repeated over its 4 finer patches, written as its order-3 trees (with --dense at order 4, 16 times the values); use -k 3, or layers of order 4" "$tmpdir/err" \
    && pass "-k above every tree's order: a warning" || fail "-k above the trees' order: $(cat "$tmpdir/err")"
expect_status 0 "the same at -k 3" -- "$BSDFSTACK" combine -k 3 --no-reduce -o "$tmpdir/s33.xml" "$tmpdir/g3.xml" "$tmpdir/b3.xml" "$tmpdir/g3.xml"
! grep -q "every layer is a rank-4" "$tmpdir/err" && pass "no such warning at the trees' order" || fail "warning at the trees' order: $(cat "$tmpdir/err")"
expect_status 0 "with a pane at -k 4" -- "$BSDFSTACK" combine -k 4 -o "$tmpdir/p34.xml" glass:clear-6mm "$tmpdir/b3.xml"
! grep -q "every layer is a rank-4" "$tmpdir/err" && pass "no such warning with a pane" || fail "warning with a pane: $(cat "$tmpdir/err")"
expect_status 0 "compare the two" -- "$BSDFSTACK" compare -k 4 "$tmpdir/s33.xml" "$tmpdir/s34.xml"
[ "$(grep -c 'all 256 incident patches: GA mean 100.000, least 100.000 .*FA mean 100.00, least 100.00' "$tmpdir/out")" -eq 4 ] \
    && pass "-k 4 of order-3 trees is the order-3 system repeated" || fail "-k 4 against -k 3: $(grep 'all 256' "$tmpdir/out")"
# ... and its file holds the order-3 trees (the same bytes after the header, which names the order
# asked and says which trees are of order 3), reduced or not; with --dense the order-4 ones
for red in --no-reduce ""; do
    # shellcheck disable=SC2086
    "$BSDFSTACK" combine -k 4 $red -o "$tmpdir/c34.xml" "$tmpdir/g3.xml" "$tmpdir/b3.xml" "$tmpdir/g3.xml" 2>/dev/null
    # shellcheck disable=SC2086
    "$BSDFSTACK" combine -k 3 $red -o "$tmpdir/c33.xml" "$tmpdir/g3.xml" "$tmpdir/b3.xml" "$tmpdir/g3.xml" 2>/dev/null
    cmp -s <(sed '1,/^-->/d' "$tmpdir/c33.xml") <(sed '1,/^-->/d' "$tmpdir/c34.xml") \
        && [ "$(grep -c 'a tree of order 3, the order of its values' "$tmpdir/c34.xml")" -eq "$(grep -c '<ScatteringData>' "$tmpdir/c34.xml")" ] \
        && grep -q 'k = 4 (16 x 16 patches' "$tmpdir/c34.xml" \
        && pass "-k 4 ${red:-reduced}: the order-3 trees written" || fail "-k 4 ${red:-reduced}: not the order-3 trees: $(sed -n '/Basis/,/^-->/p' "$tmpdir/c34.xml" | head -8)"
done
"$BSDFSTACK" combine -k 4 --dense --no-reduce -o "$tmpdir/d34.xml" "$tmpdir/g3.xml" "$tmpdir/b3.xml" "$tmpdir/g3.xml" 2>/dev/null
"$BSDFSTACK" info "$tmpdir/d34.xml" > "$tmpdir/out" 2>&1
grep -q "k = 4" "$tmpdir/out" && ! grep -q "a tree of order 3" "$tmpdir/d34.xml" \
    && pass "--dense: the order-4 trees" || fail "--dense: $(cat "$tmpdir/out")"
"$BSDFSTACK" info "$tmpdir/c34.xml" > "$tmpdir/out" 2>&1
grep -q "k = 3" "$tmpdir/out" && pass "info reads the order-3 trees" || fail "info of the -k 4 file: $(cat "$tmpdir/out")"

finish
