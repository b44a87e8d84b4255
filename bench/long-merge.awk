#!/usr/bin/awk -f
# long-merge.awk RESULTS LONG - the rows bench/run's report shows: RESULTS (results.csv, measured by
# one bench/run) as they are, then each configuration (case, stack, k, precision, option) of LONG
# (long-results.csv, one run a row from bench/run-long) that RESULTS does not have, as one row made
# from the runs recorded at the configuration's newest commit (the commit of its latest run): the
# median run by wall time (the lower of the two middle ones for an even count, as bench/lib.sh's
# `measure` takes it), every column from that run.  Older runs measured older code: they stay in
# LONG as history and are only counted here.  Columns: results.csv's, its last `runs`, then for
# the rows from LONG: dates (first..last), commit, load (least..most 1-minute load average at the
# starts and ends of the runs), host_cpu (each once) and older ("N at C1 C2...": the runs left out
# and their commits; empty where none).
# Variable meta_runs: the runs of a RESULTS row written before results.csv had a `runs` column.
BEGIN { FS = OFS = "," }
FNR == 1 {
    file++
    if (file == 1) print $0 (NF == 17 ? ",runs" : "") ",dates,commits,load,host_cpu,older"
    next
}
file == 1 {
    measured[$1 FS $2 FS $3 FS $4 FS $5] = 1
    print $0 (NF == 17 ? "," meta_runs : "") ",,,,,"
    next
}
{
    key = $1 FS $2 FS $3 FS $4 FS $5
    if (key in measured) next
    if (!(key in all)) order[++keys] = key
    row[key, ++all[key]] = $0
    if (!(key in newest) || $19 > newest[key]) { newest[key] = $19; latest[key] = $20 }
}
# the runs of key at its newest commit, by wall time (column 6; the earlier row first among equal
# times) in line[key, 1..count[key]], and their dates, loads and hosts; the others counted
function gather(key,   a, i, m, f, ld, j, c, d, h) {
    for (a = 1; a <= all[key]; a++) {
        split(row[key, a], f, ",")
        c = f[20]
        if (c != latest[key]) {
            older[key]++
            if (index(" " oldc[key] " ", " " c " ") == 0) oldc[key] = oldc[key] (oldc[key] == "" ? "" : " ") c
            continue
        }
        m = ++count[key]
        for (i = m; i > 1 && line[key, i - 1, "wall"] + 0 > f[6] + 0; i--) {
            line[key, i] = line[key, i - 1]; line[key, i, "wall"] = line[key, i - 1, "wall"]
        }
        line[key, i] = row[key, a]; line[key, i, "wall"] = f[6]
        d = f[19]; h = f[22]
        if (!(key in d0) || d < d0[key]) d0[key] = d
        if (!(key in d1) || d > d1[key]) d1[key] = d
        if (index("; " hosts[key] "; ", "; " h "; ") == 0) hosts[key] = hosts[key] (hosts[key] == "" ? "" : "; ") h
        split(f[21], ld, " ")
        for (j = 1; j <= 5; j += 4)
            if (ld[j] != "") {
                if (!(key in l0) || ld[j] + 0 < l0[key]) l0[key] = ld[j] + 0
                if (!(key in l1) || ld[j] + 0 > l1[key]) l1[key] = ld[j] + 0
            }
    }
}
# the order bench/run measures in: by k, double before single, pane + diffuser + pane before
# diffuser + diffuser
function before(a, b,   x, y) {
    split(a, x, FS); split(b, y, FS)
    if (x[3] != y[3]) return x[3] + 0 < y[3] + 0
    if (x[4] != y[4]) return x[4] < y[4]
    return x[2] > y[2]
}
END {
    for (r = 2; r <= keys; r++)
        for (i = r; i > 1 && before(order[i], order[i - 1]); i--) {
            t = order[i]; order[i] = order[i - 1]; order[i - 1] = t
        }
    for (r = 1; r <= keys; r++) {
        key = order[r]
        gather(key)
        n = count[key]
        split(line[key, int((n + 1) / 2)], f, ",")
        out = f[1]
        for (i = 2; i <= 17; i++) out = out "," f[i]
        printf "%s,%d,%s,%s,%s,%s,%s\n", out, n, d0[key] == d1[key] ? d0[key] : d0[key] ".." d1[key], latest[key],
            l0[key] == l1[key] ? l0[key] "" : l0[key] "-" l1[key], hosts[key],
            older[key] ? older[key] " at " oldc[key] : ""
    }
}
