# cli_robust.sh - bad input and a hostile environment (issue #18): what output paths name (devices,
# FIFOs, symbolic links, directories, a file's mode), write errors on files and on standard output,
# read errors on standard input, query's angle range, and short messages for absurd values.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
ref=${BST_REFDIR:?}
B=$BSDFSTACK
d=$tmpdir/o
mkdir "$d" || exit 99
umask 022

# helpers for expect_status/expect_error, which redirect stdout themselves: a command ...
to_full() { "$@" > /dev/full; }                          # ... writing to a full device
from() { local f=$1; shift; "$@" < "$f"; }               # ... reading FILE
stdin_closed() { "$@" <&-; }                             # ... with no standard input
stdout_closed() { "$@" >&-; }                            # ... with no standard output
fsize_limited() ( trap '' XFSZ; ulimit -f 1; "$@" )      # ... whose files stop at 1 KiB (EFBIG)
# no_leftovers DESCRIPTION: no temporary is left in $d
no_leftovers() {
    if ls "$d" | grep -q '\.tmp'; then fail "$1: temporaries left: $(ls "$d")"; else pass "$1"; fi
}

# a cheap output: a clear pane at k = 1 (4 patches)
pane() { "$B" combine -k 1 "$@" glass:clear-6mm; }

expect_status 0 "a plain output file" -- pane -o "$d/a.xml"
f=$d/a.xml

# --- devices are written, never replaced.  As root, on device nodes of our own: a regression then
# replaces those, not the machine's /dev/null (which a user cannot replace: it is used then).
null=/dev/null full=/dev/full
if [ "$(id -u)" -eq 0 ]; then
    if mknod -m 666 "$d/null" c 1 3 && mknod -m 666 "$d/full" c 1 7 && echo > "$d/null"; then
        null=$d/null full=$d/full
    else
        null=
        echo "skipped: device outputs (root, and no device node of our own in $d)"
    fi
fi
if [ -n "$null" ]; then
    expect_status 0 "-o a null device" -- pane -o "$null"
    [ -c "$null" ] && pass "$null is still a character device" || fail "$null was replaced"
    expect_error "-o a full device fails, naming it" "$full: .*No space left on device" -- pane -o "$full"
    [ -c "$full" ] && pass "$full is still a character device" || fail "$full was replaced"
    expect_status 0 "--absorptance a null device" -- pane --absorptance "$null" -o "$d/a.xml"
    expect_error "--absorptance a full device fails, naming it" "$full: .*No space left on device" -- \
        pane --absorptance "$full" -o "$d/b.xml"
    [ ! -e "$d/b.xml" ] && pass "a failed --absorptance leaves no system file" || fail "b.xml written"
    expect_error "-o a full device with --absorptance" "$full: .*No space left" -- \
        pane --absorptance "$d/b.tsv" -o "$full"
    [ ! -e "$d/b.tsv" ] && pass "a failed -o leaves no absorptance file" || fail "b.tsv written"
    expect_error "convert -o a full device" "$full: .*No space left" -- \
        "$B" convert "$f" -o "$full"  # a whole pane: no warning of zeros written beside the error
    expect_error "plot -o a full device" "$full: .*No space left" -- \
        "$B" plot --size 64 --format svg -o "$full" "$ref/examples/k1_4d_TF.xml"
    printf '%s glass:clear-6mm\n' "$full" > "$d/full.batch"
    expect_status 1 "batch output to a full device fails" -- "$B" batch -k 1 "$d/full.batch"
    grep -q "$full: .*No space left" "$tmpdir/err" && pass "batch names $full" || fail "batch: $(cat "$tmpdir/err")"
    [ -c "$full" ] && [ -c "$null" ] && pass "the devices survive every command" || fail "a device was replaced"
    rm -f "$d/null" "$d/full"
fi
no_leftovers "device outputs leave no temporaries"

# --- a FIFO is written, not replaced
mkfifo "$d/fifo"
timeout 60 cat "$d/fifo" > "$d/fifo.out" &
reader=$!
expect_status 0 "-o FIFO" -- timeout 60 "$B" combine -k 1 -o "$d/fifo" glass:clear-6mm
wait "$reader"
[ -p "$d/fifo" ] && pass "the FIFO is still a FIFO" || fail "the FIFO was replaced"
grep -q '</WindowElement>' "$d/fifo.out" && pass "the reader got the whole file" || fail "FIFO output: $(head -c 200 "$d/fifo.out")"
timeout 60 cat "$d/fifo" > "$d/fifo.tsv" &
reader=$!
expect_status 0 "--absorptance FIFO" -- timeout 60 "$B" combine -k 1 --absorptance "$d/fifo" -o "$d/c.xml" glass:clear-6mm
wait "$reader"
[ -p "$d/fifo" ] && head -1 "$d/fifo.tsv" | grep -q '^channel' && pass "absorptance through the FIFO" || fail "absorptance FIFO"
rm -f "$d/fifo"

# --- symbolic links stay; the file they name gets the output
echo old > "$d/target.xml"
ln -s target.xml "$d/link.xml"
expect_status 0 "-o a symbolic link" -- pane -o "$d/link.xml"
[ -L "$d/link.xml" ] && pass "the link is still a link" || fail "the link was replaced"
grep -q '</WindowElement>' "$d/target.xml" && pass "its target holds the output" || fail "target: $(head -c 100 "$d/target.xml")"
mkdir "$d/sub"
ln -s ../target.xml "$d/sub/rel.xml"  # relative to the link's directory, not ours
ln -s rel.xml "$d/sub/chain.xml"
echo old > "$d/target.xml"
expect_status 0 "-o a chain of relative links" -- pane -o "$d/sub/chain.xml"
[ -L "$d/sub/chain.xml" ] && [ -L "$d/sub/rel.xml" ] && grep -q '</WindowElement>' "$d/target.xml" \
    && pass "a chain of links: links kept, the final target written" || fail "link chain"
ln -s new.xml "$d/dangling.xml"
expect_status 0 "-o a dangling link" -- pane -o "$d/dangling.xml"
[ -L "$d/dangling.xml" ] && [ -f "$d/new.xml" ] && pass "a dangling link's target is created" || fail "dangling link"
ln -s abs-target.tsv "$d/abs.tsv"
expect_status 0 "--absorptance a symbolic link" -- pane --absorptance "$d/abs.tsv" -o "$d/d.xml"
[ -L "$d/abs.tsv" ] && head -1 "$d/abs-target.tsv" | grep -q '^channel' && pass "absorptance through a link" || fail "absorptance link"
ln -s map-target.svg "$d/map.svg"
expect_status 0 "compare --map a symbolic link" -- "$B" compare -k 1 --only Tf --incident 0,0 \
    --map "$d/map.svg" glass:clear-6mm glass:lowiron-6mm
[ -L "$d/map.svg" ] && grep -q '</svg>' "$d/map-target.svg" && pass "map through a link" || fail "map link"
ln -s loop1 "$d/loop2"; ln -s loop2 "$d/loop1"
expect_error "a loop of links" "loop1: Too many levels of symbolic links" -- pane -o "$d/loop1"
rm -f "$d/loop1" "$d/loop2"

# --- a replaced file keeps its mode (and, as root, its owner); a new one follows the umask
echo old > "$d/private.xml"
chmod 600 "$d/private.xml"
[ "$(id -u)" -eq 0 ] && chown 65534:65534 "$d/private.xml"
expect_status 0 "-o a 0600 file" -- pane -o "$d/private.xml"
[ "$(stat -c %a "$d/private.xml")" = 600 ] && pass "a 0600 file stays 0600" || fail "mode now $(stat -c %a "$d/private.xml")"
if [ "$(id -u)" -eq 0 ]; then
    [ "$(stat -c %u:%g "$d/private.xml")" = 65534:65534 ] && pass "its owner is kept" || fail "owner now $(stat -c %u:%g "$d/private.xml")"
fi
expect_status 0 "a new file under umask 027" -- sh -c 'umask 027; exec "$@"' sh "$B" combine -k 1 -o "$d/new027.xml" glass:clear-6mm
[ "$(stat -c %a "$d/new027.xml")" = 640 ] && pass "a new file is 0666 & ~umask" || fail "new file mode $(stat -c %a "$d/new027.xml")"

# --- a directory, an empty name
expect_error "a directory as output" "$d: is a directory" -- pane -o "$d"
expect_error "a directory as --absorptance" "$d: is a directory" -- pane --absorptance "$d" -o "$d/e.xml"
expect_error "an empty output name" "combine: -o '': an empty file name" -- pane -o ''
# an empty name or list is a usage error, exit 2, as other malformed values are (-o '' exited 1;
# --channels '' was taken as every channel, compare --channel '' as the first)
for args in "combine -k 1 -o '' glass:clear-6mm" "combine -k 1 --absorptance '' -o $d/x.xml glass:clear-6mm" \
    "combine -k 1 --incident-file '' -o $d/x.tsv glass:clear-6mm" "convert -o '' $f" "convert -o $d/x.xml ''" \
    "view -o '' $f" "combine -k 1 --channels '' -o $d/x.xml glass:clear-6mm" \
    "combine -k 1 --channels Visible,,Solar -o $d/x.xml glass:clear-6mm" "convert --channels , -o $d/x.xml $f" \
    "compare -k 1 --channel '' glass:clear-6mm glass:clear-4mm" \
    "plot --curve --tsv '' -o $d/x.svg $f" "plot -o '' $f"; do
    eval "set -- $args"
    expect_status 2 "$args: exit 2" -- "$B" "$@"
    [ "$(grep -vc "^Try 'bsdfstack" "$tmpdir/err")" -eq 1 ] && grep -Eq "(an empty file name|no channel named|an empty channel name)$" "$tmpdir/err" \
        && pass "one line saying so" || fail "$args: $(cat "$tmpdir/err")"
done
[ ! -e "$d/x.xml" ] && [ ! -e "$d/x.tsv" ] && pass "nothing written" || fail "written: $(ls "$d")"
[ ! -e "$d/e.xml" ] && pass "no system file beside a refused absorptance" || fail "e.xml written"

# --- an output whose temporary cannot be made: the message names the call that failed and why
# (-o /proc/version said "/proc/version: cannot create output file: No such file or directory", of
# a file that is there: ENOENT was the temporary's, in a file system that makes no new files)
if [ -f /proc/version ]; then
    expect_error "-o /proc/version" "^bsdfstack combine: /proc/version: cannot create output file: its temporary /proc/version\.tmpXXXXXX: No such file or directory \(/proc exists, but its file system makes no new files\)$" \
        -- pane -o /proc/version
fi
expect_error "-o in a missing directory" "^bsdfstack combine: $d/nodir/x\.xml: cannot create output file: $d/nodir: No such file or directory$" \
    -- pane -o "$d/nodir/x.xml"
mkdir "$d/ro" && chmod 555 "$d/ro"
if [ "$(id -u)" -ne 0 ]; then
    expect_error "-o in a read-only directory" "$d/ro/x\.xml: cannot create output file: its temporary $d/ro/x\.xml\.tmpXXXXXX: Permission denied$" \
        -- pane -o "$d/ro/x.xml"
else
    echo "skipped: a read-only directory (root writes there)"
fi
chmod 755 "$d/ro" && rm -rf "$d/ro"

# --- failures leave nothing: not a file, not a temporary; an old file keeps its content
expect_error "bad input" "nothere.xml: cannot open" -- "$B" combine -o "$d/f.xml" glass:clear-6mm "$d/nothere.xml"
[ ! -e "$d/f.xml" ] && pass "bad input: no output file" || fail "bad input left f.xml"
echo old > "$d/keep.xml"
expect_error "a write error on a file" "keep.xml: .*File too large" -- fsize_limited "$B" combine -k 3 -o "$d/keep.xml" glass:clear-6mm
[ "$(cat "$d/keep.xml")" = old ] && pass "a failed write keeps the old file" || fail "keep.xml changed"
expect_error "a write error on --absorptance" "big.tsv: .*File too large" -- \
    fsize_limited "$B" combine -k 3 --absorptance "$d/big.tsv" -o "$d/g.xml" glass:clear-6mm
[ ! -e "$d/big.tsv" ] && [ ! -e "$d/g.xml" ] && pass "neither file of a failed combine" || fail "partial files: $(ls "$d")"
no_leftovers "failed commands leave no temporaries"

# --- standard output: a lost write fails the command with one line
stdout_error() { expect_error "$1 > /dev/full" "^bsdfstack${2:+ $2}: error writing to standard output: No space left on device" -- to_full "${@:3}"; }
stdout_error "info" info "$B" info "$f"
stdout_error "glass" glass "$B" glass clear-6mm
stdout_error "glass --list" glass "$B" glass --list
stdout_error "compare" compare "$B" compare -k 1 --only Tf --incident 0,0 glass:clear-6mm glass:lowiron-6mm
stdout_error "plot (its summary)" plot "$B" plot --size 64 --format svg -o "$d/p.svg" "$f"
[ ! -e "$d/p.svg" ] && pass "plot: no image without its summary" || fail "plot wrote p.svg"
stdout_error "version" version "$B" version
stdout_error "--help" "" "$B" --help
stdout_error "combine --help" combine "$B" combine --help
stdout_error "combine -o -" combine "$B" combine -k 1 --incident 0,0 -o - glass:clear-6mm
printf '%s glass:clear-6mm\n' "$d/h.xml" > "$d/one.batch"
stdout_error "batch (its summary line)" batch "$B" batch -k 1 "$d/one.batch"
printf '0 0 -1 0 0 1\n' > "$d/dirs"
stdout_error "query" query from "$d/dirs" "$B" query "$f"
expect_error "combine -o - > /dev/full" "standard output: .*No space left on device" -- to_full pane -o -
expect_error "convert -o - > /dev/full" "standard output: .*No space left on device" -- \
    to_full "$B" convert "$f" -o -
# (plot -o - prints its summary on stderr: the error is the one line after it)
expect_status 1 "plot -o - > /dev/full" -- to_full "$B" plot --size 64 --format svg -o - "$ref/examples/k1_4d_TF.xml"
[ "$(grep -c 'error' "$tmpdir/err")" -eq 1 ] && grep -q "^bsdfstack plot: error writing to standard output: No space left on device" "$tmpdir/err" \
    && pass "plot -o - names the lost standard output once" || fail "plot -o -: $(cat "$tmpdir/err")"
expect_error "info >&-" "error writing to standard output: Bad file descriptor" -- stdout_closed "$B" info "$f"

# --- standard input: a read error is no end of input
expect_error "query < a directory" "error reading standard input: Is a directory" -- from "$d" "$B" query "$f"
expect_error "query <&-" "error reading standard input: Bad file descriptor" -- stdin_closed "$B" query "$f"
expect_error "batch - < a directory" "standard input: read error: Is a directory" -- from "$d" "$B" batch -
expect_error "combine --incident-file - <&-" "standard input: read error: Bad file descriptor" -- \
    stdin_closed "$B" combine --incident-file - -o "$d/i.tsv" glass:clear-6mm

# --- query --degrees: theta within [0, 90]
for bad in "91 0 0 0" "-1 0 0 0" "0 0 90.5 0" "0 0 -0.1 0"; do
    echo "$bad" > "$d/angles"
    expect_error "query --degrees '$bad'" "line 1: theta .* out of range.*\[0, 90\]" -- \
        from "$d/angles" "$B" query --degrees Tf "$f"
done
printf '0 0 0 0\n90 0 90 0\n' > "$d/angles"
expect_status 0 "query --degrees at 0 and 90" -- from "$d/angles" "$B" query --degrees Tf "$f"

# --- an absurd value gives a short warning, not 30 digits
sed '0,/<ScatteringData>/!{0,/^0 /s/^0 /1e30 /}' "$ref/examples/klems_TF.xml" > "$d/huge.xml"
grep -q '^1e30 ' "$d/huge.xml" || fail "the huge test file lacks its 1e30"
expect_status 0 "combine a layer holding 1e30" -- "$B" combine -o "$d/hc.xml" "$d/huge.xml"
line=$(grep 'T + R' "$tmpdir/err")
[ -n "$line" ] && [ "${#line}" -lt 200 ] && echo "$line" | grep -Eq 'T \+ R = [0-9.]+e\+[0-9]+ > 1' \
    && pass "the energy warning is short: $line" || fail "energy warning: $(head -c 300 "$tmpdir/err")"
expect_status 0 "info on a layer holding 1e30" -- "$B" info "$d/huge.xml"
[ "$(awk '!/^file/ { if (length($0) > m) m = length($0) } END { print m }' "$tmpdir/out")" -lt 100 ] \
    && grep -Eq 'largest Tf = [0-9.]+e\+[0-9]+' "$tmpdir/out" && pass "info prints 1e30 briefly" \
    || fail "info: $(head -c 300 "$tmpdir/out")"

# --- a Klems value past the single-precision range the trees are held in is refused as the file is
# read, naming the file and the value, as the tree reader does (combine -k 3 blamed the output:
# "out.xml: ... value 1.47715e+298 is not finite in single precision"; --klems combined it, warning
# only of another layer's T + R)
awk 'done || !/^[ \t]*[0-9]/ { print; next } n++ == 6 { print "\t1e300"; done = 1; next } { print }' \
    "$ref/L_blind45_t4k5_klems.xml" > "$d/k_huge.xml"
grep -q '^.1e300$' "$d/k_huge.xml" || fail "k_huge.xml lacks its 1e300"
for basis in "-k 3" --klems; do
    expect_error "combine $basis with a Klems value of 1e300" \
        "^bsdfstack combine: $d/k_huge\.xml: line [0-9]+: <ScatteringData>: value no\. 7, '1e300', exceeds the single-precision range" \
        -- "$B" combine $basis -o "$d/kh.xml" glass:clear-6mm "$d/k_huge.xml"
    [ ! -e "$d/kh.xml" ] && pass "no output" || fail "combine $basis wrote kh.xml"
done
expect_error "info on it" "^bsdfstack info: $d/k_huge\.xml: .*'1e300', exceeds the single-precision" -- \
    "$B" info "$d/k_huge.xml"
finish
