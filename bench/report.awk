#!/usr/bin/awk -f
# report.awk ROWS STEPS - bench/REPORT.md from bench/run's results.csv as bench/long-merge.awk
# extends it with the rows of bench/long-results.csv (ROWS), and the dense steps of the median runs
# (STEPS: bench/run's steps.csv, or /dev/null).  Variables, the measuring run's: cpu, cores, mem,
# blas (the Debian package of the BLAS library loaded), blas_config (OpenBLAS's own configuration
# string), threads, threads_src (how the thread count was known), commit, date, runs, gemm "double
# float" GFLOP/s at n = gemm_n, load; rendered: when the report was made again from the files by
# `bench/run --render-only`, empty in the measuring run; genbsdf: genBSDF's S1 rows of
# timings.tsv, "k user_s sys_s wall_s" (sys_s "-" where not recorded) separated by ";"; paper: the
# paper's Table 6 for CFS1 (S1), "k hours" and "genBSDF hours" separated by ";".
BEGIN {
    FS = ","
    # Windows-CalcEngine was not run here: the figures the issues give for it (its README,
    # ../shared/reference/wce/README.md, gives no timing of a combination).  Issue #14: the Klems
    # three-layer case (NFRC 102 + 2011-SA1 + NFRC 103, band values) in process; issue #15: the
    # same stack per wavelength (115 wavelengths).
    wce_klems = 0.08; wce_spectral = 19.4
    split(gemm, g, " ")
    ng = split(genbsdf, gl, ";")
    for (i = 1; i <= ng; i++) {
        split(gl[i], f, " ")
        gb_user[f[1]] = f[2]; gb_sys[f[1]] = f[3]; gb_wall[f[1]] = f[4]
        gb[f[1]] = f[2] + (f[3] == "-" ? 0 : f[3])
        gb_order[i] = f[1]
    }
    np = split(paper, pl, ";")
    for (i = 1; i <= np; i++) {
        split(pl[i], f, " ")
        if (f[1] == "genBSDF") paper_genbsdf = f[2]
        else { paper_h[f[1]] = f[2]; pp_order[++npk] = f[1] }
    }
}
FNR == 1 { file++; next }
file == 1 {
    n++
    for (i = 1; i <= NF; i++) v[n, i] = $i
    if ($19 != "") long++
    next
}
# steps.csv: case,stack,k,precision,step,channel,component,GFLOP,seconds,runs
file == 2 {
    sk = $2 SUBSEP $5 SUBSEP $6 SUBSEP $7
    if (!((sk) in seen)) { seen[sk] = 1; skey[++nsk] = sk }
    if (!($2 in stacks)) { stacks[$2] = 1; stack_order[++nstacks] = $2 }
    if (!($6 in channels)) { channels[$6] = 1; nch++ }
    st_g[sk, $3] = $8; st_s[sk, $3] = $9
    st_total[$2, $3] += $8; st_secs[$2, $3] += $9; st_runs[$2, $3] = $10
    st_k[$3] = 1
}
function N(k) { return 4 ^ k }
# a Markdown table's header row h and the separator row under it
function thead(h,   cols, sep, i) {
    cols = gsub(/\|/, "|", h) - 1
    sep = "|"
    for (i = 0; i < cols; i++) sep = sep "---|"
    print h
    print sep
}
# the runs a row is the median of: fewer than the report asks for (three for a row from
# long-results.csv, its dates in column 19; this run's count otherwise) says so
function runsof(r,   want) {
    if (v[r, 18] == "") return "-"
    want = v[r, 19] != "" ? 3 : runs
    return v[r, 18] + 0 < want + 0 ? v[r, 18] " (of " want ")" : v[r, 18]
}
# under a table: where the rows of CASE from long-results.csv come from
function provenance(c, c2,   r, any) { # rows of case c (or c2, where given)
    for (r = 1; r <= n; r++) {
        if ((v[r, 1] != c && (c2 == "" || v[r, 1] != c2)) || v[r, 19] == "") continue
        if (!any++) {
            print ""
            print "Rows recorded one run at a time by `bench/run-long` (bench/long-results.csv), each the median"
            print "by wall time of the runs recorded at the newest commit recorded for it (\"runs\"; older runs,"
            print "which measured older code, are counted as \"left out\"; \"bound\" at this report's GEMM rate):"
            print ""
        }
        printf "* %s k = %s %s: %s run%s, %s, commit%s %s, load %s, %s%s\n", c == "S1" ? "S1" : v[r, 2], v[r, 3], v[r, 4],
            v[r, 18], v[r, 18] == 1 ? "" : "s", v[r, 19], index(v[r, 20], " ") ? "s" : "", v[r, 20], v[r, 21], v[r, 22],
            v[r, 23] == "" ? "" : "; left out: " v[r, 23] " (older code)"
    }
}
# s printed as lines of at most 100 characters, the first prefixed by p1, the others by p2
function wrap(s, p1, p2,   w, nw, i, line) {
    nw = split(s, w, " ")
    line = p1 w[1]
    for (i = 2; i <= nw; i++) {
        if (length(line) + 1 + length(w[i]) > 100) { print line; line = p2 w[i] }
        else line = line " " w[i]
    }
    print line
}
function gflop(f) { return f == "" || f == "-" ? "-" : sprintf("%.4g", f) }
function ratio(x) { return x >= 10 ? sprintf("%.0fx", x) : sprintf("%.1fx", x) }
# the counted flops f (GFLOP) at this run's GEMM rate as a share of the seconds s measured
function bound(k, s, prec, f,   rate) {
    rate = (prec == "single" ? g[2] : g[1])
    if (rate <= 0 || s <= 0 || k < 5 || f == "" || f == "-" || f <= 0) return "-"
    return sprintf("%.0f %%", 100 * f / rate / s)
}
# Windows-CalcEngine's figure for row r's work, as a ratio to our wall time ("-": no figure for it)
function wce(r,   t) {
    if (v[r, 1] == "io" && v[r, 2] ~ /^combine --klems --per-channel/) t = wce_klems
    else if (v[r, 1] == "spectral" && v[r, 2] == "Klems full" && v[r, 5] ~ /^per-channel/) t = wce_klems
    else if (v[r, 1] == "spectral" && v[r, 2] == "Klems full" && v[r, 5] ~ /^spectral-tol/) t = wce_spectral
    else return "-"
    return v[r, 6] > 0 ? sprintf("%s s: %s", t, ratio(t / v[r, 6])) : "-"
}
END {
    print "# bsdfstack: the speed-accuracy trade, measured"
    print ""
    wrap("Generated by `bench/run` (`make bench-report`) on " date ", commit " commit ". Machine: " cpu ", " \
        cores " cores, " mem "; BLAS " blas (blas_config != "-" && blas_config != "" ? " (" blas_config ")" : "") \
        ", " threads " threads (" threads_src "); load average at the end " load " (the machine is shared:" \
        " compare ratios measured in one run, not across reports).", "", "")
    printf "This run's OpenBLAS GEMM rate at n = %s: %s GFLOP/s double, %s single (`bench/bench_mat`).\n", gemm_n, g[1], g[2]
    print ""
    wrap("How each row was measured: the median by wall time of its runs, their number in the table's" \
        " \"runs\" column (this run made " runs " of each, fewer where the column says so" \
        (long ? "; a row recorded by `bench/run-long`: of the runs recorded" : "") "), every column" \
        " from that one run; each run a fresh process timed by `/usr/bin/time` unless the table says" \
        " otherwise. CPU s = user + system seconds. \"read s\" and \"write s\" are the program's own timings" \
        " (`combine -v`) of reading the layers (with resampling onto the target basis) and of writing the" \
        " result; \"combine s\" = wall - read - write, so it includes the process's start (loading the" \
        " program and its libraries), the combination's own setup and the combination itself. \"bound\":" \
        " the time the dense kernels' counted flops (\"GFLOP\") take at this run's GEMM rate (double or" \
        " single, as the row) divided by \"combine s\" (100 % = every second of it spent at the GEMM rate);" \
        " \"-\" below k = 5, where those times are milliseconds.", "", "")
    if (rendered != "") {
        print ""
        printf "Re-rendered by `bench/run --render-only` on %s from bench/results.csv, bench/steps.csv,\n", rendered
        print "bench/results.meta (what the measuring run recorded: the date, commit, machine, load and GEMM"
        print "rate above) and bench/long-results.csv; nothing was measured then."
    }
    print ""
    print "## S1: pane + blind + pane (L_glass, L_blind0, L_glass), every order and precision"
    print ""
    print "GA (Grobe 2017 eq. 7, `compare -k 6`) at the paper's five directions (25/90, 45/90, 50/90,"
    print "45/45, 65/90), Tf and Tb, least and mean, against the ray-traced S1 at k = 5 (`S1_t4k5.xml`)"
    print "and at k = 6 (`S1_t4k6.xml.xz`), both on the k = 6 grid (a coarser result is replicated"
    print "onto it, which shows what it loses). k <= 5 starts from the k = 5 layers, k >= 6 from the"
    print "k = 6 layers; at k = 7 these are held factored (P M_6 P^T, issue #31), whose dense work is in"
    print "double at either precision, so both k = 7 rows' \"bound\" takes the double GEMM rate, and the"
    print "file holds the system's order-6 trees (the k = 6 file's bytes after its header)."
    print "\"GFLOP\": floating-point operations of the dense kernels the combination ran"
    print "(GEMM 2mnk, LU 2/3 n^3 - 1/2 n^2 + 5/6 n, triangular solves (2 n^2 - n) per column, sparse by"
    print "dense 2 per stored value and column: LAPACK Working Note 41's counts, as `combine -v` prints"
    print "them; O(N^2) element-wise work not counted); each step's share is under \"Flops of each dense"
    print "step\" below."
    print ""
    thead("| k | N | precision | wall s | CPU s | read s | combine s | write s | GFLOP | bound | peak MiB | file MB | GA vs k5 least / mean | GA vs k6 least / mean | genBSDF CPU s / ours | paper Table 6 / ours | runs |")
    for (r = 1; r <= n; r++) {
        if (v[r, 1] != "S1") continue
        k = v[r, 3]
        gbr = (k in gb) && v[r, 7] > 0 ? ratio(gb[k] / v[r, 7]) : "-"
        ppr = (k in paper_h) && v[r, 7] > 0 ? ratio(paper_h[k] * 3600 / v[r, 7]) : "-"
        if (k == 7 && v[r, 4] == "double") cpu7 = v[r, 7]
        printf "| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s / %s | %s / %s | %s | %s | %s |\n", k, N(k), v[r, 4], v[r, 6], v[r, 7], v[r, 9], v[r, 10], v[r, 11], gflop(v[r, 17]), bound(k, v[r, 10], k == 7 ? "double" : v[r, 4], v[r, 17]), v[r, 8], v[r, 12], v[r, 13], v[r, 14], v[r, 15], v[r, 16], gbr, ppr, runsof(r)
    }
    provenance("S1")
    print ""
    print "The alternatives on the same work, each divided by our CPU seconds (user + system; both cores"
    print "used where OpenBLAS threads), their figures read from their sources when the report is rendered:"
    print ""
    if (ng) {
        t = "genBSDF (../shared/reference/timings.tsv, its rows S1_t4k*: genBSDF ray tracing S1's geometric" \
            " model as one system at that order, not a sum of layers), user + system seconds, as ours:"
        for (i = 1; i <= ng; i++) {
            k = gb_order[i]
            if (gb_sys[k] != "-")
                t = t sprintf("%s k = %s: %s + %s = %.2f CPU-s (%s s wall)", (i > 1 ? ";" : ""), k, gb_user[k], gb_sys[k], gb[k], gb_wall[k])
            else
                t = t sprintf("%s k = %s: %s s in the row's user_s column and none in its sys_s (system time not" \
                    " recorded; ../shared/reference/README.md calls it %s CPU-s; %s s wall), so that ratio counts" \
                    " genBSDF's user time only", (i > 1 ? ";" : ""), k, gb_user[k], gb_user[k], gb_wall[k])
        }
        if (5 in gb && gb_sys[5] != "-" && gb[5] > 0)
            t = t sprintf(" (at k = 5 system time was %.1f %% of genBSDF's CPU seconds)", 100 * gb_sys[5] / gb[5])
        wrap(t ".", "* ", "  ")
    } else
        print "* genBSDF: ../shared/reference/timings.tsv not found when this was rendered: no ratio."
    if (npk) {
        t = "The paper's Table 6 (../shared/paper/grobe2017.txt, CFS1 = S1, \"elapsed user time\" of the" \
            " extended matrix formalism, one thread):"
        for (i = 1; i <= npk; i++)
            t = t sprintf("%s %s h at k = %s", (i > 1 ? "," : ""), paper_h[pp_order[i]], pp_order[i])
        t = t "."
        if (paper_genbsdf != "") {
            t = t sprintf(" The same table gives %s h for genBSDF ray tracing the three layers' BSDFs at k = 7", paper_genbsdf)
            if (cpu7 > 0) t = t sprintf(": %s our k = 7 double CPU seconds", ratio(paper_genbsdf * 3600 / cpu7))
            t = t "."
        }
        wrap(t, "* ", "  ")
    } else
        print "* The paper's Table 6: ../shared/paper/grobe2017.txt not found when this was rendered: no ratio."
    print "* Windows-CalcEngine (WCE) was not run here, and its README (../shared/reference/wce/README.md)"
    printf "  gives no timing of a combination. Its figures are the issues': issue #14 gives %s s in process\n", wce_klems
    print "  for the Klems three-layer case (NFRC 102 + 2011-SA1 + NFRC 103 with band values: the text I/O"
    print "  table's `combine --klems --per-channel --absorptance` row, and the spectral table's per-channel"
    printf "  row), issue #15 %s s for the same stack per wavelength (115 wavelengths: the spectral table's\n", wce_spectral
    print "  Klems full spectral-tol rows). Those rows give WCE's seconds over our wall seconds: an"
    print "  in-process time against our whole process (its start, reading the layers and the panes'"
    print "  optics, writing the XML and the absorptance table), which favours WCE."
    print ""
    print "## Text I/O"
    print ""
    print "Reading and writing BSDF XML (issue #14's targets in the \"target\" column). MB/s: the file's size"
    print "over CPU seconds (info: the file read, 109 MB; convert: the file written, over the CPU seconds"
    print "beyond info's; bench_read and bench_write: the reader and the writer alone, as those programs"
    print "time them, the medians by wall time of their runs in one process (\"runs\"), not fresh processes:"
    print "the file read into a layer, 109 MB; the ray-traced S1 at k = 6 written into a counting sink, no"
    print "disk). S1's end-to-end CPU seconds and its read and write times are in the first table. WCE:"
    print "Windows-CalcEngine's seconds for the same work (issue #14's figure, not measured here) over ours."
    print ""
    thead("| work | wall s | CPU s | peak MiB | file MB | MB/s | target | WCE / ours | runs |")
    for (r = 1; r <= n; r++) {
        if (v[r, 1] != "io") continue
        rate = "-"
        if (v[r, 2] ~ /^bench_read/ && v[r, 7] > 0) rate = sprintf("%.0f (read)", v[r, 12] / v[r, 7])
        else if (v[r, 2] ~ /^bench_write/ && v[r, 7] > 0) rate = sprintf("%.0f (written)", v[r, 12] / v[r, 7])
        else if (v[r, 2] ~ /^info/) { info_cpu = v[r, 7]; rate = sprintf("%.0f (read)", v[r, 12] / v[r, 7]) }
        else if (v[r, 2] ~ /^convert/ && info_cpu > 0 && v[r, 7] > info_cpu) rate = sprintf("%.0f (written)", v[r, 12] / (v[r, 7] - info_cpu))
        printf "| `%s` | %s | %s | %s | %s | %s | %s | %s | %s |\n", v[r, 2], v[r, 6], v[r, 7], v[r, 8], v[r, 12], rate, v[r, 5], wce(r), runsof(r)
    }
    print ""
    print "## Spectral stacks with a shade (issue #15)"
    print ""
    print "`combine BASIS --spectral-tol X --absorptance A glass:nfrc-102 SHADE glass:nfrc-103`: SHADE is"
    print "Windows-CalcEngine's two-band shade 2011-SA1 (its Solar and Visible Klems matrices, written by"
    print "`bench/wce_shade`; at k = 5 resampled by `convert -k 5`), combined wavelength by wavelength as"
    print "WINDOW's dual-band material, Solar and Visible.  Differences: the largest over both channels,"
    print "both sides and every incident patch of the hemispherical T, R and each layer's absorptance"
    print "(the --absorptance table, 8 decimals) against `--spectral-tol 0` (every distinct wavelength"
    print "combined; one run at k = 5: \"runs\"); `--per-channel` is the band-value answer, for scale."
    print "Targets: Klems full <= 0.5 s wall, k = 5 <= 15 s. WCE / ours: Windows-CalcEngine's seconds for"
    printf "the same stack (issue #15's %s s per wavelength; the per-channel row: issue #14's %s s with\n", wce_spectral, wce_klems
    print "band values; not measured here) over our wall seconds; WCE's figures are Klems only."
    print ""
    thead("| basis | option | wall s | CPU s | combine s | GFLOP | bound | max dT | max dR | max dA | WCE / ours | runs |")
    for (r = 1; r <= n; r++)
        if (v[r, 1] == "spectral")
            printf "| %s%s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", v[r, 2], (v[r, 3] > 0 ? " k = " v[r, 3] : ""), v[r, 5], v[r, 6], v[r, 7], v[r, 10], gflop(v[r, 17]), bound(v[r, 3], v[r, 10], v[r, 4], v[r, 17]), v[r, 13], v[r, 14], v[r, 15], wce(r), runsof(r)
    print ""
    print "## Tree reduction and the sparse drop tolerance (double)"
    print ""
    print "Each file against the unreduced, exact one: GA, the least over the five directions, Tf and Tb"
    print "(drop-tol: least over every incident patch); over every incident patch (`compare`'s closing"
    print "table), the largest change of a directional-hemispherical T (Tf, Tb) and R (Rf, Rb) and the"
    print "least flux accordance FA. The reduction rows vary the culling percentile at the default"
    print "tolerance, then the tolerance (`--reduce-tol`) at the default percentile; \"reduce-tol none\" is"
    print "the percentile alone, as RADIANCE's rttree_reduce (and bsdfstack before issue #30). \"read back"
    print "s\": `bsdfstack info` of the file written, wall seconds, the median by wall time of as many runs"
    print "(fresh processes) as the row's."
    print ""
    thead("| stack | k | option | wall s | write s | file MB | read back s | GA vs exact | max dT | max dR | FA least | runs |")
    for (r = 1; r <= n; r++)
        if (v[r, 1] == "reduce" || v[r, 1] == "drop-tol") {
            opt = v[r, 5]; rb = "-"
            if (match(opt, / \(read back [0-9.]+ s\)$/)) {
                rb = substr(opt, RSTART + 12, RLENGTH - 12 - 3)
                opt = substr(opt, 1, RSTART - 1)
            }
            printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", v[r, 2], v[r, 3], opt, v[r, 6], v[r, 11], v[r, 12], rb, v[r, 13], v[r, 14], v[r, 15], v[r, 16], runsof(r)
        }
    print ""
    print "## Dense worst cases"
    print ""
    thead("| stack | k | precision | wall s | CPU s | read s | combine s | write s | GFLOP | bound | peak MiB | file MB | runs |")
    for (r = 1; r <= n; r++)
        if (v[r, 1] == "dense")
            printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", v[r, 2], v[r, 3], v[r, 4], v[r, 6], v[r, 7], v[r, 9], v[r, 10], v[r, 11], gflop(v[r, 17]), bound(v[r, 3], v[r, 10], v[r, 4], v[r, 17]), v[r, 8], v[r, 12], runsof(r)
    provenance("dense")
    print ""
    print "Diffuser + diffuser at k = 7 in double precision is not measured: both layers are dense in all"
    print "four components (8 matrices of 2 GiB), and `combine` estimates its peak at 22.2 GiB, more than"
    print "this 23.5 GiB machine can spare beside its other work (`--max-memory 1M` prints the estimate)."
    factored_table()
    steps_table()
    print ""
    print "## Plots"
    print ""
    print "![time and memory against N](time_memory.png)"
    print ""
    print "![GA against CPU seconds](ga_cpu.png)"
    print ""
    print "The first plots wall time and peak memory of every combination against N = 4^k on log-log"
    print "axes; the legend gives each series' exponent, fitted to its points at k >= 5 (N^3 is the"
    print "dense algebra's bound). The second plots, for S1, the least GA against the k = 6 truth"
    print "against CPU seconds: the trade itself."
}
# Layers held factored or sparse (issue #31: case "factored", bench/run-long's gbg and gvg; issue
# #32: case "sparse", its gmg and grg), when any row was recorded
function factored_table(   r, any) {
    for (r = 1; r <= n; r++) any += v[r, 1] == "factored" || v[r, 1] == "sparse"
    if (!any) return
    print ""
    print "## Layers at the resolution of their information (factored, sparse)"
    print ""
    wrap("A rank-4 tree of depth 6 read at k = 7 is P M_6 P^T: the combination's dense work has the" \
        " coarse order's size (bench/README.md, issue #31); `--dense` is the dense rows' path. A matte" \
        " venetian blind made from its geometry (`venetian:width=16mm,spacing=14.5mm,tilt=45,r=0.7,t=0.05`," \
        " issue #32) is its unobstructed light's diagonal plus the slat strips' views times their" \
        " emissions; its stack's time is nearly all the writing of a 7.7 GB tree (Tb, Rf and Rb a" \
        " channel: Tf is Tb's reciprocal). A mirror blind (`venetian:width=16mm,spacing=14.5mm,tilt=45," \
        "rs=0.765,roughness=0.02`) is sparse: its first step between panes stays sparse, the second is" \
        " dense (its inverse formed once a channel; bench/README.md, \"A mirror blind's dense second" \
        " step\"). The reference blind's geometry (`rs=0.765,r=0.085,roughness=0.02`: mirror and diffuse" \
        " slats) is that sparse part plus its strips' diffuse light of rank 16, kept so through the" \
        " stack (bench/README.md, \"Mirror and diffuse slats\").", "", "")
    print ""
    thead("| stack | k | precision | wall s | CPU s | read s | combine s | write s | GFLOP | bound | peak MiB | file MB | runs |")
    for (r = 1; r <= n; r++)
        if (v[r, 1] == "factored" || v[r, 1] == "sparse")
            printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", v[r, 2], v[r, 3], v[r, 4], v[r, 6], v[r, 7], v[r, 9], v[r, 10], v[r, 11], gflop(v[r, 17]), bound(v[r, 3], v[r, 10], v[r, 4], v[r, 17]), v[r, 8], v[r, 12], runsof(r)
    provenance("factored", "sparse")
}
# The flops of each dense step (steps.csv) at the two highest orders recorded, the seconds and the
# bound at the highest
function steps_table(   k, ks, nk, i, j, s, sk, p, k1, k2, comp, row, f, st, secs, bnd) {
    print ""
    print "## Flops of each dense step"
    print ""
    for (k in st_k) ks[++nk] = k + 0
    if (!nk) {
        print "No steps recorded (bench/steps.csv: written by a measuring `bench/run` since this table exists)."
        return
    }
    for (i = 2; i <= nk; i++)
        for (j = i; j > 1 && ks[j] < ks[j - 1]; j--) { k = ks[j]; ks[j] = ks[j - 1]; ks[j - 1] = k }
    k2 = ks[nk]; k1 = nk > 1 ? ks[nk - 1] : ""
    wrap("What the \"GFLOP\" of the tables above is made of: the dense kernels' floating-point operations" \
        " in each step of the combination, as `combine -v` prints them (one line per step and component," \
        " 3 significant digits), counted as above (LAPACK Working Note 41: GEMM 2mnk, LU 2/3 n^3 - 1/2" \
        " n^2 + 5/6 n, triangular solves (2 n^2 - n) per right-hand side, sparse by dense 2 per stored" \
        " value and column; O(N^2) element-wise work not counted). Step \"layers 1-j\" adds layer j to the" \
        " system of layers 1..j-1; its components in the order `combine` forms them: Rb's line carries the" \
        " factorization of I - A for the light going inwards in the gap (and the solves it shares with Tf)," \
        " Tb's that for the light going outwards (shared with Rf); Tf and Rf then cost one product each, a" \
        " GEMM (2 N^3) or, with a pane's diagonal or sparse matrix, O(N^2): 0 or near 0. The counts depend" \
        " on the stack, the order and the operands' structures only, not on the run, the machine, the" \
        " threads or the precision (single counts the same totals: first table), so any run gives them;" \
        " these are the double rows' median runs'. \"share\": of the sum of the stack's steps at that order." \
        " \"k = " k2 " s\": the step's seconds as `-v` prints them in that median run (of " \
        (st_runs[stack_order[1], k2] != "" ? st_runs[stack_order[1], k2] : runs) "; one run's, not a median" \
        " per step); \"bound\": its GFLOP at this run's double GEMM rate over those seconds (\"-\" below" \
        " k = 5).", "", "")
    print ""
    if (k1 != "")
        thead(sprintf("| stack | step | component | k = %s GFLOP | share | k = %s GFLOP | share | k = %s s | bound |", k1, k2, k2))
    else
        thead(sprintf("| stack | step | component | k = %s GFLOP | share | k = %s s | bound |", k2, k2))
    for (s = 1; s <= nstacks; s++) {
        for (p = 1; p <= nsk; p++) {
            sk = skey[p]
            split(sk, f, SUBSEP)
            if (f[1] != stack_order[s]) continue
            comp = nch > 1 ? f[3] " " f[4] : f[4]
            row = sprintf("| %s | %s | %s |", f[1], f[2], comp)
            if (k1 != "") row = row step_cells(sk, f[1], k1)
            row = row step_cells(sk, f[1], k2)
            secs = bnd = "-"
            if ((sk, k2) in st_s) { secs = st_s[sk, k2]; bnd = bound(k2, secs, "double", st_g[sk, k2]) }
            printf "%s %s | %s |\n", row, secs, bnd
        }
        st = stack_order[s]
        row = sprintf("| %s | all steps | |", st)
        if (k1 != "") row = row total_cells(st, k1)
        row = row total_cells(st, k2)
        secs = bnd = "-"
        if ((st, k2) in st_secs) { secs = sprintf("%.3f", st_secs[st, k2]); bnd = bound(k2, st_secs[st, k2], "double", st_total[st, k2]) }
        printf "%s %s | %s |\n", row, secs, bnd
    }
}
# " GFLOP | share |" of the sum of stack st's steps at order k
function total_cells(st, k) {
    return ((st, k) in st_total) ? sprintf(" %s | 100 %% |", gflop(st_total[st, k])) : " - | - |"
}
# " GFLOP | share |" of step sk (of stack st) at order k
function step_cells(sk, st, k,   tot) {
    if (!((sk, k) in st_g)) return " - | - |"
    tot = st_total[st, k]
    return sprintf(" %s | %s |", st_g[sk, k], tot > 0 ? sprintf("%.1f %%", 100 * st_g[sk, k] / tot) : "-")
}
