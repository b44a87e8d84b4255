# cli_glass_files.sh - panes as the field ships them, through the program (issue 33): NFRC 102's
# data (../shared/reference/wce) as an Optics file (4 and 9 columns, micrometres and nanometres)
# and as an IGSDB glazing record give `bsdfstack glass` the same table and `combine` the same
# stack (its --absorptance table: T, R and each layer's absorptance per patch) as the data in
# bsdfstack's table; the # lines say the source, the model and why, and the metadata; model=
# overrides the type; the catalogue's coated and laminated panes; a shading record, malformed
# JSON and a bad Optics row: exit 1, one line, no output file.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
data=${BST_REFDIR:?}/wce/data/spectral_NFRC_102.tsv

# optics NCOL NM TYPE > FILE: NFRC 102 as an Optics file
optics() {
    awk -v ncol="$1" -v nm="$2" -v type="$3" 'BEGIN {
            printf "{ Units, Wavelength Units } SI %s\r\n", nm ? "Nanometers" : "Microns"
            printf "{ Thickness } 3.048\r\n{ Emissivity, front back } Emis= 0.84 0.84\r\n"
            printf "{ Product Name: Generic Clear Glass }\r\n{ NFRC ID: 102 }\r\n"
            printf "{ Type: %s }\r\n{ Coated Side: Neither }\r\n{ Uses:  }\r\n", type }
        /^#/ || $1 !~ /^[0-9]/ { next }
        { wl = nm ? sprintf("%.6g", $1 * 1000) : $1
          if (ncol == 4) printf "%s %s %s %s\r\n", wl, $2, $4, $5
          else printf "%s %s 0 %s 0 %s 0 %s 0\r\n", wl, $2, $3, $4, $5 }' "$data"
}
# table FILE: the angular table of `bsdfstack glass` without its # lines
table() { grep -v '^#' "$1"; }

expect_status 0 "glass: the table" -- "$B" glass "$data"
table "$tmpdir/out" > "$tmpdir/tsv.tab"
i=0
for layout in "4 0" "9 0" "4 1" "9 1"; do
    set -- $layout
    optics "$1" "$2" Monolithic > "$tmpdir/CLEAR_3_$i.DAT"
    expect_status 0 "glass: Optics file, $1 columns, nm=$2" -- "$B" glass "$tmpdir/CLEAR_3_$i.DAT"
    table "$tmpdir/out" | cmp -s - "$tmpdir/tsv.tab" && pass "same table as the TSV ($1 columns, nm=$2)" \
        || fail "Optics file ($1 columns, nm=$2): table differs from the TSV's"
    i=$((i + 1))
done
# a bare file name in the working directory, where the catalogue has no pane of that name
expect_status 0 "glass: a file name without a /" -- sh -c "cd '$tmpdir' && '$B' glass CLEAR_3_0.DAT"
table "$tmpdir/out" | cmp -s - "$tmpdir/tsv.tab" && pass "CLEAR_3_0.DAT read from the working directory" \
    || fail "a bare file name: $(head -2 "$tmpdir/out")"
expect_status 0 "glass: the last Optics file again" -- "$B" glass "$tmpdir/CLEAR_3_3.DAT"
grep -q "^# source: optics $tmpdir/CLEAR_3_3.DAT$" "$tmpdir/out" && pass "source line" \
    || fail "source line: $(grep '^# source' "$tmpdir/out")"
grep -q "^# model: uncoated (.*from the type Monolithic)" "$tmpdir/out" && pass "model line" \
    || fail "model line: $(grep '^# model' "$tmpdir/out")"
grep -q "^# product Generic Clear Glass; NFRC ID 102$" "$tmpdir/out" && pass "product line" \
    || fail "product line: $(grep '^# product' "$tmpdir/out")"
grep -q "^# thickness 3.048 mm; coated side Neither$" "$tmpdir/out" && pass "thickness line" \
    || fail "thickness line: $(grep '^# thick' "$tmpdir/out")"

# the stack: NFRC 102 from each file before NFRC 103, per wavelength, Klems quarter
expect_status 0 "combine: the table's pane" -- "$B" combine --klems=quarter --absorptance \
    "$tmpdir/a_tsv.tsv" -o "$tmpdir/tsv.xml" "glass:$data" glass:nfrc-103
for f in CLEAR_3_0.DAT CLEAR_3_3.DAT; do
    expect_status 0 "combine: glass:$f" -- "$B" combine --klems=quarter --absorptance \
        "$tmpdir/a_$f.tsv" -o "$tmpdir/$f.xml" "glass:$tmpdir/$f" glass:nfrc-103
    cmp -s "$tmpdir/a_$f.tsv" "$tmpdir/a_tsv.tsv" && pass "same stack as the TSV ($f)" \
        || fail "stack with $f differs from the TSV's"
done

# the type chooses the model, model= overrides it
optics 4 0 Coated > "$tmpdir/LOWE.DAT"
expect_status 0 "glass: a coated Optics file" -- "$B" glass "$tmpdir/LOWE.DAT"
grep -q "^# model: coated (WINDOW's correlations for coated glass; from the type Coated)" "$tmpdir/out" \
    && pass "Type: Coated gives the coated model" || fail "coated: $(grep '^# model' "$tmpdir/out")"
table "$tmpdir/out" | cmp -s - "$tmpdir/tsv.tab" && fail "the coated model changed nothing" \
    || pass "the coated model differs from the uncoated"
expect_status 0 "glass: model=uncoated" -- "$B" glass "glass:$tmpdir/LOWE.DAT,model=uncoated"
table "$tmpdir/out" | cmp -s - "$tmpdir/tsv.tab" && grep -q "^# model: uncoated (.*model= in the spec, type Coated)" "$tmpdir/out" \
    && pass "model=uncoated gives the table's pane" || fail "model=uncoated: $(grep '^# model' "$tmpdir/out")"

# an IGSDB glazing record of the same data
awk 'BEGIN { printf "{\"product_id\": 363, \"name\": \"Generic Clear Glass\", \"type\": \"glazing\",\n"
             printf " \"subtype\": \"monolithic\", \"nfrc_id\": 102, \"unit_system\": \"SI\",\n"
             printf " \"measured_data\": {\"thickness\": 3.048},\n \"spectral_data\": {\"spectral_data\": [" }
     /^#/ || $1 !~ /^[0-9]/ { next }
     { printf "%s\n  {\"wavelength\": %s, \"T\": %s, \"Rf\": %s, \"Rb\": %s}", n++ ? "," : "", $1, $2, $4, $5 }
     END { print "]}}" }' "$data" > "$tmpdir/363.json"
expect_status 0 "glass: IGSDB glazing record" -- "$B" glass "$tmpdir/363.json"
table "$tmpdir/out" | cmp -s - "$tmpdir/tsv.tab" && grep -q "^# source: igsdb " "$tmpdir/out" \
    && pass "IGSDB record: the table's pane" || fail "IGSDB record: $(head -4 "$tmpdir/out")"

# the catalogue's coated and laminated examples
expect_status 0 "glass --list" -- "$B" glass --list
for p in lowe-6mm solarcontrol-6mm laminated-6.4mm; do
    grep -q "^$p " "$tmpdir/out" && pass "catalogue lists $p" || fail "catalogue lacks $p"
done
for p in lowe-6mm:Coated solarcontrol-6mm:Coated laminated-6.4mm:Laminate; do
    expect_status 0 "glass ${p%%:*}" -- "$B" glass "${p%%:*}"
    grep -q "^# model: coated (.*from the type ${p#*:})" "$tmpdir/out" && pass "${p%%:*} is coated" \
        || fail "${p%%:*}: $(grep '^# model' "$tmpdir/out")"
    # T + R + A = 1; 90 degrees: T = 0
    awk -F'\t' '/^#/ || $1 == "channel" { next } { n++
            if ($3 + $5 + $7 < 0.999996 || $3 + $5 + $7 > 1.000004) bad = $0
            if ($2 == 90 && $3 != 0) bad = $0 }
        END { exit bad != "" || n != 42 }' "$tmpdir/out" && pass "${p%%:*}: balanced, T(90) = 0" \
        || fail "${p%%:*}: table"
done

# info: a pane's model, source and metadata; a combination lists its layers and its panes' models
expect_status 0 "info glass:FILE (coated Optics file)" -- "$B" info "glass:$tmpdir/LOWE.DAT"
grep -q "^ *model: coated (WINDOW's correlations for coated glass; from the type Coated)$" "$tmpdir/out" &&
    grep -q "^ *source: optics $tmpdir/LOWE.DAT$" "$tmpdir/out" &&
    grep -q "^ *product Generic Clear Glass; NFRC ID 102$" "$tmpdir/out" &&
    grep -q "^ *emissivity front 0.84; back 0.84 (kept, not used)$" "$tmpdir/out" &&
    grep -q "^spectral  " "$tmpdir/out" && pass "info glass:FILE: model, source, metadata" ||
    fail "info glass:FILE: $(head -8 "$tmpdir/out")"
"$B" glass "$tmpdir/LOWE.DAT" | awk -F'\t' '$2 == 45 && $1 == "Solar" { printf "%.4f %.4f\n", $3, $5 }' > "$tmpdir/g45"
awk '/^Solar:/ { on = 1 } on && $1 == 45 { printf "%.4f %.4f\n", $2, $3; exit }' "$tmpdir/out" | cmp -s - "$tmpdir/g45" &&
    pass "info glass:FILE: T and R at 45 degrees as bsdfstack glass" || fail "info's T, R at 45: $(cat "$tmpdir/g45")"
expect_status 0 "combine: a coated Optics file and a catalogue pane" -- "$B" combine -k 2 \
    -o "$tmpdir/two.xml" "glass:$tmpdir/LOWE.DAT,model=uncoated" glass:lowe-6mm
expect_status 0 "info on the combination" -- "$B" info "$tmpdir/two.xml"
grep -q "^layers    glass:$tmpdir/LOWE.DAT,model=uncoated, glass:lowe-6mm$" "$tmpdir/out" &&
    grep -q "^ *layer 1 glass:$tmpdir/LOWE.DAT,model=uncoated: uncoated model (model= in the spec, type Coated); source optics $tmpdir/LOWE.DAT; product Generic Clear Glass; NFRC ID 102; thickness 3.048 mm; coated side Neither; emissivity front 0.84; back 0.84$" "$tmpdir/out" &&
    grep -q "^ *layer 2 glass:lowe-6mm: coated model (from the type Coated); source catalogue .*lowe-6mm.glass$" "$tmpdir/out" &&
    pass "info lists the layers and each pane's model and source" || fail "info on two.xml: $(head -6 "$tmpdir/out")"
# a FIFO: read once by the reader, never opened again for its header (that would wait for ever)
if mkfifo "$tmpdir/fifo" 2>/dev/null; then
    # the writer's open waits for a reader: bounded, so that a missing reader fails, not hangs
    timeout 60 sh -c 'cat "$1" > "$2"' sh "$tmpdir/two.xml" "$tmpdir/fifo" &
    expect_status 0 "info on a FIFO" -- timeout 60 "$B" info "$tmpdir/fifo"
    ! grep -q "^layers" "$tmpdir/out" && pass "a FIFO's header is not read again" || fail "FIFO: $(head -3 "$tmpdir/out")"
    wait
fi
expect_status 0 "info on a file not written with panes" -- "$B" info "$tmpdir/tsv.xml"
grep -q "^layers    glass:$data, glass:nfrc-103$" "$tmpdir/out" && pass "its layers" || fail "tsv.xml: $(head -4 "$tmpdir/out")"
expect_error "info on a pane that is not there" "no-such-pane" -- "$B" info glass:no-such-pane
expect_status 2 "info --reference with a pane" -- "$B" info --reference "$tmpdir/two.xml" glass:lowe-6mm

# refused: one line, exit 1, no output file
printf '{"product_id": 9, "type": "shading", "subtype": "woven", "name": "made-up screen",
 "composition": [{"child_product": {"spectral_data": {"dual_band_values": {"Tf_sol_diffuse": 0.05}}},
  "extra_data": {"geometry": {"thread_diameter": 0.3, "thread_spacing": 1, "shade_thickness": 0.4}}}]}\n' \
    > "$tmpdir/screen.json"
expect_error "glass: a shading record" "this is a shading record, not a pane: name it shade:" -- "$B" glass "$tmpdir/screen.json"
expect_error "combine: a shading record" "screen.json: IGSDB shading product \"made-up screen\" \\(woven\\): this is a shading record, not a pane: name it shade:.*screen.json" \
    -- "$B" combine -k 2 -o "$tmpdir/shade.xml" "glass:$tmpdir/screen.json" glass:clear-6mm
[ -e "$tmpdir/shade.xml" ] && fail "a shading record left an output file" || pass "no output file"
printf '{"product_id": 9,\n "type": "glazing",,\n}\n' > "$tmpdir/bad.json"
expect_error "malformed JSON" "bad.json:2:[0-9]+: not valid JSON" -- "$B" combine -k 2 -o "$tmpdir/bad.xml" "glass:$tmpdir/bad.json"
[ -e "$tmpdir/bad.xml" ] && fail "malformed JSON left an output file" || pass "no output file"
optics 4 0 Monolithic | sed '20s/.*/0.5 0.8 0.08/' > "$tmpdir/BAD.DAT"
expect_error "bad Optics row" "BAD.DAT:20: 3 numbers: a data row has 4" -- "$B" glass "$tmpdir/BAD.DAT"
# a hazy product (9 columns with a diffuse part): refused at its row, not read as specular
optics 9 0 Monolithic | awk 'NR == 30 { $3 = "0.02" } { print }' > "$tmpdir/HAZY.DAT"
expect_error "a hazy Optics row" "HAZY.DAT:30: diffuse part Tf_dif = 0.02: a pane is specular" \
    -- "$B" combine -k 2 -o "$tmpdir/hazy.xml" "glass:$tmpdir/HAZY.DAT" glass:clear-6mm
[ -e "$tmpdir/hazy.xml" ] && fail "a hazy pane left an output file" || pass "no output file"
optics 4 0 Tinted > "$tmpdir/TINT.DAT"
expect_error "a type WINDOW does not know" "material type 'Tinted'.*give model=uncoated or model=coated" -- "$B" glass "$tmpdir/TINT.DAT"
expect_error "a bad model" "model=shiny \\(uncoated or coated\\)" -- "$B" glass "clear-6mm,model=shiny"
finish
