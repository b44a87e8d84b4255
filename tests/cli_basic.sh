# cli_basic.sh - the program's global behaviour: help, version, unknown commands.
. "${BST_SRCDIR:-.}/tests/clitest.sh"

expect_status 0 "--help exits 0" -- "$BSDFSTACK" --help
grep -q '^Usage: bsdfstack COMMAND' "$tmpdir/out" || fail "--help prints the usage line"
expect_status 0 "--version exits 0" -- "$BSDFSTACK" --version
grep -Eq '^bsdfstack [0-9]+\.[0-9]+\.[0-9]+ ' "$tmpdir/out" || fail "--version prints a version"
expect_error "no command is a usage error" "missing command" -- "$BSDFSTACK"
expect_error "unknown command" "unknown command 'frobnicate'" -- "$BSDFSTACK" frobnicate
# every listed command answers --help with exit 0 and a Usage line
for cmd in $("$BSDFSTACK" --help | awk '/^Commands:/{on=1; next} on && /^  [a-z]/{print $1}'); do
    expect_status 0 "$cmd --help" -- "$BSDFSTACK" "$cmd" --help
    grep -q '^Usage: bsdfstack' "$tmpdir/out" || fail "$cmd --help prints a Usage line"
done
finish
