# cli_view.sh - `bsdfstack view`: the page, loaded by headless Chromium, shows for several views
# (URL fragments) the directional-hemispherical value `info` prints and puts the hottest pixel
# of a pane pair's map where the light goes; it refers to nothing outside itself and works with
# the network off; and view's errors leave no page.  Without Chromium (CI installs it:
# ./quickstart check) only the checks that need no browser run, and the test is skipped (77).
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK
probe=$(dirname "$B")/tests/pngprobe

# Without a browser: the pages, what they name, the sizes, the errors.
"$B" view -o "$tmpdir/L_blind45_t4k5_klems.html" "$ref/L_blind45_t4k5_klems.xml" > /dev/null 2>&1 ||
    fail "view of a Klems file"
"$B" combine -k 6 -o "$tmpdir/g2.xml" glass:clear-6mm glass:clear-6mm > /dev/null 2>&1 ||
    fail "combining the glass pair"
"$B" view -o "$tmpdir/g2.html" "$tmpdir/g2.xml" > /dev/null 2>&1 || fail "view of the glass pair"
"$B" view -o "$tmpdir/two.html" "$tmpdir/g2.xml" "$tmpdir/g2.xml" > /dev/null 2>&1 || fail "view of two files"

# beyond --max-size: coarser, and the page says so
"$B" view --max-size 8M -o "$tmpdir/coarse.html" "$ref/L_blind45_t4k5.xml" > /dev/null 2>&1 &&
    grep -q '"basis":{"kind":"sc","k":4' "$tmpdir/coarse.html" && grep -q 'coarser than the files' "$tmpdir/coarse.html" &&
    [ "$(wc -c < "$tmpdir/coarse.html")" -lt $((8 * 1048576 + 200000)) ] &&
    pass "--max-size 8M: a k = 5 tree shown at k = 4, said on the page" || fail "--max-size 8M"


# Self-contained: no http(s) reference, no link, no source that is not inline, no fetch, outside
# the data (base64 holds '/' pairs); and the page works with the network off
# (browse below).
for f in L_blind45_t4k5_klems g2 two; do
    page=$tmpdir/$f.html
    sed 's/<script type="application\/json" id="bsdf-data">.*<\/script>/DATA/' "$page" > "$tmpdir/nodata"
    if grep -Eiq 'https?:|ftp:|//[a-z0-9.-]+[./]|<link|<img|<iframe|src=|url\(|@import|fetch\(|XMLHttpRequest|WebSocket|EventSource|import\(' "$tmpdir/nodata"; then
        fail "$f.html refers outside itself: $(grep -Eio 'https?:[^ ]*|//[a-z0-9.-]+[./]|<link|src=|url\(|fetch\(|XMLHttpRequest' "$tmpdir/nodata" | head -n 3)"
    else
        pass "$f.html refers to nothing outside itself"
    fi
done


# -o - writes the same page to standard output
"$B" view -o - "$ref/L_blind45_t4k5_klems.xml" > "$tmpdir/stdout.html" 2> "$tmpdir/err"
cmp -s "$tmpdir/stdout.html" "$tmpdir/L_blind45_t4k5_klems.html" && pass "-o - writes the same page" ||
    fail "-o -: $(head -c 200 "$tmpdir/err")"

# Errors: one line, no page (nor a temporary beside it)
mkdir "$tmpdir/e"
head -c 3000 "$ref/L_blind45_t4k5_klems.xml" > "$tmpdir/cut.xml"
expect_error "a malformed file" 'cut\.xml' -- "$B" view -o "$tmpdir/e/p.html" "$tmpdir/cut.xml"
expect_error "a missing file" 'nothing\.xml' -- "$B" view -o "$tmpdir/e/p.html" "$tmpdir/nothing.xml"
expect_error "a file too large for --max-size" 'max-size' -- "$B" view --max-size 100K -o "$tmpdir/e/p.html" \
    "$ref/L_blind45_t4k5_klems.xml"
expect_error "too large for the memory allowed" 'needs about' -- "$B" view --max-memory 1M -o "$tmpdir/e/p.html" \
    "$ref/L_blind45_t4k5.xml"
expect_error "a pane" 'glass:' -- "$B" view -o "$tmpdir/e/p.html" glass:clear-6mm
"$B" combine -k 3 --incident 0,0 -o "$tmpdir/inc.tsv" glass:clear-6mm > /dev/null 2>&1 ||
    fail "combine --incident for view's table check"
expect_error "a table of combine --incident" 'inc\.tsv: view reads BSDF XML files.*bsdfstack plot' -- \
    "$B" view -o "$tmpdir/e/p.html" "$tmpdir/inc.tsv"
expect_error "no file" 'no file' -- "$B" view -o "$tmpdir/e/p.html"
expect_error "a bad --max-size" 'max-size' -- "$B" view --max-size lots "$ref/L_blind45_t4k5_klems.xml"
expect_error "a bad --incident" 'incident' -- "$B" view --incident 95,0 "$ref/L_blind45_t4k5_klems.xml"
[ -z "$(ls -A "$tmpdir/e")" ] && pass "no page left by an error" || fail "left behind: $(ls -A "$tmpdir/e")"
"$B" view --help | grep -q '^Usage: bsdfstack view' && pass "view --help" || fail "view --help"
"$B" --help | grep -q '^  view ' && pass "view in bsdfstack --help" || fail "view missing from bsdfstack --help"


# With a browser
chrome=
for c in chromium chromium-browser google-chrome; do
    command -v "$c" >/dev/null 2>&1 && { chrome=$c; break; }
done
if [ -z "$chrome" ]; then
    echo "SKIP: no chromium on PATH (apt-get install chromium; ./quickstart check installs it): no"
    echo "page was loaded"
    [ "$fails" -eq 0 ] || finish
    exit 77
fi


# Chromium with the sanitizers' settings of make check-asan taken away (it is not instrumented),
# its profile in the test's directory, no network: every name resolves to nothing, no proxy.
# One window size and scale for the DOM and the screenshot, so that the map is where the page
# says it is.
browse() { # URL then chromium's own options (--dump-dom, --screenshot=FILE)
    local url=$1; shift
    env -u LD_PRELOAD -u ASAN_OPTIONS -u LSAN_OPTIONS -u UBSAN_OPTIONS HOME="$tmpdir" \
        timeout 120 "$chrome" --headless --no-sandbox --disable-gpu --hide-scrollbars \
        --force-device-scale-factor=1 --window-size=1200,1000 --user-data-dir="$tmpdir/profile" \
        --host-resolver-rules='MAP * ~NOTFOUND' --no-proxy-server --disable-background-networking \
        --virtual-time-budget=20000 "$@" "$url" 2>"$tmpdir/chrome.err"
}
# the text of the element with this id in a DOM dump
element() { sed -n "s/.*id=\"$1\"[^>]*>\([^<]*\)<.*/\1/p" "$2" | head -n 1; }

# info's directional-hemispherical table: the value of COMP at (THETA, PHI)
info_value() { # FILE COMP THETA PHI
    "$B" info "$1" | awk -v c="$2" -v t="$3" -v p="$4" '
        /^theta/ {n++} n == 1 && $1 == t && $2 == p {
            col = c == "Tf" ? 3 : c == "Rf" ? 4 : c == "Tb" ? 5 : 6; print $col; exit }'
}

# One view of a page against info: hem within 1e-4 of info's (printed to 4 decimals).
check_view() { # DESCRIPTION PAGE XML THETA PHI COMP
    browse "file://$2#incident=$4,$5&comp=$6&channel=Visible" --dump-dom > "$tmpdir/dom" ||
        { fail "$1: chromium failed: $(tail -n 3 "$tmpdir/chrome.err")"; return; }
    local hem want
    hem=$(element hem "$tmpdir/dom")
    want=$(info_value "$3" "$6" "$4" "$5")
    awk -v a="$hem" -v b="$want" 'BEGIN {exit !(a != "" && b != "" && (a - b)^2 <= 1e-8)}' &&
        pass "$1: $6 at ($4, $5): page $hem, info $want" || fail "$1: $6 at ($4, $5): page '$hem', info '$want'"
}

# Klems, rank 3, rank 4: front and back, T and R, on and off the plane phi = 0
for f in L_blind45_t4k5_klems L_diffuser_t3k5 L_blind45_t4k5; do
    "$B" view -o "$tmpdir/$f.html" "$ref/$f.xml" > "$tmpdir/out" 2>&1 || fail "view $f: $(cat "$tmpdir/out")"
    check_view "$f" "$tmpdir/$f.html" "$ref/$f.xml" 0 0 Tf
    check_view "$f" "$tmpdir/$f.html" "$ref/$f.xml" 30 90 Rf
    check_view "$f" "$tmpdir/$f.html" "$ref/$f.xml" 45 0 Tb
    check_view "$f" "$tmpdir/$f.html" "$ref/$f.xml" 60 90 Rb
done
grep -q 'Shirley-Chiu k = 5' "$tmpdir/L_blind45_t4k5.html" && pass "a k = 5 tree embedded at k = 5" ||
    fail "the k = 5 tree not embedded at its own order"

# A combination: a pane pair at k = 6.  Its hemispherical value, and the hottest pixel of the
# screenshot where the light goes: transmission continues it, reflection mirrors it, both at the
# propagation direction's x, y; radius sin(theta) of the disk the page reports (#mapdisk: centre
# and radius in page pixels), phi from +x (right) towards +y (up).  Tolerance: 1.5 k = 6 cells.
# Computed here, not by the page.
check_view "glass pair" "$tmpdir/g2.html" "$tmpdir/g2.xml" 45 90 Tf
check_view "glass pair" "$tmpdir/g2.html" "$tmpdir/g2.xml" 15 0 Rf
for comp in Tf Rf; do
    url="file://$tmpdir/g2.html#incident=40,30&comp=$comp&channel=Visible"
    browse "$url" --dump-dom > "$tmpdir/dom" && browse "$url" --screenshot="$tmpdir/g2.png" > /dev/null ||
        { fail "glass pair $comp: chromium failed: $(tail -n 3 "$tmpdir/chrome.err")"; continue; }
    set -- $(element mapdisk "$tmpdir/dom")
    if [ $# -ne 3 ]; then fail "glass pair $comp: no disk geometry on the page"; continue; fi
    hot=$("$probe" "$tmpdir/g2.png" hottest "$1" "$2" "$(awk -v r="$3" 'BEGIN {print r - 2}')")
    awk -v c="$1 $2 $3" -v h="$hot" 'BEGIN {
        split(c, g, " "); split(h, p, " "); pi = atan2(0, -1); t = 40 * pi / 180; f = 30 * pi / 180
        x = g[1] + g[3] * sin(t) * cos(f); y = g[2] - g[3] * sin(t) * sin(f)
        d = sqrt((p[1] - x)^2 + (p[2] - y)^2); tol = 1.5 * g[3] * sqrt(pi / 4096)
        printf "hottest pixel (%s, %s), luma %s, expected (%.1f, %.1f): %.1f px off (tolerance %.1f)\n", \
            p[1], p[2], p[3], x, y, d, tol
        exit !(d <= tol && p[3] > 240)}' > "$tmpdir/where" &&
        pass "glass pair $comp: $(cat "$tmpdir/where")" || fail "glass pair $comp: $(cat "$tmpdir/where")"
    peak=$(element peak "$tmpdir/dom")
    awk -v p="$peak" 'BEGIN {split(p, a, ","); exit !((a[1] - 40)^2 < 4 && (a[2] - 30)^2 < 9)}' &&
        pass "glass pair $comp: peak at ($peak)" || fail "glass pair $comp: peak at '$peak', not (40, 30)"
done

# Two files: side by side, their hemispherical values and the difference; a file with itself
# differs by 0 and accords 100 % (LA); a Klems file beside a tree is read over the tree's basis.
browse "file://$tmpdir/two.html#incident=20,10&comp=Tf&channel=Visible&mode=la" --dump-dom > "$tmpdir/dom"
[ "$(element hemdiff-1 "$tmpdir/dom")" = 0.000000 ] && [ "$(element hem-1 "$tmpdir/dom")" = "$(element hem "$tmpdir/dom")" ] &&
    grep -q 'Local accordance LA' "$tmpdir/dom" && pass "two files: the same hemispherical values, difference 0, LA map" ||
    fail "two files: hem $(element hem "$tmpdir/dom"), hem-1 $(element hem-1 "$tmpdir/dom"), diff $(element hemdiff-1 "$tmpdir/dom")"
"$B" view --max-size 64M -o "$tmpdir/mixed.html" "$ref/L_blind45_t4k5.xml" "$ref/L_blind45_t4k5_klems.xml" > /dev/null 2>&1 &&
    grep -q '"basis":{"kind":"sc","k":5' "$tmpdir/mixed.html" && pass "a Klems file beside a k = 5 tree: over k = 5" ||
    fail "a Klems file beside a tree"

# Chosen incident directions: only their columns, at the file's own resolution (k = 6 here)
xz -dc "$ref/L_blind0_t4k6.xml.xz" > "$tmpdir/b6.xml" || fail "xz"
"$B" view --incident 30,90 --incident 45,0 -o "$tmpdir/b6.html" "$tmpdir/b6.xml" > /dev/null 2>&1 ||
    fail "view --incident of a k = 6 file"
check_view "k = 6, chosen directions" "$tmpdir/b6.html" "$tmpdir/b6.xml" 30 90 Tf
check_view "k = 6, chosen directions" "$tmpdir/b6.html" "$tmpdir/b6.xml" 45 0 Tf
# k = 7: the chosen columns evaluated from the file, without its whole layer (a pane, written fast)
"$B" combine -k 7 -o "$tmpdir/g7.xml" glass:clear-6mm > /dev/null 2>&1 || fail "combine -k 7"
"$B" view --incident 30,90 --incident 45,0 -o "$tmpdir/g7.html" "$tmpdir/g7.xml" > "$tmpdir/out" 2>&1 &&
    grep -q 'k = 7, 2 incident patches' "$tmpdir/out" && pass "view --incident of a k = 7 file" ||
    fail "view --incident of a k = 7 file: $(cat "$tmpdir/out")"
check_view "k = 7, chosen directions" "$tmpdir/g7.html" "$tmpdir/g7.xml" 30 90 Tf
check_view "k = 7, chosen directions" "$tmpdir/g7.html" "$tmpdir/g7.xml" 45 0 Rb
finish
