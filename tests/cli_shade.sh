#!/bin/sh
# cli_shade.sh - IGSDB shading records as layers on the command line (shade:FILE.json[,KEYS]):
# a made-up venetian record gives the very system its hand-written venetian: spec gives (the data
# of the two output files identical), overrides too; info prints the product and the model; a
# batch line takes it; a perforated and a woven record combine, also in WINDOW's models
# (rule=centre, which the model printed names); refusals are one line, a non-zero exit and no
# output file: malformed JSON, a missing field, a glazing record given to shade:, a shading
# record given to glass:, an unknown override key, a rule that is neither.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
cd "$tmpdir" || exit 99

# record NAME SUBTYPE MATERIAL-MEASURED OPTICS GEOMETRY: a v1 shading record
record() {
    cat > "$1" <<EOT
{"product_id": 9100, "name": "made-up $2", "type": "shading", "subtype": "$2",
 "manufacturer_name": "nobody", "measured_data": {"permeability_factor": 0.1},
 "composition": [{"child_product": {"product_id": 9001, "name": "white slat", "type": "material",
   "subtype": "monolithic", "measured_data": {$3}, "spectral_data": $4},
  "extra_data": {"geometry": {$5}}}]}
EOT
}
dualband='{"dual_band_values": {"Rf_vis_diffuse": 0.7, "Rb_vis_diffuse": 0.55, "Rf_vis_specular": 0.05,
 "Rb_vis_specular": 0.05, "Tf_vis_diffuse": 0.04, "Rf_sol_diffuse": 0.6, "Rb_sol_diffuse": 0.5,
 "Rf_sol_specular": 0.1, "Rb_sol_specular": 0.1, "Tf_sol_diffuse": 0.05, "Tb_sol_diffuse": 0.05}}'
record blind.json venetian '"thickness": 0.2' "$dualband" \
    '"slat_width": 16, "slat_spacing": 12, "slat_curvature": 0, "slat_tilt": 45, "number_segments": 5'
spec=venetian:width=16mm,spacing=12mm,tilt=45,segments=5,r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05,rs=0.05/0.1

# the data of two outputs (their header comments name the command and the layers)
data() { sed -n '/<WindowElement/,$p' "$1"; }
expect_status 0 "glass + shade:blind.json + glass (Klems quarter)" -- \
    "$B" combine --klems=quarter -o rec.xml glass:clear-6mm shade:blind.json glass:clear-6mm
expect_status 0 "the same with the hand-written spec" -- \
    "$B" combine --klems=quarter -o hand.xml glass:clear-6mm "$spec" glass:clear-6mm
data hand.xml > hand.xml.data
[ -s rec.xml ] && data rec.xml | cmp -s - hand.xml.data && pass "the record's system is the spec's" ||
    fail "shade:blind.json and $spec differ"
expect_status 0 "overrides: tilt=-30,segments=8" -- \
    "$B" combine --klems=quarter -o rec30.xml "shade:blind.json,tilt=-30,segments=8^"
expect_status 0 "their spec" -- "$B" combine --klems=quarter -o hand30.xml \
    "venetian:width=16mm,spacing=12mm,tilt=-30,segments=8,r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05,rs=0.05/0.1^"
data hand30.xml > hand30.xml.data
data rec30.xml | cmp -s - hand30.xml.data && pass "overrides give the spec's layer" ||
    fail "overrides differ from the spec"

expect_status 0 "info shade:blind.json" -- "$B" info shade:blind.json,tilt=10
grep -q "^product   made-up venetian (IGSDB 9100, nobody), venetian" out &&
    grep -q "^geometry  slat width 16 mm, spacing 12 mm, curvature 0 mm, tilt 45, 5 segments" out &&
    grep -q "^model     venetian:width=16mm,spacing=12mm,tilt=10,curvature=0mm,segments=5,r-up=0.7/0.6," out &&
    grep -q "^ *Solar   specular       -       -  0.1000  0.1000  diffuse  0.0500  0.0500  0.6000  0.5000" out &&
    pass "info: product, geometry, bands, model" || fail "info: $(cat out)"

# perforated (circular: dimension_x is the radius) and woven records, spectral rows
rows='{"spectral_data": [{"wavelength": 0.3, "T": 0.1, "Rf": 0.6, "Rb": 0.3},
 {"wavelength": 2.5, "T": 0.1, "Rf": 0.6, "Rb": 0.3}]}'
record screen.json perforated-screen '"thickness": 0.5' "$rows" \
    '"spacing_x": 5, "spacing_y": 5, "dimension_x": 1.5, "dimension_y": 0, "perforation_type": "Circular"'
record fabric.json woven '"thickness": 0.6' "$rows" \
    '"thread_diameter": 0.5, "thread_spacing": 2, "shade_thickness": 0.6'
expect_status 0 "info shade:screen.json" -- "$B" info shade:screen.json
grep -q "^model     perforated:x=5mm,y=5mm,thickness=0.5mm,radius=1.5mm,rf=0.6,rb=0.3,t=0.1" out &&
    pass "screen: radius = dimension_x, thickness the material's" || fail "screen: $(grep model out)"
expect_status 0 "glass + screen + fabric (k = 2)" -- \
    "$B" combine -k 2 -o sf.xml glass:clear-6mm shade:screen.json shade:fabric.json,samples=4
[ -s sf.xml ] && pass "screen and fabric combined" || fail "no sf.xml"
expect_status 0 "convert shade:fabric.json" -- "$B" convert -k 2 shade:fabric.json -o f.xml
# WINDOW's models by an override: the model says so, and a Klems stack takes them
expect_status 0 "info shade:screen.json,rule=centre" -- "$B" info shade:screen.json,rule=centre
grep -q "^model     perforated:x=5mm,.*,t=0.1,rule=centre$" out &&
    pass "screen: rule=centre in the model" || fail "screen rule: $(grep model out)"
expect_status 0 "glass + WINDOW screen + WINDOW fabric (Klems quarter)" -- \
    "$B" combine --klems=quarter -o wf.xml glass:clear-6mm shade:screen.json,rule=centre \
    woven:diameter=0.5mm,spacing=2mm,r=0.6,t=0.1,rule=centre
[ -s wf.xml ] && pass "WINDOW screen and fabric combined" || fail "no wf.xml"

# a batch line takes it
printf 'b1.xml glass:clear-6mm shade:blind.json,tilt=0\n' > stacks.txt
expect_status 0 "batch with a shade: layer" -- "$B" batch -k 2 stacks.txt
[ -s b1.xml ] && pass "batch output written" || fail "no b1.xml"

# refusals: one line, non-zero exit, no output
bad() { # bad DESCRIPTION PATTERN LAYER...
    local what=$1 pat=$2
    shift 2
    rm -f bad.xml
    expect_error "$what" "$pat" -- "$B" combine -k 2 -o bad.xml "$@"
    [ ! -e bad.xml ] && pass "nothing written: $what" || fail "$what left bad.xml"
}
printf '{"product_id": 1, "type": "shading",,}' > broken.json
bad "malformed JSON" "broken.json:1:[0-9]+: not valid JSON" shade:broken.json
record noslat.json venetian '' "$dualband" '"slat_spacing": 12, "slat_curvature": 0, "number_segments": 5'
bad "a missing field" "noslat.json: composition\[0\]\.extra_data\.geometry\.slat_width: missing" shade:noslat.json
cat > pane.json <<'EOT'
{"product_id": 363, "type": "glazing", "subtype": "monolithic", "name": "clear",
 "spectral_data": {"spectral_data": [{"wavelength": 0.3, "T": 0.8, "Rf": 0.08, "Rb": 0.08},
  {"wavelength": 2.5, "T": 0.8, "Rf": 0.08, "Rb": 0.08}]}}
EOT
bad "a glazing record given to shade:" "pane.json: type \"glazing\": not a shading product \(a pane: read it as glass:FILE\)" \
    shade:pane.json
bad "a shading record given to glass:" "blind.json: .*this is a shading record, not a pane: name it shade:blind.json" \
    glass:blind.json
bad "an unknown override key" "blind.json: venetian: unknown key 'colour'" shade:blind.json,tilt=30,colour=red
bad "a rule that is neither" "perforated: rule: 'middle' is not average or centre" \
    perforated:x=5mm,y=5mm,radius=1mm,rule=middle
bad "a bad override value" "blind.json: venetian: tilt = 100 is not between" shade:blind.json,tilt=100
bad "a screen record without its sheet's thickness" "thickness: missing" \
    "shade:$(record thin.json perforated-screen '' "$rows" '"spacing_x": 5, "spacing_y": 5, "dimension_x": 1.5, "perforation_type": "Circular"'; echo thin.json)"
bad "no such record" "none.json" shade:none.json
finish
