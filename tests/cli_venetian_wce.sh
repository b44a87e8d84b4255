#!/bin/sh
# cli_venetian_wce.sh - WINDOW's venetian model on the command line (venetian:...,rule=centre):
# NFRC 102 and WCE's dg_small_102_venetian blind combined in the Klems full basis, both
# distributions; bad rule and distribution values refused with one line naming the key, and no
# output file left behind.
. "${BST_SRCDIR:-.}/tests/clitest.sh"

blind=venetian:width=16mm,spacing=12mm,tilt=45,rule=centre,r=0.6/0.7,t=0.2/0.1
expect_status 0 "NFRC 102 + WINDOW's blind (Klems full)" -- \
    "$BSDFSTACK" combine --klems -o "$tmpdir/sys.xml" glass:nfrc-102 "$blind"
[ -s "$tmpdir/sys.xml" ] && pass "system written" || fail "no system file"
expect_status 0 "uniform distribution, vertical, reversed" -- "$BSDFSTACK" combine --klems \
    -o "$tmpdir/uni.xml" glass:clear-6mm "$blind,distribution=uniform,vertical^"
[ -s "$tmpdir/uni.xml" ] && pass "uniform system written" || fail "no uniform system"

bad() { # bad KEY SPEC: one line naming KEY, no file
    rm -f "$tmpdir/bad.xml"
    expect_error "venetian:$2 refused" "$1" -- "$BSDFSTACK" combine --klems -o "$tmpdir/bad.xml" \
        glass:clear-6mm "venetian:$2"
    [ ! -e "$tmpdir/bad.xml" ] && pass "nothing written for $2" || fail "$2 left a file"
}
bad rule width=16mm,spacing=12mm,rule=foo
bad distribution width=16mm,spacing=12mm,rule=centre,distribution=foo
bad distribution width=16mm,spacing=12mm,distribution=uniform
bad rs width=16mm,spacing=12mm,rule=centre,rs=0.5
bad samples width=16mm,spacing=12mm,rule=centre,samples=8
finish
