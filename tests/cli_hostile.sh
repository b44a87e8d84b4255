# cli_hostile.sh - hostile and unlucky input, round two (issue #34): every command that reads a
# BSDF file refuses one that mixes kinds of scattering data; compare refuses a bad table of
# combine --incident with one line; names that are not UTF-8 leave outputs that read back;
# two outputs of one command that name one file are refused, however spelt; a NUL byte in a
# line of a text input is an error, not the end of the line; --resume does not wait on a FIFO;
# a malformed SOURCE_DATE_EPOCH is an error before any work; convert warns of zeros it writes;
# errors say what a file is, and keep their reason however long the path.
. "${BST_SRCDIR:-.}/tests/clitest.sh"
B=$BSDFSTACK
from() { local f=$1; shift; "$@" < "$f"; } # for expect_error: a command reading FILE
regress=$BST_SRCDIR/tests/fuzz/regress/xml
d=$tmpdir/o
mkdir "$d" || exit 99

# --- a file mixing a Klems block and a tensor-tree block is refused by every reader, in one line
# naming the file (each died of SIGSEGV: a NULL overlap table or a NULL matrix)
for mixed in "$regress"/mixed-*.xml; do
    m=$(basename "$mixed")
    why="$m: line [0-9]+: a [A-Za-z0-9]+ block after [A-Za-z0-9]+ blocks"
    expect_error "info $m" "^bsdfstack info: .*$why" -- "$B" info "$mixed"
    expect_error "convert $m" "^bsdfstack convert: .*$why" -- "$B" convert -k 1 "$mixed" -o "$d/c.xml"
    expect_error "combine $m" "^bsdfstack combine: .*$why" -- \
        "$B" combine -k 1 glass:clear-6mm "$mixed" -o "$d/s.xml"
    expect_error "compare $m" "^bsdfstack compare: .*$why" -- "$B" compare -k 1 glass:clear-6mm "$mixed"
    expect_error "plot --curve $m" "^bsdfstack plot: .*$why" -- \
        "$B" plot --curve --format svg -o "$d/p.svg" "$mixed"
    expect_error "query $m" "^bsdfstack query: .*$why" -- "$B" query "$mixed" < /dev/null
    printf '%s glass:clear-6mm %s\n' "$d/b.xml" "$mixed" > "$d/mixed.batch"
    expect_status 1 "batch $m" -- "$B" batch -k 1 "$d/mixed.batch"
    grep -Eq "$why" "$tmpdir/err" && pass "batch names $m" || fail "batch $m: $(cat "$tmpdir/err")"
done
[ "$(ls "$d")" = mixed.batch ] && pass "no output from a mixed file" || fail "outputs left: $(ls "$d")"

# --- compare on a table of combine --incident that its reader refuses: one error line, exit 1
# (a refused table's file was closed twice: SIGABRT on a double free)
t=$tmpdir/t
mkdir "$t" || exit 99
"$B" combine -k 1 --incident 0,0 glass:clear-6mm -o "$t/ok.tsv" 2>/dev/null || fail "combine --incident"
head -n 1 "$t/ok.tsv" > "$t/header-only.tsv"
{ cat "$t/ok.tsv"; tail -n 1 "$t/ok.tsv"; } > "$t/duplicated-row.tsv"
{ head -n 2 "$t/ok.tsv"; printf 'not a row\n'; } > "$t/malformed-row.tsv"
sed '3s/\t30\.0000\t/\t31.0000\t/' "$t/ok.tsv" > "$t/moved-exit.tsv"   # refused by the second pass
for bad in header-only duplicated-row malformed-row moved-exit; do
    expect_error "compare $bad.tsv" "^bsdfstack compare: .*$bad\.tsv" -- \
        "$B" compare "$t/$bad.tsv" glass:clear-6mm
    expect_error "compare ok.tsv $bad.tsv" "^bsdfstack compare: .*$bad\.tsv" -- \
        "$B" compare "$t/ok.tsv" "$t/$bad.tsv"
done

# --- a file name, -o path or --name whose bytes are not UTF-8 goes into the XML (declared UTF-8)
# as U+FFFD, so that the output reads back (nothing could read it: exit 0, an unreadable file)
u=$tmpdir/u
mkdir "$u" || exit 99
bad=$(printf 'x\377\300\257y')
expect_status 0 "combine -o a non-UTF-8 name" -- "$B" combine -k 1 glass:clear-6mm -o "$u/$bad.xml"
expect_status 0 "info reads it back" -- "$B" info "$u/$bad.xml"
expect_status 0 "convert --name non-UTF-8 of a non-UTF-8 file" -- \
    "$B" convert --name "$bad" "$u/$bad.xml" -o "$u/named.xml"
expect_status 0 "info reads the converted file back" -- "$B" info "$u/named.xml"
grep -q "<Name>x$(printf '\357\277\275\357\277\275\357\277\275')y</Name>" "$u/named.xml" &&
    pass "each byte that is not UTF-8 is one U+FFFD" || fail "named.xml: $(grep -a '<Name>' "$u/named.xml")"
printf '%s glass:clear-6mm\n' "$u/$bad-batch.xml" > "$u/b.batch"
expect_status 0 "batch to a non-UTF-8 output name" -- "$B" batch -k 1 "$u/b.batch"
expect_status 0 "info reads the batch output back" -- "$B" info "$u/$bad-batch.xml"
# a figure names the file in its legend or title: cairo takes UTF-8 only (it failed as "out of
# memory drawing the chart"); such bytes are drawn as '?'
for fmt in svg png pdf; do
    expect_status 0 "plot --curve --format $fmt of a non-UTF-8 file name" -- \
        "$B" plot --curve --format "$fmt" -o "$u/curve.$fmt" "$u/$bad.xml"
done
expect_status 0 "plot (a map) of a non-UTF-8 file name" -- "$B" plot --format svg -o "$u/map.svg" "$u/$bad.xml"
tail -c 10 "$u/map.svg" | grep -q '</svg>' && pass "the map is a whole SVG" || fail "map.svg: $(tail -c 100 "$u/map.svg")"

# --- two outputs that name one file, however spelt, are refused before anything is written (one
# result was silently lost, exit 0)
a=$tmpdir/a
mkdir "$a" || exit 99
cd "$a" || exit 99
printf 'a.xml glass:clear-6mm\n./a.xml glass:clear-6mm\n' > dot.batch
expect_error "batch: a.xml and ./a.xml" "dot.batch:2: '\./a\.xml' is the file line 1 writes already" -- \
    "$B" batch -k 1 dot.batch
ln -s a.xml link.xml
printf 'a.xml glass:clear-6mm\nlink.xml glass:clear-6mm\n' > link.batch
expect_error "batch: a link to another line's output" "link.batch:2: 'link\.xml' is the file line 1" -- \
    "$B" batch -k 1 link.batch
printf 'a.xml glass:clear-6mm\nb.xml glass:clear-6mm\n' > two.batch
expect_error "batch --summary an output" "two.batch:2: the output 'b\.xml' is the --summary file \./b\.xml" -- \
    "$B" batch -k 1 --summary ./b.xml two.batch
expect_error "batch --summary the batch file" "--summary \./two\.batch is the batch file two\.batch" -- \
    "$B" batch -k 1 --summary ./two.batch two.batch
printf 'self.batch glass:clear-6mm\n' > self.batch
expect_error "batch: an output that is the batch file" "self.batch:1: the output 'self\.batch' is the batch file" -- \
    "$B" batch -k 1 self.batch
[ ! -e a.xml ] && [ ! -e b.xml ] && grep -q glass two.batch && grep -q glass self.batch &&
    pass "nothing written, the batch files intact" || fail "written: $(ls)"
expect_error "combine --absorptance through a link to -o" "--absorptance link\.xml and -o a\.xml name the same file" -- \
    "$B" combine -k 1 --absorptance link.xml -o a.xml glass:clear-6mm
expect_error "combine --absorptance ./a.tsv -o a.tsv" "name the same file" -- \
    "$B" combine -k 1 --absorptance ./a.tsv -o a.tsv glass:clear-6mm
"$B" combine -k 1 glass:clear-6mm -o sys.xml 2>/dev/null || fail "combine sys.xml"
expect_error "plot --tsv X -o X" "--tsv \./c\.svg and -o c\.svg name the same file" -- \
    "$B" plot --curve --tsv ./c.svg -o c.svg sys.xml
expect_error "plot --tsv - -o -" "both write to standard output" -- "$B" plot --curve --tsv - -o - sys.xml
[ ! -e a.xml ] && [ ! -e a.tsv ] && [ ! -e c.svg ] && pass "no output from a refused command" ||
    fail "written: $(ls)"
expect_status 0 "--absorptance and -o two files" -- \
    "$B" combine -k 1 --absorptance a.tsv -o b.xml glass:clear-6mm
cd - > /dev/null || exit 99

# --- a NUL byte in a line of any text input is refused, naming the line and column (the rest of
# the line was dropped: a one-pane stack written and reported ok)
z=$tmpdir/z
mkdir "$z" || exit 99
cd "$z" || exit 99
printf '# two panes\nz.xml glass:clear-6mm\000 glass:clear-6mm\n' > nul.batch
expect_error "batch: a NUL byte" "nul\.batch:2: a NUL byte at column 22" -- "$B" batch -k 1 nul.batch
[ ! -e z.xml ] && pass "batch: nothing written" || fail "batch wrote z.xml"
printf '0 0\n10 0\000 junk\n' > nul.dirs
expect_error "combine --incident-file: a NUL byte" "nul\.dirs:2: a NUL byte at column 5" -- \
    "$B" combine -k 1 --incident-file nul.dirs glass:clear-6mm -o z.tsv
{ head -c 100000 /dev/zero | tr '\000' 1; printf ' 0\n5 5\n'; } > long.dirs
expect_error "combine --incident-file: a 100 kB line is line 1" "long\.dirs:1: give THETA PHI" -- \
    "$B" combine -k 1 --incident-file long.dirs glass:clear-6mm -o z.tsv
printf '0 0\n' | "$B" combine -k 1 --incident-file - glass:clear-6mm -o ok.tsv 2> /dev/null ||
    fail "combine --incident"
sed '3s/$/X/' ok.tsv | tr X '\000' > nul.tsv
expect_error "compare: a NUL byte in a table" "nul\.tsv:3: a NUL byte" -- "$B" compare nul.tsv ok.tsv
expect_error "plot: a NUL byte in a table" "nul\.tsv:3: a NUL byte" -- "$B" plot -o z.png nul.tsv
"$B" combine -k 1 glass:clear-6mm -o q.xml 2> /dev/null || fail "combine q.xml"
printf '0 0 -1 0.1 0.1 1\000 junk\n' > nul.query
expect_error "query: a NUL byte on standard input" "standard input:1: a NUL byte at column 17" -- \
    from nul.query "$B" query q.xml
mkdir cat && printf 'description two channels\nVisible d=6mm,n=1.52,tn=0.890\000\nSolar d=6mm,n=1.52,tn=0.790\n' > cat/nul.glass
expect_error "glass: a NUL byte in a catalogue file" "nul\.glass: line 2 holds a NUL byte" -- \
    env BSDFSTACK_GLASS_DIR="$z/cat" "$B" glass nul
cd - > /dev/null || exit 99

# --- --resume with an output that is a FIFO: the up-to-date check does not open it to read (it
# waited for a writer for ever); the stack is written into the FIFO again
f=$tmpdir/f
mkdir "$f" || exit 99
mkfifo "$f/out.fifo"
printf '%s glass:clear-6mm\n' "$f/out.fifo" > "$f/fifo.batch"
timeout 70 cat "$f/out.fifo" > "$f/read.xml" &  # bounded: a failing check must not hang here
reader=$!
expect_status 0 "batch --resume, a FIFO output: no hang" -- timeout 60 "$B" batch -k 1 --resume "$f/fifo.batch"
wait "$reader"
grep -q '</WindowElement>' "$f/read.xml" && pass "the stack went through the FIFO" || fail "FIFO got $(wc -c < "$f/read.xml") bytes"
[ -p "$f/out.fifo" ] && pass "the FIFO is still a FIFO" || fail "out.fifo replaced"

# --- a malformed SOURCE_DATE_EPOCH is an error, before the work (the current date was written)
e=$tmpdir/e
mkdir "$e" || exit 99
printf '%s glass:clear-6mm\n' "$e/b.xml" > "$e/e.batch"
"$B" combine -k 1 glass:clear-6mm -o "$e/in.xml" 2> /dev/null || fail "combine in.xml"
for v in -1 abc 1e20 99999999999999999999 ' 5' 253402300800; do
    expect_error "combine, SOURCE_DATE_EPOCH='$v'" "SOURCE_DATE_EPOCH '$v' is not a whole number of seconds" -- \
        env SOURCE_DATE_EPOCH="$v" "$B" combine -k 1 glass:clear-6mm -o "$e/a.xml"
done
expect_error "convert, SOURCE_DATE_EPOCH=abc" "SOURCE_DATE_EPOCH 'abc'" -- \
    env SOURCE_DATE_EPOCH=abc "$B" convert -k 1 "$e/in.xml" -o "$e/a.xml"
expect_error "batch, SOURCE_DATE_EPOCH=abc" "SOURCE_DATE_EPOCH 'abc'" -- \
    env SOURCE_DATE_EPOCH=abc "$B" batch -k 1 "$e/e.batch"
[ ! -e "$e/a.xml" ] && [ ! -e "$e/b.xml" ] && pass "nothing written" || fail "written: $(ls "$e")"
expect_status 0 "SOURCE_DATE_EPOCH=253402300799" -- \
    env SOURCE_DATE_EPOCH=253402300799 "$B" combine -k 1 glass:clear-6mm -o "$e/a.xml"
grep -q "on 9999-12-31T23:59:59Z" "$e/a.xml" && pass "the last date written" || fail "date: $(grep -m1 ' on ' "$e/a.xml")"
expect_status 0 "SOURCE_DATE_EPOCH empty: the current date" -- \
    env SOURCE_DATE_EPOCH= "$B" combine -k 1 glass:clear-6mm -o "$e/a.xml"

# --- convert warns when it writes a component the file lacks as zeros, as combine does (it wrote
# them without a word); a transmission given by reciprocity is no news
tf_only=$BST_SRCDIR/tests/fuzz/corpus/xml/k1_4d_TF.xml
expect_status 0 "convert a file of Tf only" -- "$B" convert -k 1 "$tf_only" -o "$e/tf.xml"
grep -q "warning: .*k1_4d_TF.xml: not in the file, written as zero: Visible Rf, Visible Rb" "$tmpdir/err" &&
    [ "$(wc -l < "$tmpdir/err")" -eq 1 ] && pass "convert names the zeros it writes" ||
    fail "convert stderr: $(cat "$tmpdir/err")"
"$B" convert -k 1 "$e/tf.xml" -o "$e/tf2.xml" 2> "$e/err2" && [ ! -s "$e/err2" ] &&
    pass "convert of a complete file says nothing" || fail "convert tf.xml: $(cat "$e/err2")"

# --- errors say what is wrong: a directory, UTF-32 text, a /proc file (not "Document is empty"
# or "the file is empty"); a path of 1000 characters keeps the reason at the end of the line
m=$tmpdir/m
mkdir "$m" || exit 99
expect_error "info on a directory" "$m: a directory, not a BSDF XML file" -- "$B" info "$m"
expect_error "combine with a directory as a layer" "a directory, not a BSDF XML file" -- \
    "$B" combine -k 1 "$m" -o "$m/x.xml"
printf '\000\000\376\377\000\000\000<\000\000\000?' > "$m/u32.xml"
expect_error "info on UTF-32 text" "u32\.xml: UTF-32 text" -- "$B" info "$m/u32.xml"
expect_error "info on a /proc file" "/proc/self/status: line 1: malformed XML" -- "$B" info /proc/self/status
long=$m
for part in 1 2 3 4 5 6; do long=$long/$(printf "%0200d" "$part"); done
long=$long/layer.xml
expect_error "a path of $((${#long})) characters" "^bsdfstack info: $m/0+1/.*\.\.\..*/layer\.xml: cannot open: No such file or directory$" -- \
    "$B" info "$long"

# --- query warns of negative Klems values read as 0, as info does (it said nothing)
sed '0,/^0.1, /s//-0.1, /' "$BST_SRCDIR/tests/fuzz/corpus/xml/klems_tiny_2ch.xml" > "$m/neg.xml"
printf '0 0 1 0 0 -1\n' > "$m/q.txt"
expect_status 0 "query a Klems file with a negative value" -- from "$m/q.txt" "$B" query "$m/neg.xml"
grep -q "warning: .*neg\.xml: 1 negative value read as 0" "$tmpdir/err" && pass "query says so" ||
    fail "query stderr: $(cat "$tmpdir/err")"
expect_status 0 "info on it" -- "$B" info "$m/neg.xml"
grep -q "1 negative value read as 0" "$tmpdir/err" && pass "as info says" || fail "info stderr: $(cat "$tmpdir/err")"

# --- a spectral pane of many rows (10^5 rows took 98 s at k = 5 without a word): past
# BST_GLASS_LAYER_ROWS (5000) its layer sums groups of adjacent wavelengths, and says so in one
# line (5999 of the 6000 rows weigh in Solar: the solar source is 0 at the first, 0.3 um); with rows=all
# it sums each and warns of the cost; the catalogue's panes say nothing
awk 'BEGIN { for (i = 0; i < 6000; i++) printf "%.8f 0.8 0.8 0.08 0.08\n", 0.3 + 2.2 * i / 5999 }' > "$m/many.txt"
expect_status 0 "combine a pane of 6000 wavelengths" -- "$B" combine -k 1 "glass:$m/many.txt" -o "$m/many.xml"
grep -q "warning: glass:.*many\.txt: its layer sums the model over 5000 groups of adjacent wavelengths (each at their weighted mean data) instead of Solar's 5999 wavelengths one by one; rows=all" "$tmpdir/err" &&
    [ "$(wc -l < "$tmpdir/err")" -eq 1 ] && pass "it says so in one line" || fail "stderr: $(cat "$tmpdir/err")"
expect_status 0 "the same with rows=all" -- "$B" combine -k 1 "glass:$m/many.txt,rows=all" -o "$m/many.xml"
grep -q "warning: glass:.*many\.txt,rows=all: 5999 wavelengths: the pane is evaluated at each of them" "$tmpdir/err" &&
    pass "rows=all warns of the cost" || fail "stderr: $(cat "$tmpdir/err")"
expect_error "rows=1" "rows=1 \\(all, or a count of at least 2\\)" -- "$B" combine -k 1 "glass:$m/many.txt,rows=1" -o "$m/many.xml"
expect_status 0 "combine a catalogue pane" -- "$B" combine -k 1 glass:nfrc-102 -o "$m/cat.xml"
! grep -q "wavelengths" "$tmpdir/err" && pass "a catalogue pane does not warn" || fail "stderr: $(cat "$tmpdir/err")"

finish
