#!/usr/bin/env bash
# plots.sh CSV OUTDIR - the report's two plots with gnuplot: time and peak memory against
# N = 4^k (log-log, each series' exponent fitted to its points at k >= 5), and S1's least GA
# against the k = 6 truth against CPU seconds.
set -euo pipefail
csv=$1 out=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# one data file per series: N wall_s peak_MiB
series=()
while IFS= read -r key; do
    f=$tmp/$(echo "$key" | tr ' +' '__').dat
    awk -F, -v key="$key" 'NR > 1 && ($1 == "S1" || $1 == "dense") && ($2 " " $4) == key {
        print 4 ^ $3, $6, $8 }' "$csv" | sort -g > "$f"
    [ -s "$f" ] && series+=("$key|$f")
done < <(awk -F, 'NR > 1 && ($1 == "S1" || $1 == "dense") { print $2 " " $4 }' "$csv" | sort -u)
awk -F, 'NR > 1 && $1 == "S1" && $15 != "-" { print $7, $15, $3, $4 }' "$csv" > "$tmp/ga.dat"

fit_exponent() { # FILE COLUMN: slope of log(column) against log(N) over N >= 1024 (k >= 5, past fixed costs)
    awk -v c="$2" '$1 >= 1024 && $c > 0 { x = log($1); y = log($c); n++; sx += x; sy += y; sxx += x * x; sxy += x * y }
        END { if (n >= 2 && n * sxx - sx * sx > 0) printf "%.2f", (n * sxy - sx * sy) / (n * sxx - sx * sx); else printf "-" }' "$1"
}

{
    echo "set terminal pngcairo size 1200,500 font ',10'"
    echo "set output '$out/time_memory.png'"
    echo "set multiplot layout 1,2"
    echo "set logscale xy; set grid; set key top left; set xlabel 'N = 4^k (patches per hemisphere)'"
    for what in 2 3; do
        if [ "$what" = 2 ]; then echo "set ylabel 'wall seconds'; set title 'time'"; else echo "set ylabel 'peak RSS (MiB)'; set title 'memory'"; fi
        printf "plot "
        sep=""
        for s in "${series[@]}"; do
            key=${s%%|*} f=${s#*|}
            printf "%s'%s' using 1:%s with linespoints title '%s (exponent %s)'" "$sep" "$f" "$what" "$key" "$(fit_exponent "$f" "$what")"
            sep=", "
        done
        echo
    done
    echo "unset multiplot"
    echo "set output '$out/ga_cpu.png'"
    echo "set terminal pngcairo size 800,500 font ',10'"
    echo "unset logscale; set logscale x; set grid; set key bottom right"
    echo "set xlabel 'CPU seconds'; set ylabel 'least GA vs ray-traced S1 at k = 6 (%)'"
    echo "set title 'S1: accuracy against cost'"
    echo "plot '$tmp/ga.dat' using 1:(strcol(4) eq 'double' ? \$2 : 1/0):(sprintf('k=%d', \$3)) with labels offset 0,1 notitle, \\"
    echo "     '' using 1:(strcol(4) eq 'double' ? \$2 : 1/0) with points pt 7 title 'double', \\"
    echo "     '' using 1:(strcol(4) eq 'single' ? \$2 : 1/0) with points pt 5 title 'single'"
} > "$tmp/plot.gp"
gnuplot "$tmp/plot.gp"
