#!/bin/sh
# The deterministic outputs of lrr, byte for byte (libsodium's .exp tests): for each
# tests/golden/NAME.args (the arguments, one per line), lrr's exit status, stdout and stderr
# must be exactly tests/golden/NAME.exp:
#     exit: STATUS
#     --- stdout
#     ...
#     --- stderr
#     ...
# In the arguments and the outputs, @GOLDEN@ stands for the tests/golden directory, so no
# absolute path is stored. Covered: --help of the tool and of each command, the usage
# errors (exit 2), `lrr info` of the built-in scenes, `lrr compare` of two fixed CSVs
# (tests/golden/direct.csv, jacobi3.csv). Left out, as not deterministic: outputs with
# times (solve_ms, seconds, direct_light_seconds), --version (the release and the
# features of the build), anything from a hemicube or ray build (threads change the
# rounding order).
# LRR_UPDATE_GOLDEN=1 (make update-golden) rewrites each NAME.exp from the built lrr instead.
. "$(dirname "$0")/harness.sh"

LC_ALL=C # strerror texts in English
export LC_ALL
GOLDEN=$SRCDIR/tests/golden
[ -d "$GOLDEN" ] || fatal "no $GOLDEN (LRR_SRCDIR)"
GOLDEN=$(cd "$GOLDEN" && pwd)
# golden_output: the .exp text of the last run, @GOLDEN@ for the golden directory.
golden_output() {
    printf 'exit: %s\n--- stdout\n' "$rc"
    sed "s|$GOLDEN|@GOLDEN@|g" "$T/out"
    printf '%s\n' '--- stderr'
    sed "s|$GOLDEN|@GOLDEN@|g" "$T/err"
}
cases=0
for args in "$GOLDEN"/*.args; do
    [ -e "$args" ] || fatal "no .args file in $GOLDEN"
    name=$(basename "$args" .args)
    exp="$GOLDEN/$name.exp"
    set --
    while IFS= read -r a || [ -n "$a" ]; do
        set -- "$@" "$(printf '%s\n' "$a" | sed "s|@GOLDEN@|$GOLDEN|g")"
    done <"$args"
    run "$@"
    golden_output >"$T/$name.got"
    cases=$((cases + 1))
    if [ "${LRR_UPDATE_GOLDEN:-0}" != 0 ]; then
        if cmp -s "$T/$name.got" "$exp"; then
            echo "unchanged: $name"
        else
            cp "$T/$name.got" "$exp" && echo "updated: $exp"
        fi
    elif [ ! -f "$exp" ]; then
        fail "$name: no $name.exp (make update-golden writes it)"
    elif cmp -s "$T/$name.got" "$exp"; then
        pass "$name: lrr $* (exit $rc) matches $name.exp"
    else
        fail "$name: lrr $* differs from $name.exp:"
        diff "$exp" "$T/$name.got" | sed 's/^/    /' | head -n 20
    fi
done
[ "$cases" -gt 30 ] && pass "$cases golden cases" || fail "only $cases golden cases in $GOLDEN"
finish
