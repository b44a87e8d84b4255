# shellcheck shell=bash disable=SC2034,SC2154
# (SC2034, SC2154: variables this file sets for, and reads from, the scripts that source it)
# lib.sh - what bench/run and bench/run-long share, sourced by both (bash): how a run is timed
# (`measure`), how S1's accuracy is computed (`ga`), how a row of results.csv is written (`row`),
# and the command line of each configuration they both measure (`case_s1`, `case_gdg`, `case_dd`,
# `case_gbg`, `case_gvg`, `case_gmg`, `case_grg`),
# so that a row recorded one run at a time by run-long is measured exactly as bench/run's rows.
#
# The caller sets, before bench_init: me (its name, for messages), bst, ref, runs; and csv before
# `row`.  bench_init checks the program and the reference data and makes the work directory,
# $work, removed at exit.

# results.csv's columns; `runs` last, so that readers of the first seventeen keep working
results_columns=case,stack,k,precision,option,wall_s,cpu_s,peak_MiB,read_s,combine_s,write_s,size_MB,GA_least_vs_k5,GA_mean_vs_k5,GA_least_vs_k6,GA_mean_vs_k6,dense_GFLOP,runs

bench_init() {
    [ -x "$bst" ] || { echo "$me: no program at $bst: run make first, or set BSDFSTACK" >&2; exit 2; }
    # In a build tree ./bsdfstack is libtool's wrapper script, which sets the library path and
    # starts .libs/bsdfstack (about 10 ms a run): time the program itself, as it runs once installed.
    if [ -x "$(dirname "$bst")/.libs/$(basename "$bst")" ] && head -c 64 "$bst" | grep -q '^#!'; then
        LD_LIBRARY_PATH="$(dirname "$bst")/.libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
        export LD_LIBRARY_PATH
        bst=$(dirname "$bst")/.libs/$(basename "$bst")
    fi
    [ -f "$ref/S1_t4k5.xml" ] || { echo "$me: no reference data in $ref (--ref DIR)" >&2; exit 2; }
    export BSDFSTACK_GLASS_DIR=${BSDFSTACK_GLASS_DIR:-$top/layers/glass}
    # The bench programs link the library, which runs OpenBLAS's own pick of kernels; the program
    # picks better ones where that pick has no AVX2 kernels (bsdfstack(1), OPENBLAS_CORETYPE).
    # Export the program's, so that both measure the kernels users get.
    if [ -z "${OPENBLAS_CORETYPE:-}" ]; then
        local core
        core=$("$bst" combine -v -k 1 glass:clear-6mm -o /dev/null 2>&1 |
            sed -n "s/.*dense algebra: OpenBLAS's \([A-Za-z0-9_]*\) kernels.*/\1/p")
        [ -n "$core" ] && export OPENBLAS_CORETYPE=$core
    fi
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    diffuser=$ref/L_diffuser_t3k5.xml
}

# unxz_ref NAME: the reference file NAME.xz (the k = 6 layers and S1 are stored compressed) as
# $work/NAME
unxz_ref() {
    [ -f "$work/$1" ] || xz -dc "$ref/$1.xz" > "$work/$1"
}

s1_layers() { # K: the S1 layers a combination at order K starts from (k = 6 files above k = 5)
    if [ "$1" -le 5 ]; then echo "$ref/L_glass_t4k5.xml $ref/L_blind0_t4k5.xml $ref/L_glass_t4k5.xml"
    else echo "$ref/L_glass_t4k6.xml $work/L_blind0_t4k6.xml $ref/L_glass_t4k6.xml"; fi
}

# measure ID ARGS...: RUNS runs of `bsdfstack ARGS` (its -o output in $work/ID.xml), the median by
# wall time as "wall cpu rss_MiB read_s write_s size_MB GFLOP run" in $work/ID.m (the lower middle
# one of an even count), a line a run in $work/ID.runs, and the median run's standard error (the
# -v lines: each step's seconds and flops) in $work/ID.err
measure() {
    local id=$1 i
    shift
    : > "$work/$id.runs"
    for i in $(seq "$runs"); do
        /usr/bin/time -f '%e %U %S %M' -o "$work/time" "$bst" "$@" > "$work/stdout" 2> "$work/$id.err.$i" || {
            echo "$me: $id failed: $(tail -1 "$work/$id.err.$i")" >&2; return 1; }
        local rd wr fl
        rd=$(awk '/: read [0-9]+ layer/ { sub(/ s,.*/, ""); print $NF }' "$work/$id.err.$i" | tail -1)
        wr=$(awk '/: wrote / { sub(/ s,.*/, ""); print $NF }' "$work/$id.err.$i" | tail -1)
        fl=$(awk '/: combined, .* GFLOP in dense kernels/ { for (i = 1; i < NF; i++) if ($(i + 1) == "GFLOP") print $i }' "$work/$id.err.$i" | tail -1)
        awk -v rd="${rd:-0}" -v wr="${wr:-0}" -v fl="${fl:--}" -v run="$i" \
            -v sz="$(stat -c %s "$work/$id.xml" 2>/dev/null || echo 0)" \
            '{ printf "%s %.2f %.0f %s %s %.1f %s %s\n", $1, $2 + $3, $4 / 1024, rd, wr, sz / 1e6, fl, run }' "$work/time" >> "$work/$id.runs"
    done
    sort -g "$work/$id.runs" | sed -n "$(( (runs + 1) / 2 ))p" > "$work/$id.m"
    mv "$work/$id.err.$(awk '{ print $8 }' "$work/$id.m")" "$work/$id.err"
    rm -f "$work/$id".err.*
}

# ga ID TRUTH: least and mean GA over the paper's five directions, Tf and Tb, on the k = 6 grid
ga() {
    "$bst" compare -k 6 --only Tf,Tb --incident 25,90 --incident 45,90 --incident 50,90 \
        --incident 45,45 --incident 65,90 "$2" "$work/$1.xml" 2>/dev/null |
        awk '$1 ~ /^[0-9.]+$/ && NF == 7 { g = $4; if (n == 0 || g < lo) lo = g; s += g; n++ }
             END { if (n) printf "%.2f %.2f", lo, s / n; else printf "- -" }'
}

# row CASE STACK K PREC OPTION ID [GA_LEAST_K5 GA_MEAN_K5 GA_LEAST_K6 GA_MEAN_K6]: ID's median as a
# line of $csv; `runs` is the number of runs measure made of it
row() {
    awk -v c="$1" -v s="$2" -v k="$3" -v p="$4" -v o="$5" -v g1="${7:--}" -v g2="${8:--}" \
        -v g3="${9:--}" -v g4="${10:--}" -v n="$(wc -l < "$work/$6.runs")" \
        '{ comb = $1 - $4 - $5; if (comb < 0) comb = 0
           printf "%s,%s,%s,%s,%s,%s,%s,%s,%s,%.2f,%s,%s,%s,%s,%s,%s,%s,%s\n", c, s, k, p, o, $1, $2, $3, $4, comb, $5, $6, g1, g2, g3, g4, $7, n }' \
        "$work/$6.m" >> "$csv"
}

# The configurations both scripts measure, K PREC each.  S1 against the ray-traced S1 at k = 5, and
# at k = 6 where $work/S1_t4k6.xml is there (unxz_ref S1_t4k6.xml); at k >= 6 it needs
# $work/L_blind0_t4k6.xml (unxz_ref L_blind0_t4k6.xml).
case_s1() {
    local k=$1 p=$2 id=s1_k$1_$2 g5 g6="- -"
    # shellcheck disable=SC2046
    measure "$id" combine -v -k "$k" --precision "$p" -o "$work/$id.xml" $(s1_layers "$k")
    g5=$(ga "$id" "$ref/S1_t4k5.xml")
    [ -f "$work/S1_t4k6.xml" ] && g6=$(ga "$id" "$work/S1_t4k6.xml")
    # shellcheck disable=SC2086
    row S1 "pane+blind+pane" "$k" "$p" - "$id" $g5 $g6
}
case_gdg() { # pane + diffuser + pane, dense
    measure "gdg_k$1_$2" combine -v -k "$1" --precision "$2" -o "$work/gdg_k$1_$2.xml" glass:clear-6mm "$diffuser" glass:clear-6mm
    row dense "pane+diffuser+pane" "$1" "$2" - "gdg_k$1_$2"
}
case_gbg() { # pane + the depth-6 blind + pane, factored above k = 6 (needs $work/L_blind0_t4k6.xml)
    measure "gbg_k$1_$2" combine -v -k "$1" --precision "$2" -o "$work/gbg_k$1_$2.xml" glass:clear-6mm "$work/L_blind0_t4k6.xml" glass:clear-6mm
    row factored "pane+blind (k = 6 tree)+pane" "$1" "$2" - "gbg_k$1_$2"
}
case_gvg() { # pane + a matte venetian blind made from its geometry + pane (issue #32), factored
    local id=gvg_k$1_$2
    measure "$id" combine -v -k "$1" --precision "$2" -o "$work/$id.xml" glass:clear-6mm \
        venetian:width=16mm,spacing=14.5mm,tilt=45,r=0.7,t=0.05 glass:clear-6mm
    row factored "pane+matte venetian+pane" "$1" "$2" - "$id"
}
case_gmg() { # pane + a mirror venetian blind made from its geometry + pane (issue #32): sparse, then dense
    local id=gmg_k$1_$2
    measure "$id" combine -v -k "$1" --precision "$2" -o "$work/$id.xml" glass:clear-6mm \
        venetian:width=16mm,spacing=14.5mm,tilt=45,rs=0.765,roughness=0.02 glass:clear-6mm
    row sparse "pane+mirror venetian+pane" "$1" "$2" - "$id"
}
case_grg() { # pane + the reference blind's geometry (mirror and diffuse slats) + pane (issue #32):
    # sparse + rank 16, then dense
    local id=grg_k$1_$2
    measure "$id" combine -v -k "$1" --precision "$2" -o "$work/$id.xml" glass:clear-6mm \
        venetian:width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,roughness=0.02 glass:clear-6mm
    row sparse "pane+mirror and diffuse venetian+pane" "$1" "$2" - "$id"
}
case_dd() { # diffuser + diffuser, dense
    measure "dd_k$1_$2" combine -v -k "$1" --precision "$2" -o "$work/dd_k$1_$2.xml" "$diffuser" "$diffuser"
    row dense "diffuser+diffuser" "$1" "$2" - "dd_k$1_$2"
}
