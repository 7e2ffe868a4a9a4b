#!/bin/sh
# The bash completion of lrr (completion/lrr): sourced into bash, its function _lrr is
# called with COMP_WORDS/COMP_CWORD as bash would, and COMPREPLY is compared with what the
# tool's --help says: the commands, each command's long options (so the completion cannot
# drift from the help texts: `make update-docs` regenerates it), the values of options
# whose help lists them, and the files a command or option takes.
# Environment: LRR_BIN, LRR_SRCDIR, LRR_TEST_TMP (make check).
set -u
top=${LRR_SRCDIR:-$(cd "$(dirname "$0")/.." && pwd)}
LRR=${LRR_BIN:-$top/lrr}
command -v bash >/dev/null 2>&1 || { echo "completion: bash not found: skipped"; exit 77; }
T=$(mktemp -d "${LRR_TEST_TMP:-${TMPDIR:-/tmp}}/completion.XXXXXX") || exit 1
trap 'rm -rf "$T"' EXIT
failures=0
pass() { echo "PASS: $1"; }
fail() { failures=$((failures + 1)); echo "FAIL: $1"; }

# offers WORDS...: what <TAB> after these words (the last one being completed, possibly
# '') offers, sorted, on one line; run in $T/files
mkdir "$T/files" "$T/files/sub"
: > "$T/files/a.obj"; : > "$T/files/b.lrr"; : > "$T/files/c.txt"; : > "$T/files/d.csv"
: > "$T/files/e.hdr"; : > "$T/files/f.glb"
offers() {
    (cd "$T/files" && bash --norc --noprofile -c '
        . "$0" || exit 1
        COMP_WORDS=("$@"); COMP_CWORD=$(($# - 1)); COMP_LINE="$*"; COMP_POINT=${#COMP_LINE}
        _lrr lrr "${COMP_WORDS[COMP_CWORD]}" "${COMP_WORDS[COMP_CWORD - 1]}"
        printf "%s\n" "${COMPREPLY[@]}"' "$top/completion/lrr" "$@") | sort -u |
        tr '\n' ' ' | sed 's/ $//'
}
# expect DESCRIPTION WANT WORDS...
expect() {
    what=$1 want=$2
    shift 2
    got=$(offers "$@")
    if [ "$got" = "$want" ]; then
        pass "$what: '$*<TAB>' offers '$got'"
    else
        fail "$what: '$*<TAB>' offers '$got', expected '$want'"
    fi
}

if bash --norc --noprofile -c '. "$0" && complete -p lrr' "$top/completion/lrr" 2>&1 |
    grep -q -- '-F _lrr lrr$'; then
    pass "sourcing completion/lrr registers complete -F _lrr lrr"
else
    fail "completion/lrr does not register _lrr for lrr"
fi

cmds=$("$LRR" --help | sed -n '/^Commands:/,/^$/s/^  \([a-z0-9][a-z0-9]*\) .*/\1/p' | sort | tr '\n' ' ')
expect "commands" "$(echo "$cmds--help --version -V -h" | tr ' ' '\n' | sort | tr '\n' ' ' | sed 's/ $//')" lrr ''
expect "commands starting re" "reference render" lrr re
# every command's long options, as its --help lists them (option terms: lines indented
# 1-4 columns starting with '-', up to a gap of two spaces)
for cmd in $cmds; do
    want=$("$LRR" "$cmd" --help | sed -n 's/^ \{1,4\}\(-.*\)/\1/p' | sed 's/  .*//' |
        tr ' ,' '\n\n' | grep -- '^--' | sed 's/[^a-zA-Z0-9-].*//' | sort -u | tr '\n' ' ' |
        sed 's/ $//')
    [ -n "$want" ] || fail "lrr $cmd --help lists no options"
    expect "lrr $cmd options" "$want" lrr "$cmd" --
done
expect "options of render starting --pro" "--probe --probe-method --probe-scale" lrr render --pro
# values the help texts list
expect "--storage values" "bf16 f16 f32" lrr preprocess a.obj --storage ''
expect "--formfactor values" "auto raster raycast" lrr reference a.obj --formfactor ''
expect "--backend values" "cpu opencl" lrr solve b.lrr --backend ''
expect "--method values" "direct gauss-seidel jacobi path-trace southwell" lrr reference a.obj --method ''
expect "--format values" "exr png" lrr render b.lrr --format ''
expect "--format values of export" "gltf ply" lrr export b.lrr -o x --format ''
# files by kind; numbers are not completed
expect "a scene" "a.obj cornell cornell-closed f.glb sub" lrr info ''
expect "a scene starting c" "cornell cornell-closed" lrr check c
expect "an operator" "b.lrr sub" lrr render ''
expect "a probe" "e.hdr sub" lrr probe ''
expect "two CSV files" "d.csv sub" lrr compare d.csv ''
expect "check --fix OUT.obj" "a.obj sub" lrr check a.obj --fix ''
expect "solve --csv OUT.csv" "d.csv sub" lrr solve b.lrr --csv ''
expect "render -o OUT (any file)" "a.obj b.lrr c.txt d.csv e.hdr f.glb sub" lrr render b.lrr -o ''
expect "demo --out DIR" "sub" lrr demo --out ''
expect "a number" "" lrr render b.lrr --width ''
expect "an unknown command" "" lrr frobnicate ''

[ "$failures" -eq 0 ] && echo "completion: all passed"
exit $((failures != 0))
