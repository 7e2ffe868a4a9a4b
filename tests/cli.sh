#!/bin/sh
# Tests of the `lrr` command-line tool, run by `make check`.
# Environment: LRR_BIN (the built lrr; default ./lrr), LRR_TEST_TMP (a writable directory).
# Prints one line per check; exits 0 when all pass, 1 otherwise.
set -u

LRR=${LRR_BIN:-./lrr}
TMPROOT=${LRR_TEST_TMP:-${TMPDIR:-/tmp}}
if [ ! -x "$LRR" ]; then
    echo "FAIL: LRR_BIN='$LRR' is not an executable"
    exit 1
fi
T=$(mktemp -d "$TMPROOT/cli.XXXXXX") || { echo "FAIL: cannot create a directory in $TMPROOT"; exit 1; }

failures=0
checks=0
pass() { checks=$((checks + 1)); echo "PASS: $1"; }
fail() { checks=$((checks + 1)); failures=$((failures + 1)); echo "FAIL: $1"; }

# run ARGS...: runs lrr, stdout in $T/out, stderr in $T/err, exit status in $rc.
run() {
    "$LRR" "$@" >"$T/out" 2>"$T/err"
    rc=$?
}

# value KEY: the value of a "key: value" line of the last stdout.
value() { sed -n "s/^$1: //p" "$T/out" | head -n 1; }

show_err() { sed 's/^/    stderr: /' "$T/err" | head -n 5; }

# expect_rc WANT DESCRIPTION
expect_rc() {
    if [ "$rc" -eq "$1" ]; then pass "$2 (exit $rc)"; else fail "$2: exit $rc, expected $1"; show_err; fi
}

# ---------------------------------------------------------------- help and version
run --help
if [ "$rc" -eq 0 ] && grep -q 'preprocess' "$T/out" && grep -q -- '--version' "$T/out"; then
    pass "lrr --help lists the commands"
else
    fail "lrr --help (exit $rc)"
fi

run --version
if [ "$rc" -eq 0 ] && grep -Eq '^lrr [0-9]+\.[0-9]+\.[0-9]+$' "$T/out"; then
    pass "lrr --version prints $(cat "$T/out")"
else
    fail "lrr --version (exit $rc): $(cat "$T/out")"
fi

# help_mentions COMMAND OPTION...: COMMAND --help exits 0 and names every OPTION.
help_mentions() {
    cmd=$1
    shift
    run "$cmd" --help
    missing=""
    for opt in "$@"; do
        grep -q -- "$opt" "$T/out" || missing="$missing $opt"
    done
    if [ "$rc" -eq 0 ] && [ -z "$missing" ]; then
        pass "lrr $cmd --help mentions $*"
    else
        fail "lrr $cmd --help (exit $rc), missing:$missing"
    fi
}
help_mentions info --max-patch-area --patches --levels cornell
help_mentions preprocess -o --hemicube --seed --threads --progress --patches --levels
help_mentions solve --csv --emission-scale --repeat
help_mentions render -o --width --height --exposure --emission-scale
help_mentions demo --out

# ---------------------------------------------------------------- command-line errors
run info cornell --bogus-option
if [ "$rc" -eq 2 ] && grep -q -- '--bogus-option' "$T/err"; then
    pass "unknown option: exit 2 naming it"
else
    fail "unknown option: exit $rc, stderr: $(cat "$T/err")"
fi

run frobnicate
if [ "$rc" -eq 2 ] && grep -q 'frobnicate' "$T/err"; then
    pass "unknown command: exit 2 naming it"
else
    fail "unknown command: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --levels abc
if [ "$rc" -eq 2 ] && grep -q -- "--levels: 'abc' is not an integer" "$T/err"; then
    pass "--levels abc: exit 2, $(cat "$T/err")"
else
    fail "--levels abc: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --levels 11
if [ "$rc" -eq 2 ] && grep -q 'out of range' "$T/err"; then
    pass "--levels 11: exit 2, out of range"
else
    fail "--levels 11: exit $rc, stderr: $(cat "$T/err")"
fi

run info cornell --patches 5x
expect_rc 2 "--patches 5x is rejected"
run info cornell --patches -3
expect_rc 2 "--patches -3 is rejected"
run info cornell --patches 10 --max-patch-area 100
expect_rc 2 "--patches with --max-patch-area is rejected"
run info cornell --levels
expect_rc 2 "--levels without a value is rejected"
run info
expect_rc 2 "info without SCENE is rejected"
run preprocess cornell
expect_rc 2 "preprocess without -o is rejected"
run solve nothing.lrr --emission-scale -1
expect_rc 2 "--emission-scale -1 is rejected"
run solve nothing.lrr --emission-scale nan
expect_rc 2 "--emission-scale nan is rejected"
run solve nothing.lrr --repeat 0
expect_rc 2 "--repeat 0 is rejected"

# ---------------------------------------------------------------- info
run info cornell --patches 50 --levels 1
patches=$(value patches)
subpatches=$(value subpatches)
if [ "$rc" -eq 0 ] && [ "$(value triangles)" = 36 ] && [ -n "$patches" ] &&
    [ "$patches" -ge 36 ] && [ "$subpatches" = $((4 * patches)) ] && [ "$(value d)" = 4 ]; then
    pass "info cornell: triangles 36, patches $patches, subpatches $subpatches = 4 x patches"
else
    fail "info cornell (exit $rc): triangles '$(value triangles)', patches '$patches', subpatches '$subpatches'"
    show_err
fi

missing_scene="$T/no-such-dir/scene.obj"
run info "$missing_scene"
if [ "$rc" -eq 1 ] && grep -qF "$missing_scene" "$T/err"; then
    pass "missing scene file: exit 1 naming the path"
else
    fail "missing scene file: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- preprocess
LRRFILE="$T/small.lrr"
run preprocess cornell -o "$LRRFILE" --patches 30 --levels 1 --hemicube 32 --threads 2
n=$(value n)
if [ "$rc" -eq 0 ] && [ -s "$LRRFILE" ] && [ -n "$n" ] && [ "$n" -gt 0 ] &&
    [ "$(value output)" = "$LRRFILE" ] && [ "$(value hemicube)" = 32 ]; then
    pass "preprocess writes $(wc -c <"$LRRFILE" | tr -d ' ') bytes, n = $n, k = $(value k)"
else
    fail "preprocess (exit $rc)"
    show_err
fi
leftover=""
for f in "$T"/*tmp*; do [ -e "$f" ] && leftover="$leftover $f"; done
if [ -n "$leftover" ]; then fail "preprocess left temporary files:$leftover"; else pass "preprocess left no temporary file"; fi

# ---------------------------------------------------------------- solve
CSV="$T/b.csv"
run solve "$LRRFILE" --csv "$CSV" --repeat 3
mean1=$(value mean_b_r)
if [ "$rc" -eq 0 ] && [ "$(value n)" = "$n" ] && [ -n "$(value solve_ms)" ] && [ -n "$mean1" ]; then
    pass "solve prints n = $n, solve_ms = $(value solve_ms), mean_b_r = $mean1"
else
    fail "solve (exit $rc)"
    show_err
fi

header='subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b'
if [ -f "$CSV" ] && [ "$(head -n 1 "$CSV")" = "$header" ]; then
    pass "CSV header is exact"
else
    fail "CSV header: '$(head -n 1 "$CSV" 2>/dev/null)'"
fi
[ -f "$CSV" ] || : >"$CSV" # a missing CSV has already failed above; keep the checks quiet
rows=$(($(wc -l <"$CSV") - 1))
if [ "$rows" = "$n" ]; then pass "CSV has n = $n rows"; else fail "CSV has $rows rows, expected $n"; fi

# Every b is a finite number >= 0, subpatch counts up from 0, patch = subpatch / d.
bad=$(awk -F, -v d=4 '
    NR == 1 { next }
    {
        if ($1 != NR - 2 || $2 != int($1 / d)) { print "row " NR ": index " $1 " patch " $2; exit }
        for (i = 10; i <= 12; i++)
            if ($i !~ /^[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?$/) { print "row " NR ": b = " $i; exit }
        if (NF != 12) { print "row " NR ": " NF " fields"; exit }
    }' "$CSV")
if [ -z "$bad" ] && [ "$rows" -gt 0 ]; then pass "CSV: indices in order, all b finite and >= 0"; else fail "CSV: $bad"; fi

run solve "$LRRFILE" --emission-scale 2 --repeat 1
mean2=$(value mean_b_r)
if [ "$rc" -eq 0 ] && awk -v a="$mean1" -v b="$mean2" \
    'BEGIN { r = b - 2 * a; if (r < 0) r = -r; exit !(a > 0 && r <= 1e-5 * b) }'; then
    pass "solve is linear in the emission: $mean2 = 2 x $mean1"
else
    fail "emission scale 2: mean_b_r '$mean2' vs 2 x '$mean1' (exit $rc)"
fi

run solve "$LRRFILE" --emission-scale 0 --repeat 1
if [ "$rc" -eq 0 ] && [ "$(value max_b)" = 0 ]; then
    pass "no emission, no light: max_b = 0"
else
    fail "emission scale 0: max_b '$(value max_b)' (exit $rc)"
fi

run solve "$LRRFILE" --csv "$T/no-such-dir/b.csv" --repeat 1
if [ "$rc" -eq 1 ] && grep -q 'no-such-dir/b.csv' "$T/err"; then
    pass "unwritable CSV: exit 1 naming it"
else
    fail "unwritable CSV: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- render
PNG="$T/b.png"
run render "$LRRFILE" -o "$PNG" --width 64 --height 48
sig=$(od -An -tx1 -N8 "$PNG" 2>/dev/null | tr -d ' \n')
if [ "$rc" -eq 0 ] && [ "$sig" = 89504e470d0a1a0a ]; then
    pass "render writes a PNG ($(wc -c <"$PNG" | tr -d ' ') bytes)"
else
    fail "render (exit $rc), signature '$sig'"
    show_err
fi

# ---------------------------------------------------------------- damaged input
size=$(wc -c <"$LRRFILE" | tr -d ' ')
head -c $((size / 2)) "$LRRFILE" >"$T/truncated.lrr"
run solve "$T/truncated.lrr" --repeat 1
if [ "$rc" -eq 1 ] && grep -Eqi 'corrupt|truncated' "$T/err"; then
    pass "truncated .lrr: exit 1, $(head -n 1 "$T/err")"
else
    fail "truncated .lrr: exit $rc, stderr: $(cat "$T/err")"
fi

run solve "$T/no-such.lrr"
if [ "$rc" -eq 1 ] && grep -q 'no-such.lrr' "$T/err"; then
    pass "missing .lrr: exit 1 naming it"
else
    fail "missing .lrr: exit $rc, stderr: $(cat "$T/err")"
fi

# ---------------------------------------------------------------- summary
if [ "$failures" -eq 0 ]; then
    rm -rf "$T"
    echo "all $checks checks passed"
    exit 0
fi
echo "$failures of $checks checks failed (files kept in $T)"
exit 1
