# cli_wce.sh - Windows-CalcEngine's case dg_full_102_bsdf2011SA1 end to end through the CLI
# (issue 15): WCE's two-band shade 2011-SA1 (its Solar and Visible Klems full matrices,
# ../shared/reference/wce/matrices, written as one Klems XML file by bench/wce_shade) behind
# glass:nfrc-102 from its spectral data, panes at patch centres (--glass-rule centre, WCE's),
# every wavelength combined (--spectral-tol 0, as WCE does).  The --absorptance table's Solar T and
# R (directional-hemispherical) and both layers' absorptance, per incident patch and side (1160
# rows), against WCE's results within WCE's own test tolerance, 1e-6 absolute (wce/README.md).
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK
shade=$(dirname "$B")/bench/wce_shade
results=$ref/wce/cases/dg_full_102_bsdf2011SA1_results.tsv

"$shade" "$ref" "$tmpdir/sa1.xml" > /dev/null || fail "bench/wce_shade could not write the shade"
expect_status 0 "NFRC 102 + 2011-SA1, Klems full, per wavelength" -- "$B" combine --klems \
    --glass-rule centre --spectral-tol 0 --absorptance "$tmpdir/a.tsv" -o "$tmpdir/s.xml" \
    glass:nfrc-102 "$tmpdir/sa1.xml"
grep -q "as WINDOW's dual-band material" "$tmpdir/s.xml" && pass "metadata: the shade as dual-band material" \
    || fail "metadata of the per-wavelength combination"

# diff TSV: WCE's Solar rows (T_dirhem, R_dirhem, Abs) against ours: "rows missing largest"
diff_wce() {
    awk -F'\t' 'FNR == NR { if (FNR > 1 && $1 == "Solar") { k = $2 " " ($3 + 1); T[k] = $(NF - 1)
                R[k] = $NF; for (i = 6; i <= NF - 2; i++) A[k " " (i - 5)] = $i }; next }
        /^#/ || $2 != "solar" || ($3 != "T_dirhem" && $3 != "R_dirhem" && $3 != "Abs") { next }
        { v = $3 == "T_dirhem" ? T[$4 " " $6] : $3 == "R_dirhem" ? R[$4 " " $6] : A[$4 " " $6 " " $5]
          if (v == "") { miss++; next }
          d = v - $9; if (d < 0) d = -d; if (d > m) m = d; n++ }
        END { printf "%d %d %.3g\n", n, miss, m }' "$1" "$results"
}
set -- $(diff_wce "$tmpdir/a.tsv")
[ "$1" = 1160 ] && [ "$2" = 0 ] && awk -v d="$3" 'BEGIN { exit !(d <= 1e-6) }' \
    && pass "WCE's 1160 Solar rows within 1e-6 (largest difference $3)" \
    || fail "against WCE: $1 rows, $2 missing, largest difference $3 (tolerance 1e-6)"

# --channels Solar alone reads no Visible: band values, with a warning, and WCE's answer missed
expect_status 0 "--channels Solar" -- "$B" combine --klems --glass-rule centre --channels Solar \
    --absorptance "$tmpdir/a1.tsv" -o "$tmpdir/s1.xml" glass:nfrc-102 "$tmpdir/sa1.xml"
grep -q "warning: .*has Solar but not Visible.*name Visible in --channels too" "$tmpdir/err" \
    && pass "--channels Solar: the warning names the missing Visible" || fail "--channels Solar: no warning"
set -- $(diff_wce "$tmpdir/a1.tsv")
awk -v d="$3" 'BEGIN { exit !(d > 1e-3) }' && pass "--channels Solar: band values, $3 from WCE" \
    || fail "--channels Solar: $3 from WCE, expected band values (> 1e-3)"
# a pane without spectral data is no dual-band material: no such warning for it
expect_status 0 "--channels Solar, two panes" -- "$B" combine --klems --channels Solar -o "$tmpdir/p.xml" \
    glass:nfrc-102 glass:clear-6mm
grep -q "warning" "$tmpdir/err" && fail "--channels Solar, two panes: $(cat "$tmpdir/err")" \
    || pass "--channels Solar, two panes: no warning"
finish
